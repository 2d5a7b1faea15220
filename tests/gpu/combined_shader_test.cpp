// Generated shaders compose: two LUTs of different layouts (3D seed LUT, 2D LUT), a representation and
// the area-light taps, each written by its command with its own prefix, go into one GLSL and one HLSL
// shader (one of them included twice: the include guards), which compile with glslangValidator and run
// on lavapipe, every function giving what its C++ lookup gives.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "cli_runner.hpp"
#include "glslang.hpp"
#include "jobs/area.hpp"
#include "lut/exr_lut.hpp"
#include "lut/lookup.hpp"
#include "lut/shader/compose.hpp"
#include "repr/representation.hpp"
#include "test_files.hpp"
#include "vulkan_compute.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::cli;
using ms::testing::compile_spirv;
using ms::testing::have_glslang;
using ms::testing::RunResult;

std::string file_text(const std::string& path) { return ms::testing::slurp_file(path); }

// The engine's point term the taps call (taps_point_term: the taps file's prefix), a smooth stand-in.
double combined_stub(const ms::Vec3& wi, const ms::Vec3& wo) { return 0.5 + 0.3 * wo.z - 0.2 * wo.x * wo.y + 0.1 * wi.x * wo.x; }
const char* kCombinedStub = "float taps_point_term(VEC3 wi, VEC3 wo) { return 0.5 + 0.3 * wo.z - 0.2 * wo.x * wo.y + 0.1 * wi.x * wo.x; }\n";

std::string with_vec3(std::string s, const std::string& vec3) {
    s.replace(s.find("VEC3"), 4, vec3);
    s.replace(s.find("VEC3"), 4, vec3);
    return s;
}

// Four input vec4 per query: (v, NdotL, NdotV, roughness), (cos_phi, alpha_x, alpha_y, lobe),
// (wi, half_angle), (light centre, 0); four outputs: LUT A, LUT B, the representation, the sphere taps.
const char* kCombinedMainGlsl =
    "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    if (4u * i + 3u >= uint(inputs.length())) return;\n"
    "    vec4 a = inputs[4u * i], b = inputs[4u * i + 1u], c = inputs[4u * i + 2u], d = inputs[4u * i + 3u];\n"
    "    outputs[4u * i] = lut_a_micro_shadowing(lut_a, a.x, a.y, a.z, a.w);\n"
    "    outputs[4u * i + 1u] = lut_b_micro_shadowing(lut_b, a.x, a.y, a.z, a.w);\n"
    "    outputs[4u * i + 2u] = repr_c_micro_shadowing(repr_c, a.x, a.y, a.z, a.w, b.x);\n"
    "    outputs[4u * i + 3u] = taps_area_light_taps(c.xyz, d.xyz, c.w, b.y, b.z, int(b.w));\n}\n";

const char* kCombinedMainHlsl =
    "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
    "    uint n, stride; g_inputs.GetDimensions(n, stride);\n    uint i = id.x;\n    if (4 * i + 3 >= n) return;\n"
    "    float4 a = g_inputs[4 * i], b = g_inputs[4 * i + 1], c = g_inputs[4 * i + 2], d = g_inputs[4 * i + 3];\n"
    "    g_outputs[4 * i] = lut_a_micro_shadowing(g_lut_a, g_sampler_a, a.x, a.y, a.z, a.w);\n"
    "    g_outputs[4 * i + 1] = lut_b_micro_shadowing(g_lut_b, g_sampler_b, a.x, a.y, a.z, a.w);\n"
    "    g_outputs[4 * i + 2] = repr_c_micro_shadowing(g_repr_c, g_sampler_c, a.x, a.y, a.z, a.w, b.x);\n"
    "    g_outputs[4 * i + 3] = taps_area_light_taps(c.xyz, d.xyz, c.w, b.y, b.z, int(b.w));\n}\n";

// A harmonics representation with the edge-roughness NdotL warp (its shader uses the shared asinh),
// of random texels: the test checks the shader, not the term.
std::unique_ptr<ms::repr::Representation> combined_representation() {
    ms::repr::AzimuthBake b;
    b.grid.visibility = 5, b.grid.n_dot_l = 4, b.grid.n_dot_v = 3, b.grid.roughness = {0.05, 0.2, 0.5, 1.0};
    b.grid.warps = {ms::repr::NdotVWarp::linear, ms::repr::NdotLWarp::edge_roughness, ms::repr::VisibilityWarp::sqrt_top};
    b.azimuth_nodes = 7;
    const std::size_t n = b.grid.roughness.size() * b.azimuth_nodes * b.grid.visibility * b.grid.n_dot_l * b.grid.n_dot_v;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0, 1);
    b.value.resize(n);
    for (auto& v : b.value) v = u(rng);
    b.std_error.assign(n, 0.0f);
    return ms::repr::build_representation("azimuth-harmonics", b);
}

class CombinedShaderTest : public ms::testing::ScratchDirTest {
protected:
    CombinedShaderTest() : ScratchDirTest("combined_shader") {}
};

TEST_F(CombinedShaderTest, TwoLutsAReprAndTheTapsInOneShaderOnLavapipe) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools)";
    // LUT A: the 3D seed layout, its prefix from the file name; LUT B: the 2D layout, a chosen prefix.
    RunResult r = cli("bake -q --size 8 --samples 4096 --out " + path("lut_a.ktx2") + " --shader-glsl " + path("lut_a.glsl") +
                      " --shader-hlsl " + path("lut_a.hlsl"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = cli("bake -q --layout seed-2d --size 8 --samples 4096 --out " + path("b.ktx2") + " --shader-glsl " + path("b.glsl") +
            " --shader-hlsl " + path("b.hlsl") + " --shader-prefix lut_b");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto rep = combined_representation();
    rep->write(path("repr_c.exr"), false);
    for (const char* lang : {"glsl", "hlsl"}) {
        r = cli(std::string("repr shader ") + path("repr_c.exr") + " --lang " + lang + " --out " + path(std::string("repr_c.") + lang));
        ASSERT_EQ(r.exit_code, 0) << r.output;
        r = cli(std::string("area shader --lang ") + lang + " --out " + path(std::string("taps.") + lang));
        ASSERT_EQ(r.exit_code, 0) << r.output;
    }
    // The names carry the prefixes; the shared helpers sit in the one common block.
    EXPECT_NE(file_text(path("lut_a.glsl")).find("float lut_a_micro_shadowing(sampler3D lut"), std::string::npos);
    EXPECT_NE(file_text(path("b.glsl")).find("float lut_b_micro_shadowing(sampler2D lut"), std::string::npos);
    EXPECT_NE(file_text(path("repr_c.glsl")).find("float repr_c_micro_shadowing(sampler3D repr_c_tex"), std::string::npos);
    EXPECT_NE(file_text(path("taps.glsl")).find("taps_point_term(wi, wo)"), std::string::npos);
    for (const char* f : {"lut_a.glsl", "b.glsl", "repr_c.glsl", "taps.glsl"}) EXPECT_EQ(file_text(path(f)).find(" ms_micro"), std::string::npos) << f;
    const std::string common = ms::lutshader::common_block(ms::lutshader::ShaderLanguage::glsl);
    EXPECT_NE(file_text(path("repr_c.glsl")).find(common), std::string::npos);
    EXPECT_NE(file_text(path("taps.glsl")).find(common), std::string::npos);

    // lut_a comes twice (a material that includes it from two places): its guard keeps one copy.
    std::string glsl_files, hlsl_files;
    for (const char* f : {"lut_a", "b", "repr_c", "taps", "lut_a"}) {
        glsl_files += file_text(path(std::string(f) + ".glsl"));
        hlsl_files += file_text(path(std::string(f) + ".hlsl"));
    }
    const std::string glsl = "#version 450\nlayout(local_size_x = 64) in;\n"
                             "layout(set = 0, binding = 0) uniform sampler3D lut_a;\n"
                             "layout(set = 0, binding = 1) uniform sampler2D lut_b;\n"
                             "layout(set = 0, binding = 2) uniform sampler3D repr_c;\n"
                             "layout(std430, set = 0, binding = 3) readonly buffer Inputs { vec4 inputs[]; };\n"
                             "layout(std430, set = 0, binding = 4) writeonly buffer Outputs { float outputs[]; };\n" +
                             with_vec3(kCombinedStub, "vec3") + glsl_files + kCombinedMainGlsl;
    const std::string hlsl = with_vec3(kCombinedStub, "float3") + hlsl_files +
                             "[[vk::binding(0)]] Texture3D<float4> g_lut_a;\n[[vk::binding(1)]] SamplerState g_sampler_a;\n"
                             "[[vk::binding(2)]] Texture2D<float4> g_lut_b;\n[[vk::binding(3)]] SamplerState g_sampler_b;\n"
                             "[[vk::binding(4)]] Texture3D<float4> g_repr_c;\n[[vk::binding(5)]] SamplerState g_sampler_c;\n"
                             "[[vk::binding(6)]] StructuredBuffer<float4> g_inputs;\n"
                             "[[vk::binding(7)]] RWStructuredBuffer<float> g_outputs;\n" + kCombinedMainHlsl;
    const auto glsl_spirv = compile_spirv(glsl, path("combined.comp"), "");
    const auto hlsl_spirv = compile_spirv(hlsl, path("combined.hlsl"), "-D -e main -S comp");
    ASSERT_FALSE(glsl_spirv.empty() || hlsl_spirv.empty()) << "the combined shaders did not compile";

    ms::testing::ComputeTexture repr_texture;
    repr_texture.width = rep->texture_width(), repr_texture.height = rep->texture_height(), repr_texture.depth = rep->texture_depth();
    repr_texture.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
    repr_texture.texels.resize(rep->texels().size() * 4);
    std::memcpy(repr_texture.texels.data(), rep->texels().data(), repr_texture.texels.size());
    const std::vector<ms::testing::ComputeTexture> textures = {ms::testing::ktx2_texture(path("lut_a.ktx2")),
                                                               ms::testing::ktx2_texture(path("b.ktx2")), repr_texture};
    const ms::LutLookup lut_a(ms::read_lut(path("lut_a.ktx2"))), lut_b(ms::read_lut(path("b.ktx2")));

    // Random queries over each domain; the C++ value of each function from the float inputs the shader sees.
    std::mt19937_64 rng(39);
    std::uniform_real_distribution<double> u(0, 1);
    const std::size_t n = 512;
    std::vector<float> inputs;
    std::vector<std::array<double, 4>> expected;
    std::vector<bool> zero_region;
    for (std::size_t i = 0; i < n; ++i) {
        const float v = float(u(rng)), l = float(0.001 + 0.999 * u(rng)), nv = float(0.02 + 0.98 * u(rng)), ro = float(0.05 + u(rng));
        const float cos_phi = float(2 * u(rng) - 1);
        ms::area::AreaQuery q;
        q.lobe = i % 2 ? ms::area::Lobe::ggx : ms::area::Lobe::lambert;
        const double wz = 0.1 + 0.9 * u(rng), phi_v = 2 * M_PI * u(rng);
        q.wi = {float(std::sqrt(1 - wz * wz) * std::cos(phi_v)), float(std::sqrt(1 - wz * wz) * std::sin(phi_v)), float(wz)};
        const double gamma = float(ms::area::radians(0.5 + 29.5 * u(rng)));
        const double el = -gamma + (M_PI / 2 + gamma) * u(rng), az = 2 * M_PI * u(rng);
        q.light.sphere.centre = {float(std::cos(el) * std::cos(az)), float(std::cos(el) * std::sin(az)), float(std::sin(el))};
        q.light.sphere.half_angle = gamma;
        q.alpha_x = float(0.01 + 0.8 * u(rng));
        q.alpha_y = float(q.alpha_x * (0.25 + 0.75 * u(rng)));
        inputs.insert(inputs.end(), {v, l, nv, ro, cos_phi, float(q.alpha_x), float(q.alpha_y), float(q.lobe == ms::area::Lobe::ggx),
                                     float(q.wi.x), float(q.wi.y), float(q.wi.z), float(gamma), float(q.light.sphere.centre.x),
                                     float(q.light.sphere.centre.y), float(q.light.sphere.centre.z), 0.0f});
        ms::approx::Inputs in;
        in.visibility = v, in.n_dot_l = l, in.n_dot_v = nv, in.roughness = ro, in.relative_azimuth = std::acos(double(cos_phi));
        double num = 0, den = 0;
        const ms::area::AreaQuery nq = ms::area::normalised(q);
        for (const auto& t : ms::area::sphere_taps(q)) num += t.weight * combined_stub(nq.wi, t.wo), den += t.weight;
        expected.push_back({lut_a(v, l, nv, ro), lut_b(v, l, nv, ro), (*rep)(in), den > 0 ? num / den : 0.0});
        // The LUTs' zero region (cosine AO), where their shaders return exactly 0; points within float
        // rounding of its edge are left out.
        zero_region.push_back(2.0 * v + l <= 1.0);
        if (std::abs(2.0 * v + l - 1.0) < 1e-5) expected.back()[0] = expected.back()[1] = std::nan("");
    }
    // Tolerances: the single-file tests' (float textures 1e-5, the representation 2e-5, the taps 1e-4).
    const std::array<double, 4> tolerance = {1e-5, 1e-5, 2e-5, 1e-4};
    const char* what[] = {"LUT A (3D)", "LUT B (2D)", "representation", "sphere taps"};
    for (bool use_hlsl : {false, true}) {
        const auto run = ms::testing::run_compute(use_hlsl ? hlsl_spirv : glsl_spirv, textures, inputs, use_hlsl, 1);
        if (!run.skip.empty()) GTEST_SKIP() << run.skip;
        ASSERT_GE(run.values.size(), 4 * n);
        for (int f = 0; f < 4; ++f) {
            double worst = 0;
            std::size_t zeros = 0;
            for (std::size_t i = 0; i < n; ++i) {
                const float got = run.values[4 * i + f];
                if (std::isnan(expected[i][f])) continue;
                if (f < 2 && zero_region[i]) {
                    EXPECT_EQ(got, 0.0f) << what[f] << " query " << i;
                    ++zeros;
                    continue;
                }
                worst = std::max(worst, std::abs(got - expected[i][f]));
            }
            EXPECT_LT(worst, tolerance[f]) << what[f] << (use_hlsl ? " HLSL" : " GLSL") << " on " << run.device;
            if (f < 2) EXPECT_GT(zeros, 50u) << what[f];
            std::cout << "[ figures  ] combined " << (use_hlsl ? "HLSL" : "GLSL") << " " << what[f] << ": max |shader - C++| = " << worst
                      << " over " << n << " queries\n";
        }
    }
}

// The prefixes: from the output file's name by default ("ms" on standard output), checked when given.
TEST(ShaderPrefixTest, DefaultsFromTheFileNameAndRejectsBadNames) {
    using ms::lutshader::default_prefix;
    EXPECT_EQ(default_prefix(""), "ms");
    EXPECT_EQ(default_prefix("-"), "ms");
    EXPECT_EQ(default_prefix("out/lut_a.glsl"), "lut_a");
    EXPECT_EQ(default_prefix("out/my-lut.v2.hlsl"), "my_lut_v2");
    EXPECT_EQ(default_prefix("3d.glsl"), "ms_3d");
    EXPECT_EQ(default_prefix("gl_x.glsl"), "ms_gl_x");
    EXPECT_EQ(default_prefix("__.glsl"), "ms");
    for (const char* bad : {"", "_a", "a_", "a__b", "gl_a", "3d", "a-b", "a b"})
        EXPECT_THROW(ms::lutshader::check_prefix(bad), std::invalid_argument) << bad;
    EXPECT_NO_THROW(ms::lutshader::check_prefix("Lut_2"));
}

}  // namespace
