// End to end, as an engine ships it: the example scene's G-buffer (normals, visibility, roughness, the sun)
// shaded on a Vulkan device (Mesa lavapipe) by a compute pass that includes the GLSL `bake --shader-glsl`
// writes and samples the baked LUT's KTX2 (direct light x the term), compared pixel by pixel with what
// `microshadow scene --lut` reports for the same LUT (scene.exr: the light's weight x its approximation).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <sstream>

#include "cli_runner.hpp"
#include "glslang.hpp"
#include "lut/bitmap_font.hpp"
#include "scene/description.hpp"
#include "scene/image_io.hpp"
#include "scene/inputs.hpp"
#include "test_files.hpp"
#include "vulkan_compute.hpp"

namespace {

using ms::testing::cli;

class SceneRender : public ms::testing::ScratchDirTest {
protected:
    SceneRender() : ScratchDirTest("scene_render") {}
};

TEST_F(SceneRender, GeneratedGlslShadesTheExampleSceneAsTheSceneCommandReports) {
    if (!ms::testing::have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools; scripts/install-deps.sh)";
    const std::string scene_toml = std::string(MICROSHADOW_SOURCE_DIR) + "/examples/scene/scene.toml";
    // A small LUT (8^3, float32) and its shader; the KTX2 holds the EXR's floats.
    for (const std::string& args : {"bake -q --size 8 --samples 4096 --out " + path("lut.exr") + " --shader-glsl " + path("lut.glsl"),
                                    "lut export " + path("lut.exr") + " --out " + path("lut.ktx2") + " --encoding float32",
                                    // The reference's tolerance is irrelevant here (only the LUT's layer is compared): the loosest.
                                    "scene " + scene_toml + " --out " + path("scene") + " --lut " + path("lut.exr") +
                                        " --tolerance 0.5 --method sampled --no-seed-luts -q"}) {
        const auto r = cli(args);
        ASSERT_EQ(r.exit_code, 0) << args << "\n" << r.output;
    }
    const auto planes = ms::scene::read_channels(path("scene/scene.exr"), {"sun.lut-lut", "sun.weight"});
    ASSERT_EQ(planes.size(), 2u);

    // The G-buffer, per pixel as the scene job reads it: (visibility, NdotL, NdotV, roughness) under the sun.
    const ms::scene::SceneInputs inputs = ms::scene::SceneInputs::load(ms::scene::load_scene(scene_toml));
    const auto& lights = inputs.description().lights;
    ASSERT_EQ(lights.size(), 1u);
    const double intensity = lights[0].intensity;
    std::vector<float> gbuffer;
    std::vector<std::size_t> shaded;
    for (std::size_t i = 0; i < inputs.pixels(); ++i) {
        const ms::scene::PixelSurface p = inputs.pixel(i);
        const ms::scene::LightQuery q = ms::scene::light_query(p, lights[0]);
        if (q.status != ms::scene::PixelStatus::shaded) continue;
        shaded.push_back(i);
        gbuffer.insert(gbuffer.end(), {float(p.visibility), float(q.n_dot_l), float(q.n_dot_v), float(p.roughness)});
    }
    ASSERT_GT(shaded.size(), inputs.pixels() / 2);

    // The engine's pass: direct light (max(N.L, 0) x intensity) times the generated lookup.
    std::ostringstream source;
    source << "#version 450\nlayout(local_size_x = 64) in;\n"
              "layout(set = 0, binding = 0) uniform sampler3D u_micro_shadowing;\n"
              "layout(std430, set = 0, binding = 1) readonly buffer GBuffer { vec4 gbuffer[]; };\n"
              "layout(std430, set = 0, binding = 2) writeonly buffer Radiance { float radiance[]; };\n"
           << ms::testing::slurp_file(path("lut.glsl"))
           << "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    vec4 g = gbuffer[i];\n"
              "    float direct = max(g.y, 0.0) * float(" << intensity << ");\n"
              "    radiance[i] = direct * lut_micro_shadowing(u_micro_shadowing, g.x, g.y, g.z, g.w);\n}\n";
    const auto spirv = ms::testing::compile_spirv(source.str(), path("shade.comp"), "");
    ASSERT_FALSE(spirv.empty()) << "the pass did not compile";
    const auto run = ms::testing::run_compute(spirv, ms::testing::ktx2_texture(path("lut.ktx2")), gbuffer, false);
    if (!run.skip.empty()) GTEST_SKIP() << run.skip;
    ASSERT_EQ(run.values.size(), shaded.size());

    // Bound per pixel: the lookup's agreement on float textures (1e-5, measured over the domain by the
    // shader tests: float filtering and coordinate rounding), times the weight (at most the intensity),
    // plus the float roundings of the weight, the stored approximation and the product (2^-24 relative each).
    double worst = 0, worst_ratio = 0;
    std::size_t lit = 0, reported = 0;
    for (std::size_t k = 0; k < shaded.size(); ++k) {
        const std::size_t i = shaded[k];
        const double weight = planes[1].data[i], term = planes[0].data[i];
        const double want = weight * term;
        const double bound = 1e-5 * weight + 3 * std::ldexp(1.0, -24) * std::abs(want) + 1e-30;
        const double d = std::abs(double(run.values[k]) - want);
        worst = std::max(worst, d);
        worst_ratio = std::max(worst_ratio, d / bound);
        if (weight > 0) ++lit;
        if (d > bound && reported++ < 5)
            ADD_FAILURE() << "pixel (" << i % inputs.width() << ", " << i / inputs.width() << "): shader " << run.values[k]
                          << ", scene " << want << " (weight " << weight << ", term " << term << "), bound " << bound;
    }
    EXPECT_GT(lit, shaded.size() / 2);

    // The picture (docs/engine.md): the shader's image, the scene command's, and |difference| x 10^6, side by
    // side under their titles, radiance sRGB-encoded with its grey scale below, unlit pixels blue; written
    // beside the test's files, and into MICROSHADOW_FIGURE_DIR when set.
    const std::uint32_t w = inputs.width(), h = inputs.height();
    const std::int64_t top = 20, scale_top = top + h + 8, bar_height = 12;
    ms::RgbImage picture(3 * w + 8, std::uint32_t(scale_top + bar_height + 40), 255, 255, 255);
    const auto srgb = [](double v) {
        v = std::clamp(v, 0.0, 1.0);
        return std::uint8_t(std::lround(255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055)));
    };
    const char* titles[3] = {"GLSL on lavapipe", "microshadow scene", "abs difference x 1e6"};
    for (int panel = 0; panel < 3; ++panel) {
        const std::int64_t x0 = panel * std::int64_t(w + 4);
        ms::draw_text(picture, x0 + (std::int64_t(w) - ms::text_width(titles[panel], 2)) / 2, 3, titles[panel], 2, 0, 0, 0);
        // Pixels the sun does not light (below a horizon) in blue, so that no panel shows them as a value.
        picture.fill(x0, top, w, h, 40, 60, 120);
    }
    for (std::size_t k = 0; k < shaded.size(); ++k) {
        const std::size_t i = shaded[k];
        const std::int64_t x = std::int64_t(i % w), y = top + std::int64_t(i / w);
        const double want = double(planes[1].data[i]) * planes[0].data[i];
        const std::uint8_t a = srgb(run.values[k]), b = srgb(want), c = srgb(std::abs(run.values[k] - want) * 1e6);
        picture.set(x, y, a, a, a);
        picture.set(x + w + 4, y, b, b, b);
        picture.set(x + 2 * (w + 4), y, c, c, c);
    }
    // The grey scale: radiance 0 to 1 (W/m^2 per unit intensity) as every panel encodes it; the third panel's
    // value is the difference times 10^6.
    const std::int64_t bar_width = 3 * std::int64_t(w) + 8 - 40;
    for (std::int64_t x = 0; x < bar_width; ++x) {
        const std::uint8_t g = srgb(double(x) / double(bar_width - 1));
        picture.fill(20 + x, scale_top, 1, bar_height, g, g, g);
    }
    for (const double tick : {0.0, 0.25, 0.5, 0.75, 1.0}) {
        char label[16];
        std::snprintf(label, sizeof label, "%g", tick);
        const std::int64_t x = 20 + std::int64_t(std::lround(tick * double(bar_width - 1)));
        picture.fill(x, scale_top + bar_height, 1, 4, 0, 0, 0);
        ms::draw_text(picture, x - std::int64_t(ms::text_width(label, 1)) / 2, scale_top + bar_height + 6, label, 1, 0, 0, 0);
    }
    ms::draw_text(picture, 20, scale_top + bar_height + 18,
                  "radiance = max(N.L, 0) x intensity x term, sRGB-encoded, blue: not lit by the sun", 1, 0, 0, 0);
    ms::scene::write_png_rgb(path("render.png"), picture);
    if (const char* figures = std::getenv("MICROSHADOW_FIGURE_DIR"))
        ms::scene::write_png_rgb(std::string(figures) + "/engine-scene-render.png", picture);
    std::cout << "[ figures  ] example scene " << inputs.width() << "x" << inputs.height() << " on " << run.device << ": " << shaded.size()
              << " shaded pixels (" << lit << " lit), max |shader - scene| = " << worst << ", max ratio to the bound = " << worst_ratio << "\n";
}

}  // namespace
