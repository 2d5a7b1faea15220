// Scene descriptions and `microshadow scene`, on generated scenes with known answers.
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>
#include <png.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "cli_runner.hpp"
#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "core/query.hpp"
#include "jobs/eval.hpp"
#include "jobs/compare.hpp"
#include "jobs/scene.hpp"
#include "repr/representation.hpp"
#include "scene/description.hpp"
#include "scene/image_io.hpp"
#include "scene/inputs.hpp"

namespace ms {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDirTest;

// A PNG of `channels` interleaved values in [0, 1], 8 or 16 bits.
void write_png(const std::string& path, int w, int h, int channels, const std::vector<double>& v, int bits = 16) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_TRUE(f);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, f);
    const int type = channels == 1 ? PNG_COLOR_TYPE_GRAY : channels == 3 ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_RGBA;
    png_set_IHDR(png, info, w, h, bits, type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    const int bytes = bits / 8;
    std::vector<png_byte> row(std::size_t(w) * channels * bytes);
    for (int y = 0; y < h; ++y) {
        for (int i = 0; i < w * channels; ++i) {
            const double x = v[std::size_t(y) * w * channels + i];
            const unsigned q = unsigned(std::lround(std::clamp(x, 0.0, 1.0) * (bits == 16 ? 65535 : 255)));
            if (bits == 16) {
                row[2 * i] = png_byte(q >> 8);
                row[2 * i + 1] = png_byte(q & 255);
            } else {
                row[i] = png_byte(q);
            }
        }
        png_write_row(png, row.data());
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
}

struct ExrPart {
    std::string name;  // empty: no name
    std::vector<std::pair<std::string, std::vector<float>>> channels;
};

// A multi-part EXR (one part is a plain single-part file), FLOAT channels.
void write_exr_parts(const std::string& path, int w, int h, const std::vector<ExrPart>& parts) {
    std::vector<Imf::Header> headers;
    for (const auto& p : parts) {
        Imf::Header header(w, h);
        header.setType(Imf::SCANLINEIMAGE);
        if (!p.name.empty() || parts.size() > 1) header.setName(p.name.empty() ? "part" : p.name);
        for (const auto& [name, data] : p.channels) header.channels().insert(name.c_str(), Imf::Channel(Imf::FLOAT));
        headers.push_back(header);
    }
    Imf::MultiPartOutputFile file(path.c_str(), headers.data(), int(headers.size()));
    for (std::size_t i = 0; i < parts.size(); ++i) {
        Imf::OutputPart part(file, int(i));
        Imf::FrameBuffer fb;
        for (const auto& [name, data] : parts[i].channels)
            fb.insert(name.c_str(), Imf::Slice(Imf::FLOAT, (char*)data.data(), sizeof(float), sizeof(float) * w));
        part.setFrameBuffer(fb);
        part.writePixels(h);
    }
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TermBackend& backend() {
    static std::unique_ptr<TermBackend> b = make_opencl_backend(ocl::select_devices("default"));
    return *b;
}

scene::SceneResult run(const std::string& toml, bool skip = true) {
    const scene::SceneDescription d = scene::load_scene(toml);
    const scene::SceneInputs inputs = scene::SceneInputs::load(d);
    scene::SceneRunOptions options;
    options.skip = skip;
    options.bake_seed_luts = false;
    return scene::run_scene(inputs, backend(), options);
}

std::string scene_error(const std::string& toml) {
    try {
        const scene::SceneDescription d = scene::load_scene(toml);
        const scene::SceneInputs inputs = scene::SceneInputs::load(d);
    } catch (const scene::SceneError& e) {
        return e.what();
    }
    return "(no error)";
}

class SceneTest : public ScratchDirTest {
protected:
    SceneTest() : ScratchDirTest("scene") {}
};

TEST_F(SceneTest, VisibilityOneEverywhereGivesExactlyOne) {
    write_png(path("ao.png"), 6, 5, 1, std::vector<double>(30, 1.0), 8);
    write_text(path("s.toml"), R"(
[normal]
value = [0.1, 0.0, 1.0]
[visibility]
file = "ao.png"
[roughness]
value = 0.5
[view]
direction = [0.3, 0.2, 0.9]
[[light]]
direction = [0.5, -0.3, 0.8]
[comparators]
analytic = ["pz-analytic"]
)");
    const auto r = run(path("s.toml"));
    ASSERT_EQ(r.width, 6u);
    ASSERT_EQ(r.height, 5u);
    for (float v : r.lights[0].reference) EXPECT_EQ(v, 1.0f);
    for (float v : r.lights[0].std_error) EXPECT_EQ(v, 0.0f);
    EXPECT_EQ(r.counts.v_one, 30u);
    EXPECT_EQ(r.counts.sampled, 0u);
    EXPECT_DOUBLE_EQ(r.counts.skipped_fraction(), 1.0);
}

TEST_F(SceneTest, ZeroRegionMaskAndHorizonAreExactAndCounted) {
    // Left half v = 0.2 (2 v + NdotL = 0.9 <= 1 for NdotL = 0.5: exactly 0), right half v = 0.8; the
    // bottom row is masked (object index 0), and a second light sits below the horizon.
    const int w = 8, h = 4;
    std::vector<double> ao(w * h), mask(w * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            ao[y * w + x] = x < w / 2 ? 51.0 / 255 : 204.0 / 255;
            mask[y * w + x] = y == h - 1 ? 0 : 1.0 / 255;
        }
    write_png(path("ao.png"), w, h, 1, ao, 8);
    write_png(path("id.png"), w, h, 1, mask, 8);
    write_text(path("s.toml"), R"(
[normal]
value = [0, 0, 1]
[visibility]
file = "ao.png"
[roughness]
value = 0.6
[mask]
file = "id.png"
kind = "object-index"
[view]
direction = [0, 0.3, 1]
[[light]]
name = "key"
direction = [0.8660254037844386, 0, 0.5]
[[light]]
name = "under"
direction = [0.3, 0.2, -0.5]
[sampling]
tolerance = 0.01
)");
    const auto r = run(path("s.toml"));
    ASSERT_EQ(r.lights.size(), 2u);
    for (int y = 0; y < h - 1; ++y)
        for (int x = 0; x < w; ++x) {
            const float v = r.lights[0].reference[y * w + x];
            if (x < w / 2) EXPECT_EQ(v, 0.0f) << x << "," << y;
            else EXPECT_GT(v, 0.0f) << x << "," << y;
            EXPECT_EQ(r.lights[1].reference[y * w + x], 0.0f);
        }
    EXPECT_EQ(r.counts.pixel_lights, 2u * w * h);
    EXPECT_EQ(r.counts.masked, 2u * w);
    EXPECT_EQ(r.counts.zero_region, std::uint64_t(w / 2 * (h - 1)));
    EXPECT_EQ(r.counts.light_below_horizon, std::uint64_t(w * (h - 1)));
    // The 12 right-hand pixels share one query: sampled once, 11 duplicates.
    EXPECT_EQ(r.counts.sampled, 1u);
    EXPECT_EQ(r.counts.duplicates, std::uint64_t(w / 2 * (h - 1) - 1));
    for (float m : std::vector<float>(r.mask.begin(), r.mask.begin() + w * (h - 1))) EXPECT_EQ(m, 1.0f);
    for (float m : std::vector<float>(r.mask.begin() + w * (h - 1), r.mask.end())) EXPECT_EQ(m, 0.0f);
}

TEST_F(SceneTest, ConstantSceneEqualsEvalWithinErrorBars) {
    write_png(path("rough.png"), 5, 4, 1, std::vector<double>(20, 0.6));
    write_text(path("s.toml"), R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.7
[roughness]
file = "rough.png"
[view]
direction = [0.6, 0.0, 0.8]
[[light]]
direction = [-0.3, 0.5, 0.6]
[comparators]
analytic = []
)");
    const auto r = run(path("s.toml"));
    const auto no_skip = run(path("s.toml"), false);
    EXPECT_EQ(r.counts.sampled, 1u);
    EXPECT_EQ(r.counts.duplicates, 19u);
    EXPECT_EQ(no_skip.counts.sampled, 20u);
    // eval of the same query (the scene's frame: normal +z, the world vectors as they are).
    Query q;
    q.visibility = 0.7;
    q.alpha_x = q.alpha_y = 0.6 * 0.6;
    q.wi = {0.6, 0.0, 0.8};
    q.wo = {-0.3, 0.5, 0.6};
    q = normalised(q);
    SamplingPlan plan;
    plan.samples = 1 << 20;
    const Estimate e = evaluate(backend(), {q}, TermOptions{}, plan)[0];
    for (const auto* result : {&r, &no_skip})
        for (std::size_t i = 0; i < 20; ++i) {
            const double ref = result->lights[0].reference[i], se = result->lights[0].std_error[i];
            EXPECT_GT(se, 0);
            EXPECT_LE(result->lights[0].t * se, r.tolerance);
            // Error bars of both, plus the key grid's quantisation (an eighth of the tolerance, see scene.hpp).
            EXPECT_NEAR(ref, e.term, scene::kStudentT999R8 * std::hypot(se, e.std_error) + r.tolerance / 8) << i;
        }
}

TEST_F(SceneTest, TangentSpaceNormalMapEqualsItsWorldSpaceEquivalent) {
    const int w = 12, h = 10;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-0.45, 0.45);
    std::vector<double> tangent_png(w * h * 3), flipped_png(w * h * 3), rough(w * h);
    std::vector<float> wx(w * h), wy(w * h), wz(w * h);
    // The plane's frame: N tilted, T along x.
    const double nlen = std::hypot(0.0, 0.3, 1.0);
    const Vec3 N{0, 0.3 / nlen, 1 / nlen}, T{1, 0, 0};
    const Vec3 B{N.y * T.z - N.z * T.y, N.z * T.x - N.x * T.z, N.x * T.y - N.y * T.x};
    for (int i = 0; i < w * h; ++i) {
        const double x = u(rng), y = u(rng), z = std::sqrt(1 - x * x - y * y);
        // What the file holds (16-bit) and what reading it gives back.
        for (int c = 0; c < 3; ++c) tangent_png[i * 3 + c] = std::round((0.5 * (c == 0 ? x : c == 1 ? y : z) + 0.5) * 65535) / 65535;
        flipped_png[i * 3 + 0] = tangent_png[i * 3 + 0];
        flipped_png[i * 3 + 1] = 1 - tangent_png[i * 3 + 1];
        flipped_png[i * 3 + 2] = tangent_png[i * 3 + 2];
        const double nx = 2 * tangent_png[i * 3] - 1, ny = 2 * tangent_png[i * 3 + 1] - 1, nz = 2 * tangent_png[i * 3 + 2] - 1;
        wx[i] = float(T.x * nx + B.x * ny + N.x * nz);
        wy[i] = float(T.y * nx + B.y * ny + N.y * nz);
        wz[i] = float(T.z * nx + B.z * ny + N.z * nz);
        rough[i] = 0.3 + 0.6 * (i % 7) / 6.0;
    }
    write_png(path("tangent.png"), w, h, 3, tangent_png);
    write_png(path("directx.png"), w, h, 3, flipped_png);
    write_png(path("rough.png"), w, h, 1, rough);
    write_exr_parts(path("world.exr"), w, h, {{"", {{"N.X", wx}, {"N.Y", wy}, {"N.Z", wz}}}});
    const std::string common = R"(
[visibility]
value = 0.75
[roughness]
file = "rough.png"
[surface]
normal = [0, 0.3, 1]
tangent = [1, 0, 0]
[view]
direction = [0.2, -0.5, 0.8]
[[light]]
direction = [0.7, 0.4, 0.45]
[comparators]
analytic = ["pz-analytic", "naughty-dog"]
[sampling]
tolerance = 0.005
)";
    write_text(path("tangent.toml"), "[normal]\nfile = \"tangent.png\"\nspace = \"tangent\"\n" + common);
    write_text(path("directx.toml"), "[normal]\nfile = \"directx.png\"\nspace = \"tangent\"\ngreen = \"-Y\"\n" + common);
    write_text(path("world.toml"), "[normal]\nfile = \"world.exr\"\nchannels = [\"N.X\", \"N.Y\", \"N.Z\"]\n" + common);
    const auto a = run(path("tangent.toml")), b = run(path("world.toml")), c = run(path("directx.toml"));
    double max_diff = 0;
    for (int i = 0; i < w * h; ++i) {
        EXPECT_EQ(a.lights[0].reference[i], c.lights[0].reference[i]) << i;  // -Y: the same numbers
        max_diff = std::max(max_diff, std::fabs(double(a.lights[0].reference[i]) - b.lights[0].reference[i]));
        for (std::size_t k = 0; k < a.comparators.size(); ++k)
            EXPECT_NEAR(a.lights[0].approximation[k][i], b.lights[0].approximation[k][i], 1e-5);
        EXPECT_NEAR(a.lights[0].weight[i], b.lights[0].weight[i], 1e-6);
    }
    // World normals stored as float: the same keys but for the odd one on a grid boundary (an eighth of
    // the tolerance apart at most).
    EXPECT_LE(max_diff, a.tolerance / 8);
}

TEST_F(SceneTest, MultiPartExrWithForeignChannelNamesIsReadThroughTheDescription) {
    const int w = 7, h = 3;
    std::vector<float> nx(w * h, 0.0f), ny(w * h, 0.0f), nz(w * h, 1.0f), ao(w * h), r(w * h, 0.5f), other(w * h, 9.0f);
    for (int i = 0; i < w * h; ++i) ao[i] = float((20000 + 1500 * i) / 65535.0);
    write_exr_parts(path("render.exr"), w, h,
                    {{"ViewLayer", {{"ViewLayer.Normal.X", nx}, {"ViewLayer.Normal.Y", ny}, {"ViewLayer.Normal.Z", nz},
                                    {"ViewLayer.AO.R", ao}, {"A", other}}},
                     {"aovs", {{"roughness", r}, {"A", other}}}});
    const auto names = scene::list_channels(path("render.exr"));
    EXPECT_NE(std::find(names.begin(), names.end(), "aovs.roughness"), names.end());
    // The same scene from a 16-bit PNG holding the same AO values: the same queries, the same bits.
    std::vector<double> ao_png(ao.begin(), ao.end());
    write_png(path("ao.png"), w, h, 1, ao_png);
    const std::string rest = R"(
[view]
direction = [0.1, 0.4, 0.9]
[[light]]
direction = [0.5, 0.1, 0.5]
[comparators]
analytic = ["activision"]
[sampling]
tolerance = 0.005
)";
    write_text(path("exr.toml"), R"(
[normal]
file = "render.exr"
channels = ["ViewLayer.Normal.X", "ViewLayer.Normal.Y", "ViewLayer.Normal.Z"]
[visibility]
file = "render.exr"
channel = "ViewLayer.AO.R"
[roughness]
file = "render.exr"
channel = "aovs.roughness"
)" + rest);
    write_text(path("png.toml"), R"(
[normal]
value = [0, 0, 1]
[visibility]
file = "ao.png"
[roughness]
value = 0.5
)" + rest);
    const auto a = run(path("exr.toml")), b = run(path("png.toml"));
    for (int i = 0; i < w * h; ++i) {
        EXPECT_EQ(a.lights[0].reference[i], b.lights[0].reference[i]) << i;
        EXPECT_GT(a.lights[0].reference[i], 0.0f);
    }
    // "A" is in both parts: ambiguous unless the part is named.
    write_text(path("ambiguous.toml"), R"(
[normal]
value = [0, 0, 1]
[visibility]
file = "render.exr"
channel = "A"
[roughness]
value = 0.5
)" + rest);
    const std::string e = scene_error(path("ambiguous.toml"));
    EXPECT_NE(e.find("render.exr"), std::string::npos) << e;
    EXPECT_NE(e.find("'A' is in several parts"), std::string::npos) << e;
}

TEST_F(SceneTest, BadInputNamesFileChannelAndPixel) {
    const int w = 4, h = 3;
    std::vector<float> nx(w * h, 0.0f), ny(w * h, 0.0f), nz(w * h, 1.0f), ao(w * h, 0.5f);
    const std::string rest = "[roughness]\nvalue = 0.5\n[view]\ndirection = [0, 0, 1]\n[[light]]\ndirection = [0, 0, 1]\n";
    const std::string normal = "[normal]\nfile = \"n.exr\"\nchannels = [\"nx\", \"ny\", \"nz\"]\n";
    auto check = [&](const std::string& toml, const std::vector<std::string>& expected) {
        write_text(path("s.toml"), toml);
        const std::string e = scene_error(path("s.toml"));
        for (const auto& x : expected) EXPECT_NE(e.find(x), std::string::npos) << "'" << x << "' not in: " << e;
    };
    // NaN in a normal.
    nx[1 * w + 2] = std::numeric_limits<float>::quiet_NaN();
    write_exr_parts(path("n.exr"), w, h, {{"", {{"nx", nx}, {"ny", ny}, {"nz", nz}, {"ao", ao}}}});
    check(normal + "[visibility]\nvalue = 1\n" + rest, {"n.exr", "channel 'nx'", "pixel (2, 1)", "not a finite number"});
    // A zero normal.
    nx[1 * w + 2] = 0;
    nz[2 * w + 3] = 0;
    write_exr_parts(path("n.exr"), w, h, {{"", {{"nx", nx}, {"ny", ny}, {"nz", nz}, {"ao", ao}}}});
    check(normal + "[visibility]\nvalue = 1\n" + rest, {"n.exr", "'nx', 'ny', 'nz'", "pixel (3, 2)", "zero-length normal"});
    // AO outside [0, 1].
    nz[2 * w + 3] = 1;
    ao[0 * w + 1] = 1.25f;
    write_exr_parts(path("n.exr"), w, h, {{"", {{"nx", nx}, {"ny", ny}, {"nz", nz}, {"ao", ao}}}});
    check(normal + "[visibility]\nfile = \"n.exr\"\nchannel = \"ao\"\n" + rest, {"n.exr", "channel 'ao'", "pixel (1, 0)", "outside [0, 1]"});
    // A missing channel, with the names the file has.
    check(normal + "[visibility]\nfile = \"n.exr\"\nchannel = \"AO.R\"\n" + rest, {"n.exr", "channel 'AO.R' not found", "nx, ny, nz"});
    // Sizes that differ.
    write_png(path("small.png"), 2, 2, 1, {0.5, 0.5, 0.5, 0.5});
    check(normal + "[visibility]\nfile = \"small.png\"\n" + rest, {"small.png", "2 x 2", "4 x 3", "n.exr"});
    // An unknown key.
    check(normal + "colour = \"red\"\n[visibility]\nvalue = 1\n" + rest, {"s.toml", "normal.colour", "unknown key"});
}

TEST_F(SceneTest, DeduplicationChangesTheImageByMuchLessThanTheTolerance) {
    // Varied inputs (roughness 0.1 - 1, AO 0.3 - 1, normals within about 40 degrees), one plan for every
    // query (min = max samples) so both runs use the same points: the difference is the key grid's alone.
    const int w = 24, h = 24;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<double> normal(w * h * 3), ao(w * h), rough(w * h);
    for (int i = 0; i < w * h; ++i) {
        const double x = 0.6 * (u(rng) - 0.5), y = 0.6 * (u(rng) - 0.5), z = std::sqrt(1 - x * x - y * y);
        normal[3 * i] = 0.5 * x + 0.5;
        normal[3 * i + 1] = 0.5 * y + 0.5;
        normal[3 * i + 2] = 0.5 * z + 0.5;
        ao[i] = 0.3 + 0.7 * u(rng);
        rough[i] = 0.1 + 0.9 * (i % 10) / 9.0;
    }
    // Half the pixels repeat the first 8 columns: duplicates within the grid.
    for (int y = 0; y < h; ++y)
        for (int x = 16; x < w; ++x) {
            const int from = y * w + (x - 16), to = y * w + x;
            for (int c = 0; c < 3; ++c) normal[3 * to + c] = normal[3 * from + c];
            ao[to] = ao[from];
            rough[to] = rough[from];
        }
    write_png(path("n.png"), w, h, 3, normal);
    write_png(path("ao.png"), w, h, 1, ao);
    write_png(path("r.png"), w, h, 1, rough);
    write_text(path("s.toml"), R"(
[normal]
file = "n.png"
space = "tangent"
[visibility]
file = "ao.png"
[roughness]
file = "r.png"
[view]
direction = [0.3, -0.4, 0.85]
[[light]]
direction = [0.8, 0.2, 0.45]
[comparators]
analytic = []
[sampling]
tolerance = 0.002
min_samples = 65536
max_samples = 65536
)");
    const auto a = run(path("s.toml")), b = run(path("s.toml"), false);
    double max_diff = 0, sum_sq = 0;
    for (int i = 0; i < w * h; ++i) {
        const double d = double(a.lights[0].reference[i]) - b.lights[0].reference[i];
        max_diff = std::max(max_diff, std::fabs(d));
        sum_sq += d * d;
    }
    std::printf("dedup vs none: max |diff| %.3g, RMS %.3g (tolerance %.3g); duplicates %llu of %d\n", max_diff,
                std::sqrt(sum_sq / (w * h)), a.tolerance, (unsigned long long)a.counts.duplicates, w * h);
    EXPECT_LE(max_diff, a.tolerance / 4);
    EXPECT_GE(a.counts.duplicates, std::uint64_t(8 * h - 8));  // the repeated columns (less any in the zero region)
    EXPECT_GT(a.counts.skipped_fraction(), b.counts.skipped_fraction());
}

TEST_F(SceneTest, DistantPointLightMatchesDirectionalAndAnisotropyFollowsTheTangent) {
    write_png(path("rough.png"), 4, 4, 1, std::vector<double>(16, 0.5));
    const std::string common = R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.8
[roughness]
file = "rough.png"
[view]
direction = [0.5, 0.1, 0.8]
[comparators]
analytic = []
[sampling]
tolerance = 0.005
)";
    write_text(path("dir.toml"), common + "[[light]]\ndirection = [0.4, -0.6, 0.5]\nintensity = 2\n");
    write_text(path("point.toml"), common + "[[light]]\ntype = \"point\"\nposition = [4e5, -6e5, 5e5]\nintensity = 1.54e12\n");
    const auto a = run(path("dir.toml")), b = run(path("point.toml"));
    for (int i = 0; i < 16; ++i) {
        EXPECT_NEAR(a.lights[0].reference[i], b.lights[0].reference[i], a.tolerance / 8) << i;
        EXPECT_NEAR(a.lights[0].weight[i], b.lights[0].weight[i], 1e-3 * a.lights[0].weight[i]) << i;
    }
    // Anisotropic: alpha_x = 0.25 (1 + 0.6) along the tangent (world y here), alpha_y = 0.25 (1 - 0.6).
    write_text(path("aniso.toml"), common + "[anisotropy]\nvalue = 0.6\n[tangent]\nvalue = [0, 1, 0]\n[[light]]\ndirection = [0.4, -0.6, 0.5]\n");
    const auto c = run(path("aniso.toml"));
    Query q;
    q.visibility = 0.8;
    q.alpha_x = 0.25 * 1.6;
    q.alpha_y = 0.25 * 0.4;
    // Frame: x = tangent = world y, y = z x x = -world x, z = normal.
    q.wi = {0.1, -0.5, 0.8};
    q.wo = {-0.6, -0.4, 0.5};
    q = normalised(q);
    SamplingPlan plan;
    plan.samples = 1 << 20;
    const Estimate e = evaluate(backend(), {q}, TermOptions{}, plan)[0];
    for (int i = 0; i < 16; ++i)
        EXPECT_NEAR(c.lights[0].reference[i], e.term,
                    scene::kStudentT999R8 * std::hypot(c.lights[0].std_error[i], e.std_error) + c.tolerance / 8);
    // The same surface turned by 90 degrees in its plane is a different surface: the term moves.
    write_text(path("aniso90.toml"), common + "[anisotropy]\nvalue = 0.6\n[tangent]\nvalue = [1, 0, 0]\n[[light]]\ndirection = [0.4, -0.6, 0.5]\n");
    const auto d = run(path("aniso90.toml"));
    EXPECT_GT(std::fabs(double(c.lights[0].reference[0]) - d.lights[0].reference[0]), 4 * c.tolerance);
}

TEST_F(SceneTest, PositionPassViewAndPerMaterialStatistics) {
    // A position pass with a far camera equals one view direction; statistics per material follow the
    // material index (8-bit PNG indices read as stored integers).
    const int w = 6, h = 4;
    std::vector<float> px(w * h), py(w * h), pz(w * h, 0.0f);
    std::vector<double> material(w * h), rough(w * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            px[y * w + x] = float((x + 0.5) / w);
            py[y * w + x] = float(1 - (y + 0.5) / h);
            material[y * w + x] = (x < 2 ? 1 : 2) / 255.0;
            rough[y * w + x] = x < 2 ? 0.3 : 0.8;
        }
    write_exr_parts(path("p.exr"), w, h, {{"", {{"P.X", px}, {"P.Y", py}, {"P.Z", pz}}}});
    write_png(path("m.png"), w, h, 1, material, 8);
    write_png(path("r.png"), w, h, 1, rough);
    const std::string common = R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.7
[roughness]
file = "r.png"
[material]
file = "m.png"
names = ["none", "plaster", "metal"]
[[light]]
direction = [0.3, 0.4, 0.6]
[comparators]
analytic = ["pz-analytic"]
[sampling]
tolerance = 0.005
)";
    write_text(path("dir.toml"), common + "[view]\ndirection = [0.2, -0.5, 0.8]\n");
    write_text(path("pos.toml"), common + "[view]\nposition = \"p.exr\"\nposition_channels = [\"P.X\", \"P.Y\", \"P.Z\"]\n"
                                          "camera = [2e6, -5e6, 8e6]\n");
    const auto a = run(path("dir.toml")), b = run(path("pos.toml"));
    for (int i = 0; i < w * h; ++i) EXPECT_NEAR(a.lights[0].reference[i], b.lights[0].reference[i], a.tolerance / 8) << i;
    ASSERT_EQ(a.groups.size(), 7u);  // all, 4 roughness bands, 2 materials
    EXPECT_EQ(a.groups[5], "material plaster");
    EXPECT_EQ(a.groups[6], "material metal");
    EXPECT_EQ(a.lights[0].stats[0][5].count, std::uint64_t(2 * h));
    EXPECT_EQ(a.lights[0].stats[0][6].count, std::uint64_t(4 * h));
    EXPECT_EQ(a.lights[0].stats[0][0].count, std::uint64_t(w * h));
}

TEST_F(SceneTest, ViewVectorsAndMaskKinds) {
    const int w = 4, h = 2;
    std::vector<float> vx(w * h, 0.2f), vy(w * h, -0.5f), vz(w * h, 0.8f), alpha(w * h), depth(w * h), rough(w * h, 0.5f);
    for (int i = 0; i < w * h; ++i) {
        alpha[i] = i % 2 ? 0.9f : 0.1f;                                   // shaded at odd pixels (threshold 0.5)
        depth[i] = i < 3 ? std::numeric_limits<float>::infinity() : 2.0f;  // background: infinite depth
    }
    alpha[0] = std::numeric_limits<float>::quiet_NaN();
    write_exr_parts(path("v.exr"), w, h, {{"", {{"V.x", vx}, {"V.y", vy}, {"V.z", vz}, {"alpha", alpha}, {"depth", depth}, {"rough", rough}}}});
    const std::string common = R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.7
[roughness]
file = "v.exr"
channel = "rough"
[[light]]
direction = [0.3, 0.4, 0.6]
[comparators]
analytic = []
[sampling]
tolerance = 0.005
)";
    write_text(path("dir.toml"), common + "[view]\ndirection = [0.2, -0.5, 0.8]\n");
    write_text(path("vec.toml"), common + "[view]\nfile = \"v.exr\"\nchannels = [\"V.x\", \"V.y\", \"V.z\"]\n");
    const auto a = run(path("dir.toml")), b = run(path("vec.toml"));
    for (int i = 0; i < w * h; ++i) EXPECT_EQ(a.lights[0].reference[i], b.lights[0].reference[i]) << i;
    // A NaN in the mask itself is an error naming it; a finite alpha mask selects by threshold.
    write_text(path("alpha.toml"), common + "[view]\ndirection = [0.2, -0.5, 0.8]\n[mask]\nfile = \"v.exr\"\nchannel = \"alpha\"\n");
    EXPECT_NE(scene_error(path("alpha.toml")).find("channel 'alpha': pixel (0, 0): NaN in the mask"), std::string::npos) << scene_error(path("alpha.toml"));
    alpha[0] = 0.0f;
    write_exr_parts(path("v.exr"), w, h, {{"", {{"V.x", vx}, {"V.y", vy}, {"V.z", vz}, {"alpha", alpha}, {"depth", depth}, {"rough", rough}}}});
    const auto c = run(path("alpha.toml"));
    for (int i = 0; i < w * h; ++i) EXPECT_EQ(c.mask[i], i % 2 ? 1.0f : 0.0f) << i;
    EXPECT_EQ(c.counts.masked, 4u);
    // Background: shaded where the channel differs from `background` (infinite depth here).
    write_text(path("bg.toml"), common + "[view]\ndirection = [0.2, -0.5, 0.8]\n[mask]\nfile = \"v.exr\"\nchannel = \"depth\"\n"
                                         "kind = \"background\"\nbackground = inf\n");
    const auto d = run(path("bg.toml"));
    for (int i = 0; i < w * h; ++i) EXPECT_EQ(d.mask[i], i < 3 ? 0.0f : 1.0f) << i;
}

TEST_F(SceneTest, KeyGridRoundTrips) {
    // The query at a key's grid point has the same key (the grid is a fixed point of its own rounding).
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 2000; ++k) {
        Query q;
        q.visibility = 0.05 + 0.9 * u(rng);
        q.alpha_x = 0.01 + 0.99 * u(rng);
        q.alpha_y = k % 2 ? q.alpha_x : 0.01 + 0.99 * u(rng);
        const double tv = 1.5 * u(rng), tl = 1.5 * u(rng), pv = 6 * u(rng), pl = 6 * u(rng);
        q.wi = {std::sin(tv) * std::cos(pv), std::sin(tv) * std::sin(pv), std::cos(tv)};
        q.wo = {std::sin(tl) * std::cos(pl), std::sin(tl) * std::sin(pl), std::cos(tl)};
        const double step = 0.125 * 2e-3;
        const scene::DedupKey key = scene::dedup_key(q, AoWeighting::cosine, step);
        const Query g = scene::dedup_query(key, AoWeighting::cosine, step);
        EXPECT_TRUE(scene::dedup_key(g, AoWeighting::cosine, step) == key) << k;
        // The grid point is within half a step of the query in every parameter.
        const double s = step * std::sqrt(g.alpha_x * g.alpha_y);
        EXPECT_LE(std::fabs(std::log(g.alpha_x / q.alpha_x)), step / 2 + 1e-12);
        EXPECT_LE(std::fabs(std::acos(g.wi.z) - std::acos(q.wi.z)), s / 2 + 1e-9);
        EXPECT_LE(std::fabs(std::acos(g.wo.z) - std::acos(q.wo.z)), s / 2 + 1e-9);
        EXPECT_LE(std::fabs(std::acos(std::sqrt(1 - g.visibility)) - std::acos(std::sqrt(1 - q.visibility))), s / 2 + 1e-9);
    }
}

TEST_F(SceneTest, CommandLineWritesEverythingOrNothing) {
    const std::string cli = MICROSHADOW_CLI;
    const std::string example = std::string(MICROSHADOW_SOURCE_DIR) + "/examples/scene/scene.toml";
    // Bad input: exit 2, the message names the key, the output folder is not even created.
    write_text(path("bad.toml"), "[normal]\nvalue = [0, 0, 1]\nspin = 1\n");
    auto r = testing::run_shell(cli + " scene " + path("bad.toml") + " --out " + path("out") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("normal.spin: unknown key"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(path("out")));
    // An --out that is a file: refused before any work.
    write_text(path("file"), "x");
    r = testing::run_shell(cli + " scene " + example + " --out " + path("file") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("is not a folder"), std::string::npos) << r.output;
    // The example scene, quickly (a loose tolerance, no LUT bakes).
    r = testing::run_shell(cli + " scene " + example + " --out " + path("out") + " --tolerance 0.02 --no-seed-luts --quiet 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const char* f : {"scene.exr", "report.json", "report.md", "sun_reference.png", "sun_errors.png", "sun_pz-analytic.png"})
        EXPECT_TRUE(fs::exists(path("out/") + f)) << f;
    std::ifstream in(path("out/report.json"));
    const auto j = nlohmann::json::parse(in);
    EXPECT_EQ(j["work"]["pixel_lights"].get<std::uint64_t>(), 256u * 256u);
    EXPECT_GT(j["work"]["skipped_fraction"].get<double>(), 0.0);
    const auto layers = scene::list_channels(path("out/scene.exr"));
    EXPECT_NE(std::find(layers.begin(), layers.end(), "sun.reference"), layers.end());
    EXPECT_NE(std::find(layers.begin(), layers.end(), "sun.pz-analytic_error"), layers.end());
}

}  // namespace
}  // namespace ms

namespace ms {
namespace {

// Representations on scenes: a representation that keeps the azimuth is a scene comparator like a LUT file,
// and reads each pixel's relative azimuth: two lights at the same NdotL on opposite sides of the view
// give the values the representation's own lookup gives at azimuths 0 and 180 degrees.
TEST_F(SceneTest, RepresentationComparatorReadsEachPixelsAzimuth) {
    const auto bake = testing::run_shell(std::string(MICROSHADOW_CLI) +
                                         " repr bake -q --kind azimuth-harmonics --visibility-count 4 --n-dot-l-count 4"
                                         " --n-dot-v-count 4 --azimuth-nodes 7 --roughness 0.4,0.8 --samples 1024 --out " +
                                         path("harm.exr") + " 2>&1");
    ASSERT_EQ(bake.exit_code, 0) << bake.output;
    write_png(path("rough.png"), 3, 2, 1, std::vector<double>(6, 0.6));
    write_text(path("s.toml"), R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.75
[roughness]
file = "rough.png"
[view]
direction = [0.6, 0.0, 0.8]
[[light]]
name = "same-side"
direction = [0.6, 0.0, 0.8]
[[light]]
name = "opposite"
direction = [-0.6, 0.0, 0.8]
[comparators]
analytic = []
)");
    const scene::SceneDescription d = scene::load_scene(path("s.toml"));
    const scene::SceneInputs inputs = scene::SceneInputs::load(d);
    scene::SceneRunOptions options;
    options.bake_seed_luts = false;
    options.luts = {path("harm.exr")};
    const scene::SceneResult r = scene::run_scene(inputs, backend(), options);
    ASSERT_EQ(r.comparators.size(), 1u);
    EXPECT_EQ(r.comparators[0], "repr-harm");
    const compare::Comparator c = compare::Comparator::open_file("harm", path("harm.exr"));
    ASSERT_TRUE(c.is_representation());
    approx::Inputs in;
    in.visibility = 0.75;
    in.n_dot_l = 0.8;
    in.n_dot_v = 0.8;
    in.roughness = 0.6;
    const double pi = 3.14159265358979323846;
    for (std::size_t light = 0; light < 2; ++light) {
        in.relative_azimuth = light == 0 ? 0.0 : pi;
        const double expected = c(in);
        for (float v : r.lights[light].approximation[0]) EXPECT_NEAR(v, expected, 1e-6) << "light " << light;
    }
    // The azimuth matters here: the two lights differ by far more than the storage's rounding.
    EXPECT_GT(std::fabs(r.lights[0].approximation[0][0] - r.lights[1].approximation[0][0]), 0.01);
}

// A comparator file's domain in a scene: lit pixels outside it are counted per comparator (report.json
// "comparator_domains"), and --strict-domain refuses the scene before any sampling.
TEST_F(SceneTest, LookupsOutsideAComparatorsDomainAreCountedAndStrictRefusesThem) {
    const auto bake = testing::run_shell(std::string(MICROSHADOW_CLI) +
                                         " repr bake -q --kind azimuth-harmonics --visibility-count 2 --n-dot-l-count 2"
                                         " --n-dot-v-count 2 --azimuth-nodes 7 --roughness 0.4,0.8 --out " + path("harm.exr") + " 2>&1");
    ASSERT_EQ(bake.exit_code, 0) << bake.output;
    // Two of six pixels at roughness 0.2, below the file's 0.4.
    write_png(path("rough.png"), 3, 2, 1, {0.2, 0.6, 0.6, 0.6, 0.6, 0.2});
    write_text(path("s.toml"), R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.75
[roughness]
file = "rough.png"
[view]
direction = [0.6, 0.0, 0.8]
[[light]]
name = "sun"
direction = [0.6, 0.0, 0.8]
[comparators]
analytic = ["naughty-dog"]
)");
    const scene::SceneDescription d = scene::load_scene(path("s.toml"));
    const scene::SceneInputs inputs = scene::SceneInputs::load(d);
    scene::SceneRunOptions options;
    options.bake_seed_luts = false;
    options.luts = {path("harm.exr")};
    const scene::SceneResult r = scene::run_scene(inputs, backend(), options);
    ASSERT_EQ(r.comparators.size(), 2u);
    EXPECT_FALSE(r.domains[0].has_value()) << "part 1's formula answers everywhere";
    ASSERT_TRUE(r.domains[1].has_value());
    EXPECT_EQ(r.outside_domain[1].lookups, 6u);
    // The PNG's 16-bit roughness 0.2 is outside [0.4, 0.8]; 0.6 inside.
    EXPECT_EQ(r.outside_domain[1].outside, 2u);
    EXPECT_NE(r.first_outside[1].find("pixel (0, 0): roughness"), std::string::npos) << r.first_outside[1];
    const nlohmann::json report = scene::scene_report(r);
    EXPECT_EQ(report["comparator_domains"]["repr-harm"]["outside_domain"], 2);

    options.strict_domain = true;
    try {
        scene::run_scene(inputs, backend(), options);
        ADD_FAILURE() << "a strict scene outside the domain ran";
    } catch (const scene::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("--strict-domain: comparator repr-harm: 2 of 6 lookups"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace ms

#include "exact/exact_term.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "jobs/area.hpp"

namespace ms {
namespace {

// Area lights in scenes: a flat 4 x 4 texture set (pixel (x, y) at ((x + 0.5) / 4, 1 - (y + 0.5) / 4, 0),
// normal +z) under a sphere and a rectangle light, against the area integrand run on each pixel's own
// query, known answers, and the description's checks.
const char* kAreaScene = R"(
[normal]
value = [0, 0, 1]
[visibility]
value = 0.6
[roughness]
file = "rough.png"
[view]
direction = [0.3, 0.1, 0.9]
[comparators]
analytic = ["pz-analytic"]
[sampling]
area_tolerance = 0.01
)";

Vec3 pixel_position(int x, int y) { return {(x + 0.5) / 4, 1 - (y + 0.5) / 4, 0}; }

TEST_F(SceneTest, AreaLightsMatchTheAreaIntegrandPerPixel) {
    write_png(path("rough.png"), 4, 4, 1, std::vector<double>(16, 0.5));
    write_text(path("s.toml"), std::string(kAreaScene) + R"(
[[light]]
name = "bulb"
type = "sphere"
position = [0.5, 0.2, 1.5]
radius = 0.4
lobe = "ggx"
intensity = 3
[[light]]
name = "panel"
type = "rect"
corners = [[-0.3, 1.2, 1.0], [1.3, 1.2, 1.0], [1.3, 1.2, 2.0], [-0.3, 1.2, 2.0]]
intensity = 2
[[light]]
name = "under"
type = "sphere"
position = [0.5, 0.5, -2]
radius = 0.5
)");
    const auto r = run(path("s.toml"));
    ASSERT_EQ(r.lights.size(), 3u);
    ASSERT_EQ(r.comparators, (std::vector<std::string>{"pz-analytic", "centre-exact", "taps-exact"}));
    // Each pixel's own query, in world axes (normal +z; the surface is isotropic, so the frame's azimuth
    // does not matter), by the exact inner term on the host with another seed.
    std::vector<area::AreaQuery> queries;
    const Vec3 view = normalised(Query{0.5, 0.25, 0.25, {0.3, 0.1, 0.9}, {0, 0, 1}}).wi;
    for (int light = 0; light < 2; ++light)
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 4; ++x) {
                const Vec3 p = pixel_position(x, y);
                area::AreaQuery q;
                q.visibility = 0.6;
                q.alpha_x = q.alpha_y = 0.25;
                q.wi = view;
                if (light == 0) {
                    q.lobe = area::Lobe::ggx;
                    q.light.shape = area::LightShape::sphere;
                    const Vec3 c{0.5 - p.x, 0.2 - p.y, 1.5};
                    q.light.sphere.centre = c;
                    q.light.sphere.half_angle = std::asin(0.4 / std::hypot(c.x, c.y, c.z));
                } else {
                    q.lobe = area::Lobe::lambert;
                    q.light.shape = area::LightShape::rect;
                    const double corners[4][3] = {{-0.3, 1.2, 1.0}, {1.3, 1.2, 1.0}, {1.3, 1.2, 2.0}, {-0.3, 1.2, 2.0}};
                    for (int k = 0; k < 4; ++k) q.light.rect.corners[k] = {corners[k][0] - p.x, corners[k][1] - p.y, corners[k][2]};
                }
                queries.push_back(q);
            }
    area::AreaRoutineConfig config;
    config.inner_term = area::exact_inner_term(AoWeighting::cosine, 1e-6);
    SamplingPlan plan;
    plan.samples = 8 * 512;
    plan.replicates = 8;
    plan.seed = 99;
    const auto expected = area::evaluate_area(*make_oracle_backend(), queries, {}, plan, config);
    // Bonferroni over the 32 pixels: each side's own Student t (16 and 8 replicates) at 1 - 0.001 / 64; the
    // scene's std_error layer already holds its inner bound (t x std_error is the pixel's bound).
    const double t_scene = student_t_quantile(1 - 0.001 / 64, 15), t_ref = student_t_quantile(1 - 0.001 / 64, 7);
    for (int light = 0; light < 2; ++light) {
        const auto& li = r.lights[std::size_t(light)];
        for (int i = 0; i < 16; ++i) {
            const area::AreaEstimate& e = expected[std::size_t(light * 16 + i)];
            EXPECT_NEAR(li.reference[i], e.term.term, t_scene * li.std_error[i] + t_ref * e.term.std_error + e.inner_error)
                << li.light << " pixel " << i;
            EXPECT_LE(li.t * li.std_error[i], 0.01 * (1 + 1e-6)) << li.light << " pixel " << i;  // the area tolerance
            // The weight: intensity x Int f cos, estimated by both runs (the scene's with >= 2048 light samples,
            // half of the reference's: at most sqrt(2) times its standard error at the Monte Carlo rate, so
            // 3 x covers both).
            const double intensity = light == 0 ? 3 : 2;
            EXPECT_NEAR(li.weight[i], intensity * e.lobe_integral.term, t_ref * 3 * intensity * e.lobe_integral.std_error + 1e-6)
                << li.light << " pixel " << i;
        }
    }
    // The panel's Lambert weight in closed form: radiance x (1/pi) Int cos dw = radiance x (1 / 2 pi)
    // Sum_edges theta_k |z . unit(v_k x v_k+1)| (Lambert's polygon formula; the panel is above the horizon).
    for (int i = 0; i < 16; ++i) {
        const auto& k = queries[std::size_t(16 + i)].light.rect.corners;
        double sum = 0;
        for (int e = 0; e < 4; ++e) {
            const Vec3 a = k[e], b = k[(e + 1) % 4];
            const Vec3 n{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
            const double theta = std::atan2(std::hypot(n.x, n.y, n.z), a.x * b.x + a.y * b.y + a.z * b.z);
            sum += theta * n.z / std::hypot(n.x, n.y, n.z);
        }
        const double closed = 2 * std::fabs(sum) / (2 * M_PI);
        EXPECT_NEAR(r.lights[1].weight[i], closed, t_ref * 3 * 2 * expected[std::size_t(16 + i)].lobe_integral.std_error + 1e-6) << i;
    }
    // Below the horizon: exactly 0, weight 0, counted.
    for (int i = 0; i < 16; ++i) {
        EXPECT_EQ(r.lights[2].reference[i], 0.0f);
        EXPECT_EQ(r.lights[2].weight[i], 0.0f);
    }
    EXPECT_EQ(r.counts.light_below_horizon, 16u);
    // The centre comparators: a point lookup where the light is (its centre), which the taps beat on the
    // 0.4-radius bulb (half-angles 14 - 16 degrees) in RMS.
    const auto& bulb = r.lights[0].stats;
    EXPECT_LT(bulb[2][0].term_rms, bulb[1][0].term_rms);
}

TEST_F(SceneTest, ATinySphereLightIsItsCentresPointTerm) {
    // Radius 1e-4 at distance ~5: T_area is a weighted mean of T over the light, within slope x radius of
    // the centre's term (slope <= 2 C / alpha, C <= 2 as measured for the key grid, jobs/scene.hpp).
    write_png(path("rough.png"), 4, 4, 1, std::vector<double>(16, 0.5));
    write_text(path("s.toml"), std::string(kAreaScene) + R"(
[[light]]
name = "tiny"
type = "sphere"
position = [3, 1, 4]
radius = 1e-4
)");
    const auto r = run(path("s.toml"));
    const auto& li = r.lights[0];
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            const int i = y * 4 + x;
            const Vec3 p = pixel_position(x, y);
            Query q{0.6, 0.25, 0.25, {0.3, 0.1, 0.9}, {3 - p.x, 1 - p.y, 4}};
            q = normalised(q);
            const double gamma = std::asin(1e-4 / std::hypot(3 - p.x, 1 - p.y, 4.0));
            const exact::ExactValue point = exact::exact_term(q, AoWeighting::cosine, 1e-10);
            const double bound = student_t_quantile(1 - 0.001 / 16, 15) * li.std_error[i] + point.error + 4 / 0.25 * gamma;
            EXPECT_NEAR(li.reference[i], point.term, bound) << i;
            EXPECT_NEAR(li.approximation[1][i], point.term, 1e-5) << i;            // centre-exact
            EXPECT_NEAR(li.approximation[2][i], li.approximation[1][i], 4 / 0.25 * gamma + 2e-6) << i;  // taps-exact
        }
}

TEST_F(SceneTest, AreaLightDescriptionsAreChecked) {
    write_png(path("rough.png"), 4, 4, 1, std::vector<double>(16, 0.5));
    auto error_of = [&](const std::string& light) {
        write_text(path("bad.toml"), std::string(kAreaScene) + "[[light]]\n" + light);
        return scene_error(path("bad.toml"));
    };
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"type = \"sphere\"\nposition = [0, 0, 2]\n", "light[0].radius: missing"},
        {"type = \"sphere\"\nposition = [0, 0, 2]\nradius = 0\n", "light[0].radius: must be in (0, 1e30], got 0"},
        {"type = \"sphere\"\nposition = [0, 0, 2]\nradius = -1\n", "light[0].radius: must be in (0, 1e30], got -1"},
        {"type = \"sphere\"\nradius = 1\n", "light[0].position: missing: the position of a sphere light"},
        {"type = \"sphere\"\nposition = [0, 0, 2]\nradius = 1\ndirection = [0, 0, 1]\n", "light[0].direction: a sphere light has a position"},
        {"type = \"sphere\"\nposition = [0.5, 0.5, 0.1]\nradius = 0.5\n", "is inside the sphere light"},
        {"direction = [0, 0, 1]\nradius = 1\n", "light[0].radius: only a sphere light has a radius"},
        {"type = \"point\"\nposition = [0, 0, 1]\nlobe = \"ggx\"\n", "light[0].lobe: only area lights"},
        {"type = \"sphere\"\nposition = [0, 0, 2]\nradius = 1\nlobe = \"phong\"\n", "light[0].lobe"},
        {"type = \"rect\"\n", "light[0].corners: missing"},
        {"type = \"rect\"\ncorners = [[0, 0, 1], [1, 0, 1], [1, 1, 1]]\n", "must be a list of 4 positions"},
        {"type = \"rect\"\ncorners = [[0, 0, 1], [0, 0, 1], [1, 1, 1], [0, 1, 1]]\n", "light[0].corners: degenerate rect light: a side"},
        {"type = \"rect\"\ncorners = [[0, 0, 1], [1, 0, 1], [1.2, 1, 1], [0.2, 1, 1]]\n", "not a right angle"},
        {"type = \"rect\"\ncorners = [[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]]\n", "p1 + p3 - p0"},
        {"type = \"rect\"\nposition = [0, 0, 1]\ncorners = [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]\n", "light[0].position: a rect light has corners"},
    };
    for (const auto& [light, expected] : cases) {
        const std::string e = error_of(light);
        EXPECT_NE(e.find(expected), std::string::npos) << light << " -> " << e;
    }
    std::string loose = kAreaScene;
    loose.replace(loose.find("area_tolerance = 0.01"), 21, "area_tolerance = 1e-6");
    write_text(path("bad.toml"), loose + "[[light]]\ndirection = [0, 0, 1]\n");
    EXPECT_NE(scene_error(path("bad.toml")).find("sampling.area_tolerance: must be in [1e-4, 0.5]"), std::string::npos)
        << scene_error(path("bad.toml"));
    // A pixel in a rectangle's plane sees no light: 0, not an error. (The panel's plane z = 0 is the surface's.)
    write_text(path("edge.toml"), std::string(kAreaScene) + "[[light]]\ntype = \"rect\"\ncorners = [[2, 0, 0], [3, 0, 0], [3, 1, 0], [2, 1, 0]]\n");
    const auto r = run(path("edge.toml"));
    for (int i = 0; i < 16; ++i) EXPECT_EQ(r.lights[0].reference[i], 0.0f);
    EXPECT_EQ(r.counts.light_below_horizon, 16u);
}

TEST_F(SceneTest, AreaLightsSampledAndExactReferencesAgree) {
    // The same bulb by the joint kernel (method = "sampled") and by the exact inner term: each pixel within
    // both bounds (Bonferroni over 16 pixels; t x std_error is each run's bound at 99.9 %, so the sum of the
    // two at 1 - 0.001 / 32 covers both).
    write_png(path("rough.png"), 4, 4, 1, std::vector<double>(16, 0.5));
    const std::string light = "[[light]]\nname = \"bulb\"\ntype = \"sphere\"\nposition = [0.5, 0.2, 1.5]\nradius = 0.4\nlobe = \"ggx\"\n";
    std::string sampled = kAreaScene;
    sampled.replace(sampled.find("[sampling]\n"), 11, "[sampling]\nmethod = \"sampled\"\n");
    write_text(path("exact.toml"), std::string(kAreaScene) + light);
    write_text(path("sampled.toml"), sampled + light);
    const auto e = run(path("exact.toml")), k = run(path("sampled.toml"));
    const double t = student_t_quantile(1 - 0.001 / 32, 15);
    for (int i = 0; i < 16; ++i) {
        EXPECT_NEAR(e.lights[0].reference[i], k.lights[0].reference[i], t * (e.lights[0].std_error[i] + k.lights[0].std_error[i])) << i;
        EXPECT_GT(k.lights[0].std_error[i], 0.0f) << i;
    }
    EXPECT_EQ(k.method, Method::sampled);
}

TEST_F(SceneTest, AreaLightQueriesUseThePixelsFrameAndCarryNoPointIrradiance) {
    // An anisotropic pixel: the light's positions in its tangent frame (x = tangent, y = n x t, z = n).
    scene::PixelSurface p;
    p.shaded = true;
    p.normal = {0, 0, 1};
    p.tangent = {0, 1, 0};
    p.anisotropic = true;
    p.view = {0.6, 0, 0.8};
    p.position = {1, 2, 3};
    p.visibility = 0.5;
    p.alpha_x = 0.3, p.alpha_y = 0.1;
    scene::Light sphere;
    sphere.type = scene::LightType::sphere;
    sphere.position = {2, 2, 5};
    sphere.radius = 1;
    const scene::AreaLightQuery a = scene::area_light_query(p, sphere);
    ASSERT_EQ(a.status, scene::PixelStatus::shaded);
    // (1, 0, 2) relative; in the frame x = (0, 1, 0), y = z x x = (-1, 0, 0): (0, -1, 2).
    EXPECT_NEAR(a.query.light.sphere.centre.x, 0, 1e-12);
    EXPECT_NEAR(a.query.light.sphere.centre.y, -1, 1e-12);
    EXPECT_NEAR(a.query.light.sphere.centre.z, 2, 1e-12);
    EXPECT_NEAR(a.query.light.sphere.half_angle, std::asin(1 / std::sqrt(5.0)), 1e-12);
    EXPECT_NEAR(a.query.wi.x, 0, 1e-12);
    EXPECT_NEAR(a.query.wi.y, -0.6, 1e-12);
    // A rectangle whose centre is 1e-170 above the pixel: its point query towards the centre must not carry
    // I / d^2 (infinite here); an area light's weight comes from its radiance and T_area's lobe integral.
    scene::Light rect;
    rect.type = scene::LightType::rect;
    rect.corners = {Vec3{-1, -1, 1e-170}, Vec3{1, -1, 1e-170}, Vec3{1, 1, 1e-170}, Vec3{-1, 1, 1e-170}};
    p.position = {0, 0, 0};
    EXPECT_EQ(scene::light_query(p, rect).status, scene::PixelStatus::shaded);  // N.L = 1 towards the centre
    EXPECT_EQ(scene::light_query(p, rect).irradiance, 0.0);
    EXPECT_EQ(scene::light_query(p, sphere).irradiance, 0.0);
}

TEST_F(SceneTest, CommandLineWritesAreaLightLayers) {
    write_png(path("rough.png"), 4, 4, 1, std::vector<double>(16, 0.5));
    write_text(path("s.toml"), std::string(kAreaScene) + "[[light]]\nname = \"bulb\"\ntype = \"sphere\"\nposition = [0.5, 0.2, 1.5]\nradius = 0.4\n");
    const auto r = testing::run_shell(std::string(MICROSHADOW_CLI) + " scene " + path("s.toml") + " --out " + path("out") + " --no-seed-luts --quiet 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const char* f : {"scene.exr", "report.json", "bulb_reference.png", "bulb_centre-exact.png", "bulb_taps-exact.png"})
        EXPECT_TRUE(fs::exists(path("out/") + f)) << f;
    const auto layers = scene::list_channels(path("out/scene.exr"));
    EXPECT_NE(std::find(layers.begin(), layers.end(), "bulb.taps-exact_error"), layers.end());
    std::ifstream in(path("out/report.json"));
    const auto j = nlohmann::json::parse(in);
    EXPECT_EQ(j["work"]["sampled"].get<std::uint64_t>(), 16u);
}

}  // namespace
}  // namespace ms
