// Issue 15: the GLSL and HLSL each representation generates compile with glslangValidator and, run as
// compute shaders on lavapipe (tests/vulkan_compute.hpp) over the representation's texture uploaded as
// RGBA32F, agree with its C++ lookup (ms::repr::Representation::operator()). The texture is a synthetic
// bake (random texel values): the test is of the layout and arithmetic, not of the term. Tolerance
// 2e-5: float32 arithmetic of values of order 1 (a few ulps of 6e-8 each over ~30 operations) and
// float acos (the C++ side takes the same float cos_phi, so the acos ill-conditioning near +-1 acts on
// both alike); a wrong texel, slot, slab or weight errs by the texel spread, ~0.3.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "cli_runner.hpp"
#include "repr/representation.hpp"
#include "vulkan_compute.hpp"

namespace {

using ms::testing::RunResult;
using ms::testing::run_shell;
namespace repr = ms::repr;

bool have_glslang() { return run_shell("command -v glslangValidator >/dev/null 2>&1").exit_code == 0; }

// Two input vec4 per lookup: (visibility, NdotL, NdotV, roughness) and (cos_phi, 0, 0, 0).
std::string glsl_wrapper(const std::string& generated) {
    return "#version 450\nlayout(local_size_x = 64) in;\n"
           "layout(set = 0, binding = 0) uniform sampler3D lut;\n"
           "layout(std430, set = 0, binding = 1) readonly buffer Inputs { vec4 inputs[]; };\n"
           "layout(std430, set = 0, binding = 2) writeonly buffer Outputs { float outputs[]; };\n" +
           generated +
           "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    if (2u * i + 1u >= uint(inputs.length())) return;\n"
           "    vec4 p = inputs[2u * i];\n    vec4 q = inputs[2u * i + 1u];\n"
           "    outputs[i] = ms_micro_shadowing(lut, p.x, p.y, p.z, p.w, q.x);\n}\n";
}

std::string hlsl_wrapper(const std::string& generated) {
    return generated + "[[vk::binding(0)]] Texture3D<float4> g_lut;\n[[vk::binding(1)]] SamplerState g_linear_clamp;\n"
           "[[vk::binding(2)]] StructuredBuffer<float4> g_inputs;\n[[vk::binding(3)]] RWStructuredBuffer<float> g_outputs;\n"
           "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
           "    uint n, stride; g_inputs.GetDimensions(n, stride);\n    if (2 * id.x + 1 >= n) return;\n"
           "    float4 p = g_inputs[2 * id.x];\n    float4 q = g_inputs[2 * id.x + 1];\n"
           "    g_outputs[id.x] = ms_micro_shadowing(g_lut, g_linear_clamp, p.x, p.y, p.z, p.w, q.x);\n}\n";
}

std::vector<std::uint32_t> compile(const std::string& source, const std::string& file, const std::string& flags) {
    std::ofstream(file) << source;
    const RunResult r = run_shell("glslangValidator " + flags + " -V -o " + file + ".spv " + file + " 2>&1");
    EXPECT_EQ(r.exit_code, 0) << file << ":\n" << r.output << "\n" << source;
    std::ifstream in(file + ".spv", std::ios::binary);
    std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::vector<std::uint32_t> words(bytes.size() / 4);
    if (!words.empty()) std::memcpy(words.data(), bytes.data(), words.size() * 4);
    return words;
}

// A bake of random values in [0, 1] on `grid` (no sampling: the shader test needs texels, not the term).
repr::AzimuthBake synthetic_bake(const repr::ReprGrid& grid, std::uint32_t nodes, std::uint32_t seed) {
    repr::AzimuthBake b;
    b.grid = grid;
    b.azimuth_nodes = nodes;
    const std::size_t n = grid.roughness.size() * nodes * grid.visibility * grid.n_dot_l * grid.n_dot_v;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0, 1);
    b.value.resize(n);
    for (auto& v : b.value) v = u(rng);
    b.std_error.assign(n, 0.0f);
    return b;
}

struct Case {
    std::string name, kind;
    repr::ReprGrid grid;
    std::uint32_t nodes;
};

std::vector<Case> cases() {
    repr::ReprGrid linear;
    linear.visibility = 5, linear.n_dot_l = 4, linear.n_dot_v = 3, linear.roughness = {0.2, 0.5, 0.9};
    repr::ReprGrid warped = linear;
    warped.warps = {repr::NdotVWarp::sqrt, repr::NdotLWarp::shadow_edge, repr::VisibilityWarp::linear};
    warped.roughness = {0.3, 0.45, 0.6, 1.0};
    repr::ReprGrid top = linear;
    top.warps = {repr::NdotVWarp::linear, repr::NdotLWarp::sqrt_top, repr::VisibilityWarp::sqrt_top};
    repr::ReprGrid uniform = warped;
    uniform.weighting = ms::AoWeighting::uniform;
    uniform.roughness = {0.5};
    return {{"axis_linear", "azimuth-axis", linear, 5},       {"axis_warped", "azimuth-axis", warped, 4},
            {"axis_uniform", "azimuth-axis", uniform, 3},     {"harm_linear", "azimuth-harmonics", linear, 9},
            {"harm_warped", "azimuth-harmonics", warped, 7},  {"axis_top", "azimuth-axis", top, 6},
            {"harm_top", "azimuth-harmonics", top, 7},  {"harm_uniform", "azimuth-harmonics", uniform, 8}};
}

TEST(ReprShaderTest, GeneratedShadersMatchTheCppLookupOnLavapipe) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools)";
    const std::string dir = ::testing::TempDir() + "repr_shader";
    std::filesystem::create_directories(dir);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    for (const auto& c : cases()) {
        SCOPED_TRACE(c.name);
        const auto rep = repr::build_representation(c.kind, synthetic_bake(c.grid, c.nodes, 11));
        const auto glsl = compile(glsl_wrapper(rep->shader(repr::ShaderLanguage::glsl, c.name)), dir + "/" + c.name + ".comp", "");
        const auto hlsl = compile(hlsl_wrapper(rep->shader(repr::ShaderLanguage::hlsl, c.name)), dir + "/" + c.name + ".hlsl",
                                  "-D -e main -S comp");
        ms::testing::ComputeTexture tex;
        tex.width = rep->texture_width(), tex.height = rep->texture_height(), tex.depth = rep->texture_depth();
        tex.three_d = true;
        tex.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
        tex.texels.resize(rep->texels().size() * 4);
        std::memcpy(tex.texels.data(), rep->texels().data(), tex.texels.size());
        // Points over the whole domain and beyond the roughness range (clamping), plus the azimuth ends.
        const std::size_t n = 512;
        std::vector<float> inputs;
        std::vector<double> expected;
        for (std::size_t i = 0; i < n; ++i) {
            const float v = float(u(rng)), l = float(u(rng) * 1.1 - 0.05), nv = float(0.02 + 0.98 * u(rng)), r = float(u(rng));
            const float cos_phi = i % 16 == 0 ? 1.0f : i % 16 == 1 ? -1.0f : float(2 * u(rng) - 1);
            inputs.insert(inputs.end(), {v, l, nv, r, cos_phi, 0, 0, 0});
            ms::compare::ComparatorInputs in;
            in.visibility = v, in.n_dot_l = l, in.n_dot_v = nv, in.roughness = r;
            in.relative_azimuth = std::acos(double(cos_phi));
            expected.push_back((*rep)(in));
        }
        for (int lang = 0; lang < 2; ++lang) {
            const auto run = ms::testing::run_compute(lang ? hlsl : glsl, tex, inputs, lang == 1);
            if (!run.skip.empty()) GTEST_SKIP() << run.skip;
            ASSERT_GE(run.values.size(), n);
            double worst = 0;
            for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(run.values[i] - expected[i]));
            const double acos_bound = c.kind == "azimuth-axis" ? (c.nodes - 1) / M_PI * 4096 * std::ldexp(1.0, -22) : 0.0;
            EXPECT_LT(worst, 2e-5 + acos_bound) << (lang ? "HLSL" : "GLSL") << " on " << run.device;
        }
    }
}

}  // namespace
