// The GLSL and HLSL each representation generates compile with glslangValidator and, run as
// compute shaders on lavapipe (tests/support/vulkan_compute.hpp) over the representation's texture uploaded as
// RGBA32F, agree with its C++ lookup (ms::repr::Representation::operator()). The texture is a synthetic
// bake (random texel values): the test is of the layout and arithmetic, not of the term. Tolerance
// 2e-5: float32 arithmetic of values of order 1 (a few ulps of 6e-8 each over ~30 operations) and
// float acos (the C++ side takes the same float cos_phi, so the acos ill-conditioning near +-1 acts on
// both alike); a wrong texel, slot, slab or weight errs by the texel spread, ~0.3.
// KTX2/DDS output: the KTX2 file, read field by field by a reader written here from the
// KTX 2.0 specification, holds the EXR's texels and metadata, opens as a comparator equal to the EXR, and
// the GLSL run over its level data as uploaded agrees with the C++ lookup; `repr export` and
// `repr bake --out F.ktx2` end to end.
#include <gtest/gtest.h>

#include <Imath/half.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "cli_runner.hpp"
#include "core/query.hpp"
#include "jobs/compare.hpp"
#include "lut/lookup.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"
#include "vulkan_compute.hpp"
#include "glslang.hpp"
#include "lut/shader/compose.hpp"
#include "wgpu_runner.hpp"

namespace {

using ms::testing::RunResult;
using ms::testing::run_shell;
namespace repr = ms::repr;

using ms::testing::have_glslang;
using ms::testing::compile_spirv;

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

// WGSL: the texture and its sampler at bindings 0 and 1, `per` input vec4 per lookup, the call `call`
// (of the vec4s p = inputs[per i], inputs[per i + k]).
std::string repr_wgsl_wrapper(const std::string& generated, unsigned per, const std::string& call) {
    return "@group(0) @binding(0) var g_lut: texture_3d<f32>;\n@group(0) @binding(1) var g_sampler: sampler;\n"
           "@group(0) @binding(2) var<storage, read> g_inputs: array<vec4<f32>>;\n"
           "@group(0) @binding(3) var<storage, read_write> g_outputs: array<f32>;\n" +
           generated +
           "@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n"
           "    let i = id.x;\n    if (i >= arrayLength(&g_outputs)) { return; }\n"
           "    let p = g_inputs[" + std::to_string(per) + "u * i];\n"
           "    g_outputs[i] = " + call + ";\n}\n";
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

struct ReprShaderCase {
    std::string name, kind;
    repr::ReprGrid grid;
    std::uint32_t nodes;
};

std::vector<ReprShaderCase> cases() {
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
    // The edge-roughness NdotL: each slab its own NdotL coordinate (low roughness: widths 2 r^2 down to 0.005).
    repr::ReprGrid edge = linear;
    edge.warps = {repr::NdotVWarp::linear, repr::NdotLWarp::edge_roughness, repr::VisibilityWarp::sqrt_top};
    edge.roughness = {0.05, 0.2, 0.5, 1.0};
    repr::ReprGrid edge_geometric = edge;  // equal ratios: the shader finds the slab by a logarithm
    edge_geometric.roughness = {0.05, 0.1, 0.2, 0.4, 0.8};
    repr::ReprGrid edge_one = edge;
    edge_one.roughness = {0.3};
    edge_one.weighting = ms::AoWeighting::uniform;
    // The edge-roughness visibility warp (each slab its own visibility coordinate, from the start or
    // from v = 0) with the NdotL width's view cap: nodes found by comparison, and one uniform-AO node.
    repr::ReprGrid edge_visibility = edge;
    edge_visibility.warps.visibility = repr::VisibilityWarp::edge_roughness;
    edge_visibility.n_dot_l_edge_view = 1;
    edge_visibility.visibility_start = 0.02;
    repr::ReprGrid edge_visibility_one = edge_one;
    edge_visibility_one.warps.visibility = repr::VisibilityWarp::edge_roughness;
    edge_visibility_one.n_dot_l_edge_view = 0.5;
    edge_visibility_one.visibility_edge_view = 0;
    return {{"harm_edge", "azimuth-harmonics", edge, 7}, {"harm_edge_one", "azimuth-harmonics", edge_one, 7},
            {"harm_edge_geometric", "azimuth-harmonics", edge_geometric, 7}, {"harm_top_geometric", "azimuth-harmonics",
            [&] { repr::ReprGrid g = top; g.roughness = {0.1, 0.3, 0.9}; return g; }(), 7},
            {"axis_linear", "azimuth-axis", linear, 5},       {"axis_warped", "azimuth-axis", warped, 4},
            {"axis_uniform", "azimuth-axis", uniform, 3},     {"harm_linear", "azimuth-harmonics", linear, 9},
            {"harm_warped", "azimuth-harmonics", warped, 7},  {"axis_top", "azimuth-axis", top, 6},
            {"harm_top", "azimuth-harmonics", top, 7},  {"harm_uniform", "azimuth-harmonics", uniform, 8},
            // The full-range preset's grid: NdotL and NdotV texels from end to end, the visibility start,
            // the far-side azimuth warp, the edge-roughness visibility warp and the NdotL width's view cap.
            {"harm_full_range", "azimuth-harmonics", repr::preset("full-range").grid, 9},
            {"harm_edge_visibility", "azimuth-harmonics", edge_visibility, 7},
            {"harm_edge_visibility_one", "azimuth-harmonics", edge_visibility_one, 7}};
}

// The points where a lookup's rules act (each (v, NdotL, NdotV, roughness, cos_phi)): the zero region's
// edge exactly (its binary32 arithmetic exact there: 2 v + NdotL = 1 with v in [1/4, 1/2], or 1 - v = k / 2048
// for uniform AO), one binary32 step either side and 2^-21 above (the C++ lookup decides the early-out in
// binary32, as the shader does); v = 1 (the harmonics' rule) and the visibility just below it; the
// domain's edges: v 0, the grid's visibility start, NdotL 1, NdotV 0.02, its start and 1, the first and
// last roughness nodes and beyond, the azimuth's ends.
std::vector<std::array<float, 5>> repr_edge_points(const repr::ReprGrid& grid, std::mt19937& rng) {
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<std::array<float, 5>> p;
    auto any_r = [&] { return float(1.1 * u(rng)); };
    auto any_nv = [&] { return float(0.02 + 0.98 * u(rng)); };
    auto any_phi = [&] { return float(2 * u(rng) - 1); };
    for (int i = 0; i < 400; ++i) {
        float v, l;
        if (grid.weighting == ms::AoWeighting::cosine) {
            v = float(0.25 + 0.25 * u(rng));
            l = 1.0f - 2.0f * v;
        } else {
            const float c = float(std::uniform_int_distribution<int>(1449, 2047)(rng)) / 2048.0f;
            v = 1.0f - c;
            l = 2.0f * c * c - 1.0f;
        }
        if (i % 4 == 1) l = std::nextafter(l, 2.0f);
        if (i % 4 == 2) l = std::nextafter(l, -2.0f);
        if (i % 4 == 3) l += std::ldexp(1.0f, -21);
        p.push_back({v, l, any_nv(), any_r(), any_phi()});
    }
    for (int i = 0; i < 64; ++i) {
        p.push_back({1.0f, float(u(rng)), any_nv(), any_r(), any_phi()});
        p.push_back({std::nextafter(1.0f, 0.0f), float(u(rng)), any_nv(), any_r(), any_phi()});
        p.push_back({1.0f - float(1e-4 * u(rng)), float(0.05 * u(rng)), any_nv(), any_r(), any_phi()});
    }
    const std::vector<float> vs{0.0f, float(grid.visibility_start), 0.5f, 1.0f}, ls{0.0f, 1e-3f, 1.0f},
        nvs{0.02f, float(std::max(grid.n_dot_v_start, 0.02)), 1.0f},
        rs{0.0f, float(grid.roughness.front()), float(grid.roughness.back()), 1.1f}, phis{-1.0f, 1.0f, 0.3f};
    for (float v : vs)
        for (float l : ls)
            for (float nv : nvs)
                for (float r : rs)
                    for (float cp : phis) p.push_back({v, l, nv, r, cp});
    return p;
}

TEST(ReprShaderTest, GeneratedShadersMatchTheCppLookupOnLavapipe) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools)";
    const std::string dir = ::testing::TempDir() + "repr_shader";
    std::filesystem::create_directories(dir);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    // The WGSL of every case, run through wgpu in one process after the loop.
    std::vector<ms::testing::WgpuJob> wgsl_jobs;
    std::vector<std::vector<double>> wgsl_expected;
    std::vector<double> wgsl_tolerance;
    for (const auto& c : cases()) {
        SCOPED_TRACE(c.name);
        const auto rep = repr::build_representation(c.kind, synthetic_bake(c.grid, c.nodes, 11));
        const auto glsl = compile_spirv(glsl_wrapper(rep->shader(repr::ShaderLanguage::glsl, c.name)), dir + "/" + c.name + ".comp", "");
        const auto hlsl = compile_spirv(hlsl_wrapper(rep->shader(repr::ShaderLanguage::hlsl, c.name)), dir + "/" + c.name + ".hlsl",
                                  "-D -e main -S comp");
        ms::testing::ComputeTexture tex;
        tex.width = rep->texture_width(), tex.height = rep->texture_height(), tex.depth = rep->texture_depth();
        tex.three_d = true;
        tex.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
        tex.texels.resize(rep->texels().size() * 4);
        std::memcpy(tex.texels.data(), rep->texels().data(), tex.texels.size());
        // Points over the whole domain and beyond the roughness range (clamping), plus the azimuth ends,
        // the domain's edges, v = 1 and the zero region's edge (repr_edge_points).
        std::vector<float> inputs;
        std::vector<double> expected;
        std::size_t zero_region = 0;
        auto add = [&](float v, float l, float nv, float r, float cos_phi) {
            inputs.insert(inputs.end(), {v, l, nv, r, cos_phi, 0, 0, 0});
            ms::approx::Inputs in;
            in.visibility = v, in.n_dot_l = l, in.n_dot_v = nv, in.roughness = r;
            in.relative_azimuth = std::acos(double(cos_phi));
            expected.push_back((*rep)(in));
            zero_region += ms::lookup_zero_region(c.grid.weighting, v, l);
        };
        for (std::size_t i = 0; i < 512; ++i) {
            const float v = float(u(rng)), l = float(u(rng) * 1.1 - 0.05), nv = float(0.02 + 0.98 * u(rng)), r = float(u(rng));
            const float cos_phi = i % 16 == 0 ? 1.0f : i % 16 == 1 ? -1.0f : float(2 * u(rng) - 1);
            add(v, l, nv, r, cos_phi);
        }
        for (const auto& p : repr_edge_points(c.grid, rng)) add(p[0], p[1], p[2], p[3], p[4]);
        const std::size_t n = expected.size();
        EXPECT_GT(zero_region, 200u);
        for (int lang = 0; lang < 2; ++lang) {
            const auto run = ms::testing::run_compute(lang ? hlsl : glsl, tex, inputs, lang == 1);
            if (!run.skip.empty()) GTEST_SKIP() << run.skip;
            ASSERT_GE(run.values.size(), n);
            double worst = 0;
            for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(run.values[i] - expected[i]));
            const double acos_bound = c.kind == "azimuth-axis" ? (c.nodes - 1) / M_PI * 4096 * std::ldexp(1.0, -22) : 0.0;
            EXPECT_LT(worst, 2e-5 + acos_bound) << (lang ? "HLSL" : "GLSL") << " on " << run.device;
        }
        const std::string wgsl = ms::lutshader::compose(rep->shader(repr::ShaderLanguage::wgsl, c.name), repr::ShaderLanguage::wgsl, c.name);
        wgsl_jobs.push_back({repr_wgsl_wrapper(wgsl, 2, c.name + "_micro_shadowing(g_lut, g_sampler, p.x, p.y, p.z, p.w, g_inputs[2u * i + 1u].x)"),
                             {tex}, inputs, n});
        wgsl_expected.push_back(expected);
        wgsl_tolerance.push_back(2e-5 + (c.kind == "azimuth-axis" ? (c.nodes - 1) / M_PI * 4096 * std::ldexp(1.0, -22) : 0.0));
    }
    const auto run = ms::testing::run_wgpu(wgsl_jobs, dir);
    if (!run.skip.empty()) GTEST_SKIP() << run.skip;
    ASSERT_EQ(run.outputs.size(), wgsl_jobs.size());
    const auto all = cases();
    for (std::size_t j = 0; j < wgsl_jobs.size(); ++j) {
        ASSERT_EQ(run.outputs[j].size(), wgsl_expected[j].size());
        double worst = 0;
        for (std::size_t i = 0; i < wgsl_expected[j].size(); ++i) worst = std::max(worst, std::abs(run.outputs[j][i] - wgsl_expected[j][i]));
        EXPECT_LT(worst, wgsl_tolerance[j]) << all[j].name << " WGSL on " << run.device;
        std::cout << "[ figures  ] " << all[j].name << " WGSL on " << run.device << ": max |shader - C++| = " << worst << "\n";
    }
}

// The anisotropic entry point: three input vec4 per lookup, (visibility, alpha_x, alpha_y, 0), V and L
// in the tangent frame.
std::string anisotropic_glsl_wrapper(const std::string& generated) {
    return "#version 450\nlayout(local_size_x = 64) in;\n"
           "layout(set = 0, binding = 0) uniform sampler3D lut;\n"
           "layout(std430, set = 0, binding = 1) readonly buffer Inputs { vec4 inputs[]; };\n"
           "layout(std430, set = 0, binding = 2) writeonly buffer Outputs { float outputs[]; };\n" +
           generated +
           "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    if (3u * i + 2u >= uint(inputs.length())) return;\n"
           "    vec4 p = inputs[3u * i];\n"
           "    outputs[i] = ms_micro_shadowing(lut, p.x, inputs[3u * i + 1u].xyz, inputs[3u * i + 2u].xyz, p.y, p.z);\n}\n";
}

std::string anisotropic_hlsl_wrapper(const std::string& generated) {
    return generated + "[[vk::binding(0)]] Texture3D<float4> g_lut;\n[[vk::binding(1)]] SamplerState g_linear_clamp;\n"
           "[[vk::binding(2)]] StructuredBuffer<float4> g_inputs;\n[[vk::binding(3)]] RWStructuredBuffer<float> g_outputs;\n"
           "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
           "    uint n, stride; g_inputs.GetDimensions(n, stride);\n    if (3 * id.x + 2 >= n) return;\n"
           "    float4 p = g_inputs[3 * id.x];\n"
           "    g_outputs[id.x] = ms_micro_shadowing(g_lut, g_linear_clamp, p.x, g_inputs[3 * id.x + 1].xyz, "
           "g_inputs[3 * id.x + 2].xyz, p.y, p.z);\n}\n";
}

// The anisotropic preset's layout on a small grid with random coefficients in [-1, 1]: the shaders
// take the renderer's tangent-frame V and L and alpha_x, alpha_y, and agree with the C++ lookup fed the
// same query (approx::inputs_of). Tolerance 1e-4, wider than the isotropic kinds' 2e-5 for one measured
// reason: float rounding of NdotL (6e-8) is divided by the edge warp's width w = alpha max(sin theta_c,
// alpha), at least 1e-4 at the lowest node (alpha = 0.01), and four series with coefficients up to 1 are
// blended (6e-8 / 1e-4 x 5 texels / 4 asinh units ~ 1e-4 at worst); a wrong
// slab, node weight, rho or azimuth errs by the coefficients' spread, ~0.5. The anisotropic preset's kind
// (anisotropic-mapped-harmonics, a synthetic azimuth bake on the same grid) is held to the same bound: its
// float mapping moves NdotL, NdotV and the roughness by a few ulps (relative 1e-6 after log and exp),
// which the same widths turn into at most the same 1e-4. The preset's own kind
// (anisotropic-corrected-harmonics: the mapped lookup plus a correction with random coefficients in
// [-1, 1]) too: its features g (|g_i| < 2 up to ratio 30) weigh its coefficients as the series' basis
// (|T_m| <= 1, coefficients up to 1) weighs the harmonics', and their float rounding (1e-7 relative
// after log) adds ~1e-6. Measured on lavapipe: worst 1.8e-6 (anisotropic-harmonics), 5e-7 (mapped),
// 4.5e-6 (corrected).
TEST(ReprShaderTest, AnisotropicShadersMatchTheCppLookupOnLavapipe) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools)";
    const std::string dir = ::testing::TempDir() + "repr_shader_aniso";
    std::filesystem::create_directories(dir);
    std::vector<ms::testing::WgpuJob> wgsl_jobs;
    std::vector<std::vector<double>> wgsl_expected;
    std::vector<std::string> wgsl_names;
    // 0: anisotropic-harmonics, 1: anisotropic-mapped-harmonics, 2: anisotropic-corrected-harmonics.
    for (const int kind : {0, 1, 2})
    for (const auto weighting : {ms::AoWeighting::cosine, ms::AoWeighting::uniform}) {
        const bool mapped = kind == 1;
        const std::string name = std::string(kind == 2 ? "aniso_corrected_" : mapped ? "aniso_mapped_" : "aniso_") +
                                 (weighting == ms::AoWeighting::cosine ? "cosine" : "uniform");
        SCOPED_TRACE(name);
        repr::ReprGrid g;
        g.visibility = 4, g.n_dot_l = 5, g.n_dot_v = 3, g.roughness = {0.1, 0.2, 0.4, 0.8};
        g.warps = {repr::NdotVWarp::sqrt, repr::NdotLWarp::edge_roughness, repr::VisibilityWarp::sqrt_top};
        g.edge_width = 1.0;
        g.weighting = weighting;
        // The mapped kind reads the full-range preset's texture: its edge-roughness visibility warp and
        // the NdotL width's view cap, at the mapped NdotV (anisotropic-harmonics has neither).
        if (mapped) g.warps.visibility = repr::VisibilityWarp::edge_roughness, g.n_dot_l_edge_view = 1, g.visibility_start = 0.02;
        const std::size_t R = g.roughness.size();
        std::mt19937 rng(23);
        std::uniform_real_distribution<double> u(0, 1);
        std::vector<float> rgba(g.visibility * R * g.n_dot_l * g.n_dot_v * R * 4);
        for (auto& x : rgba) x = float(2 * u(rng) - 1);
        std::vector<float> correction(kind == 2 ? repr::anisotropic_correction_texels(g) * 4 : 0);
        for (auto& x : correction) x = float(2 * u(rng) - 1);
        const auto rep = kind == 2 ? repr::build_anisotropic_corrected(synthetic_bake(g, 7, 29), correction, nlohmann::json::object())
                         : mapped  ? repr::build_representation("anisotropic-mapped-harmonics", synthetic_bake(g, 7, 29))
                                   : repr::build_anisotropic_harmonics(g, rgba);
        const auto glsl = compile_spirv(anisotropic_glsl_wrapper(rep->shader(repr::ShaderLanguage::glsl, name)), dir + "/" + name + ".comp", "");
        const auto hlsl = compile_spirv(anisotropic_hlsl_wrapper(rep->shader(repr::ShaderLanguage::hlsl, name)), dir + "/" + name + ".hlsl",
                                  "-D -e main -S comp");
        ms::testing::ComputeTexture tex;
        tex.width = rep->texture_width(), tex.height = rep->texture_height(), tex.depth = rep->texture_depth();
        tex.three_d = true;
        tex.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
        tex.texels.resize(rep->texels().size() * 4);
        std::memcpy(tex.texels.data(), rep->texels().data(), tex.texels.size());
        // Surfaces over ratio 1-30 and alphas beyond the nodes (clamping), any azimuths, V or L along
        // the normal now and then; of the last 256, every eighth at v = 1, every eighth one float step
        // below it (the harmonics kinds' full-visibility rule) and every eighth with alpha_x 1.
        const std::size_t n = 768;
        std::vector<float> inputs;
        std::vector<double> expected;
        for (std::size_t i = 0; i < n; ++i) {
            const bool edge = i >= 512;
            const float v = edge && i % 8 < 2 ? (i % 8 == 0 ? 1.0f : std::nextafter(1.0f, 0.0f)) : float(u(rng));
            const float ax0 = float(0.005 + u(rng)), ax = edge && i % 8 == 2 ? 1.0f : ax0, ay = float(i % 8 == 0 ? ax : ax / (1 + 29 * u(rng)));
            auto dir3 = [&](double cos_theta, double phi, bool normal) {
                if (normal) return std::array<float, 3>{0, 0, 1};
                const double s = std::sqrt(1 - cos_theta * cos_theta);
                return std::array<float, 3>{float(s * std::cos(phi)), float(s * std::sin(phi)), float(cos_theta)};
            };
            const auto vt = dir3(0.02 + 0.98 * u(rng), 2 * M_PI * u(rng), i % 32 == 1);
            const auto lt = dir3(u(rng) * 1.05 - 0.05, 2 * M_PI * u(rng), i % 32 == 2);
            inputs.insert(inputs.end(), {v, ax, ay, 0, vt[0], vt[1], vt[2], 0, lt[0], lt[1], lt[2], 0});
            ms::Query q;
            q.visibility = v, q.alpha_x = ax, q.alpha_y = ay;
            q.wi = {vt[0], vt[1], vt[2]}, q.wo = {lt[0], lt[1], lt[2]};
            expected.push_back((*rep)(ms::approx::inputs_of(q, weighting)));
        }
        for (int lang = 0; lang < 2; ++lang) {
            const auto run = ms::testing::run_compute(lang ? hlsl : glsl, tex, inputs, lang == 1);
            if (!run.skip.empty()) GTEST_SKIP() << run.skip;
            ASSERT_GE(run.values.size(), n);
            double worst = 0;
            std::size_t at = 0;
            for (std::size_t i = 0; i < n; ++i)
                if (std::abs(run.values[i] - expected[i]) > worst) worst = std::abs(run.values[i] - expected[i]), at = i;
            EXPECT_LT(worst, 1e-4) << (lang ? "HLSL" : "GLSL") << " on " << run.device << ", lookup " << at;
        }
        const std::string wgsl = ms::lutshader::compose(rep->shader(repr::ShaderLanguage::wgsl, name), repr::ShaderLanguage::wgsl, name);
        wgsl_jobs.push_back({repr_wgsl_wrapper(wgsl, 3, name + "_micro_shadowing(g_lut, g_sampler, p.x, g_inputs[3u * i + 1u].xyz, "
                                                             "g_inputs[3u * i + 2u].xyz, p.y, p.z)"),
                             {tex}, inputs, n});
        wgsl_expected.push_back(expected);
        wgsl_names.push_back(name);
    }
    // The WGSL of each, through wgpu, to the same bound.
    const auto run = ms::testing::run_wgpu(wgsl_jobs, dir);
    if (!run.skip.empty()) GTEST_SKIP() << run.skip;
    ASSERT_EQ(run.outputs.size(), wgsl_jobs.size());
    for (std::size_t j = 0; j < wgsl_jobs.size(); ++j) {
        ASSERT_EQ(run.outputs[j].size(), wgsl_expected[j].size());
        double worst = 0;
        for (std::size_t i = 0; i < wgsl_expected[j].size(); ++i) worst = std::max(worst, std::abs(run.outputs[j][i] - wgsl_expected[j][i]));
        EXPECT_LT(worst, 1e-4) << wgsl_names[j] << " WGSL on " << run.device;
        std::cout << "[ figures  ] " << wgsl_names[j] << " WGSL on " << run.device << ": max |shader - C++| = " << worst << "\n";
    }
}

// --- KTX2 and DDS output --------------------------------------------------------
// A KTX2 file read field by field from the KTX 2.0 specification ("File Structure", "Level Index",
// "Key/Value Data"), independently of the writer (lut/formats/texture.cpp).
struct Ktx2File {
    std::uint32_t vk_format = 0, type_size = 0, width = 0, height = 0, depth = 0, layers = 0, faces = 0, levels = 0, scheme = 0;
    std::map<std::string, std::string> kv;  // values without their terminating NUL
    std::vector<std::uint8_t> level0;
};

Ktx2File read_ktx2(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    const std::vector<std::uint8_t> b{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    Ktx2File k;
    const std::uint8_t id[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    EXPECT_GE(b.size(), 104u);
    if (b.size() < 104 || std::memcmp(b.data(), id, 12) != 0) {
        ADD_FAILURE() << path << ": no KTX2 identifier";
        return k;
    }
    auto u32 = [&](std::size_t at) { std::uint32_t v; std::memcpy(&v, b.data() + at, 4); return v; };
    auto u64 = [&](std::size_t at) { std::uint64_t v; std::memcpy(&v, b.data() + at, 8); return v; };
    k.vk_format = u32(12), k.type_size = u32(16), k.width = u32(20), k.height = u32(24), k.depth = u32(28);
    k.layers = u32(32), k.faces = u32(36), k.levels = u32(40), k.scheme = u32(44);
    const std::uint32_t kvd_offset = u32(56), kvd_length = u32(60);
    for (std::size_t at = kvd_offset; at + 4 <= std::size_t(kvd_offset) + kvd_length;) {
        const std::uint32_t n = u32(at);
        const std::string entry(reinterpret_cast<const char*>(b.data() + at + 4), n);
        const std::size_t nul = entry.find('\0');
        std::string value = entry.substr(nul + 1);
        if (!value.empty() && value.back() == '\0') value.pop_back();
        k.kv[entry.substr(0, nul)] = value;
        at += 4 + ((n + 3) / 4) * 4;  // each entry padded to 4 bytes
    }
    const std::uint64_t offset = u64(80), length = u64(88);
    EXPECT_EQ(u64(96), length);  // no supercompression: uncompressed length = length
    EXPECT_LE(offset + length, b.size());
    if (offset + length <= b.size()) k.level0.assign(b.begin() + std::ptrdiff_t(offset), b.begin() + std::ptrdiff_t(offset + length));
    return k;
}

std::vector<float> decode_level(const Ktx2File& k) {
    std::vector<float> out;
    if (k.type_size == 4) {
        out.resize(k.level0.size() / 4);
        std::memcpy(out.data(), k.level0.data(), out.size() * 4);
    } else {
        for (std::size_t i = 0; i + 1 < k.level0.size(); i += 2) {
            std::uint16_t bits;
            std::memcpy(&bits, k.level0.data() + i, 2);
            Imath::half h;
            h.setBits(bits);
            out.push_back(float(h));
        }
    }
    return out;
}

TEST(ReprKtx2Test, TextureEqualsTheExrAndTheGeneratedShaderSamplesIt) {
    const std::string dir = ::testing::TempDir() + "repr_ktx2";
    std::filesystem::create_directories(dir);
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(0, 1);
    for (const auto& c : cases()) {
        if (c.name != "axis_warped" && c.name != "harm_linear") continue;
        SCOPED_TRACE(c.name);
        const auto rep = repr::build_representation(c.kind, synthetic_bake(c.grid, c.nodes, 11));
        const std::string base = dir + "/" + c.name;
        rep->write(base + "_half.exr", true);
        rep->write(base + "_half.ktx2", true);
        rep->write(base + ".ktx2", false);
        const auto exr = repr::open_representation(base + "_half.exr");
        for (int half = 0; half < 2; ++half) {
            const Ktx2File k = read_ktx2(half ? base + "_half.ktx2" : base + ".ktx2");
            EXPECT_EQ(k.vk_format, half ? 97u : 109u);  // VK_FORMAT_R16G16B16A16_SFLOAT / R32G32B32A32_SFLOAT
            EXPECT_EQ(k.type_size, half ? 2u : 4u);
            EXPECT_EQ(k.width, rep->texture_width());
            EXPECT_EQ(k.height, rep->texture_height());
            EXPECT_EQ(k.depth, rep->texture_depth());
            EXPECT_EQ(k.layers + (k.faces - 1) + (k.levels - 1) + k.scheme, 0u);  // 1 face, 1 level, no array, none
            EXPECT_EQ(k.kv.at("KTXorientation"), "rdi");
            const auto meta = nlohmann::json::parse(k.kv.at("microshadow"));
            EXPECT_EQ(meta.at("kind"), "representation");
            EXPECT_EQ(meta.at("representation"), c.kind);
            EXPECT_EQ(meta.at("file_format"), "ktx2");
            EXPECT_EQ(meta.at("half").get<bool>(), half == 1);
            EXPECT_EQ(meta.at("grid").at("roughness").get<std::vector<double>>(), c.grid.roughness);
            EXPECT_EQ(meta.at("azimuth_nodes").get<std::uint32_t>(), c.nodes);
            // Texel for texel: the half file equals the half EXR (both round to nearest even), the float
            // file the representation's own texels.
            const auto texels = decode_level(k);
            const auto& want = half ? exr->texels() : rep->texels();
            ASSERT_EQ(texels.size(), want.size());
            std::size_t differ = 0;
            for (std::size_t i = 0; i < texels.size(); ++i) differ += texels[i] != want[i];
            EXPECT_EQ(differ, 0u);
        }
        // The KTX2 opens as a representation (eval --compare, sweeps) equal to the EXR of the same precision.
        const auto from_ktx2 = repr::open_representation(base + "_half.ktx2");
        const auto cmp = ms::compare::Comparator::parse("k=" + base + "_half.ktx2");
        ASSERT_TRUE(cmp.is_representation());
        EXPECT_EQ(from_ktx2->kind(), c.kind);
        for (int i = 0; i < 200; ++i) {
            ms::approx::Inputs in;
            in.visibility = u(rng), in.n_dot_l = u(rng), in.n_dot_v = 0.05 + 0.95 * u(rng), in.roughness = u(rng);
            in.relative_azimuth = M_PI * u(rng);
            EXPECT_EQ((*from_ktx2)(in), (*exr)(in));
            EXPECT_EQ(cmp(in), (*exr)(in));
        }
        // A cut-off KTX2 is refused naming the file.
        {
            std::ifstream in(base + "_half.ktx2", std::ios::binary);
            std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
            std::ofstream(base + "_cut.ktx2", std::ios::binary) << bytes.substr(0, bytes.size() - 8);
        }
        EXPECT_FALSE(repr::is_representation_file(base + "_cut.ktx2"));
        try {
            repr::open_representation(base + "_cut.ktx2");
            ADD_FAILURE() << "a cut-off KTX2 was accepted";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("_cut.ktx2"), std::string::npos) << e.what();
        }
        // The generated GLSL over the half KTX2's level data uploaded as they are (RGBA16F, the file's
        // dimensions) agrees with the C++ lookup of the half EXR: the shader samples the KTX2 layout.
        if (!have_glslang()) continue;
        const Ktx2File k = read_ktx2(base + "_half.ktx2");
        const auto glsl = compile_spirv(glsl_wrapper(exr->shader(repr::ShaderLanguage::glsl, c.name)), base + "_ktx2.comp", "");
        ms::testing::ComputeTexture tex;
        tex.width = k.width, tex.height = k.height, tex.depth = k.depth;
        tex.three_d = true;
        tex.vk_format = k.vk_format;
        tex.texels.assign(k.level0.begin(), k.level0.end());
        const std::size_t n = 256;
        std::vector<float> inputs;
        std::vector<double> expected;
        for (std::size_t i = 0; i < n; ++i) {
            const float v = float(u(rng)), l = float(u(rng)), nv = float(0.02 + 0.98 * u(rng)), r = float(u(rng));
            const float cos_phi = float(2 * u(rng) - 1);
            inputs.insert(inputs.end(), {v, l, nv, r, cos_phi, 0, 0, 0});
            ms::approx::Inputs in;
            in.visibility = v, in.n_dot_l = l, in.n_dot_v = nv, in.roughness = r;
            in.relative_azimuth = std::acos(double(cos_phi));
            expected.push_back((*exr)(in));
        }
        const auto run = ms::testing::run_compute(glsl, tex, inputs, false);
        if (!run.skip.empty()) GTEST_SKIP() << run.skip;
        ASSERT_GE(run.values.size(), n);
        double worst = 0;
        for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(run.values[i] - expected[i]));
        // As above: float arithmetic, plus Vulkan's acos error for the axis.
        const double acos_bound = c.kind == "azimuth-axis" ? (c.nodes - 1) / M_PI * 4096 * std::ldexp(1.0, -22) : 0.0;
        EXPECT_LT(worst, 2e-5 + acos_bound) << "GLSL on " << run.device;
    }
}

class ReprExportCliTest : public ms::testing::ScratchDirTest {
protected:
    ReprExportCliTest() : ScratchDirTest("repr_export") {}
};

TEST_F(ReprExportCliTest, BakeAndExportWriteKtx2AndDdsAndRefuseOtherExtensions) {
    const std::string cli = MICROSHADOW_CLI;
    const auto c = cases()[3];  // harmonics, linear grid
    const auto rep = repr::build_representation(c.kind, synthetic_bake(c.grid, c.nodes, 11));
    rep->write(path("h.exr"), false);
    // KTX2 and DDS are RGBA16F by default (what an engine uploads, and what the memory figures count).
    auto r = run_shell(cli + " repr export " + path("h.exr") + " --out " + path("h.ktx2") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto half = repr::open_representation(path("h.exr"));
    const auto k = read_ktx2(path("h.ktx2"));
    EXPECT_EQ(k.vk_format, 97u);
    const auto texels = decode_level(k);
    ASSERT_EQ(texels.size(), rep->texels().size());
    for (std::size_t i = 0; i < texels.size(); ++i) ASSERT_EQ(texels[i], float(Imath::half(rep->texels()[i]))) << i;
    EXPECT_EQ(k.level0.size(), rep->texels().size() * 2);
    // --float: RGBA32F, the texels as they are.
    r = run_shell(cli + " repr export " + path("h.exr") + " --float --out " + path("f.ktx2") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(read_ktx2(path("f.ktx2")).vk_format, 109u);
    EXPECT_EQ(decode_level(read_ktx2(path("f.ktx2"))), rep->texels());
    r = run_shell(cli + " repr export " + path("h.exr") + " --float --half --out " + path("x.ktx2") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    std::filesystem::remove(path("f.ktx2"));
    // DDS: the texture and its metadata beside it, together.
    r = run_shell(cli + " repr export " + path("h.exr") + " --out " + path("h.dds") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(std::filesystem::file_size(path("h.dds")), 4 + 124 + 20 + rep->texels().size() * 2);
    std::ifstream sidecar(path("h.dds.json"));
    const auto meta = nlohmann::json::parse(sidecar);
    EXPECT_EQ(meta.at("file_format"), "dds");
    EXPECT_EQ(meta.at("representation"), c.kind);
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir_), std::filesystem::directory_iterator()), 4);  // no temporaries left
    // An unknown extension: exit 2, nothing written.
    r = run_shell(cli + " repr export " + path("h.exr") + " --out " + path("h.png") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(".ktx2"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(path("h.png")));
    // repr bake --out X.ktx2 writes the texture directly (a tiny bake).
    r = run_shell(cli + " repr bake -q --kind azimuth-axis --visibility-count 2 --n-dot-l-count 2 --n-dot-v-count 2 "
                        "--azimuth-nodes 3 --roughness 0.5 --samples 256 --out " + path("b.ktx2") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto b = read_ktx2(path("b.ktx2"));
    EXPECT_EQ(b.width, 2u * 3);  // 3 azimuth slots of 2 visibility texels
    EXPECT_EQ(b.height, 2u);
    EXPECT_EQ(b.depth, 2u);
    EXPECT_EQ(b.vk_format, 97u);  // RGBA16F by default
    EXPECT_NE(nlohmann::json::parse(b.kv.at("microshadow")).at("command_line").get<std::string>().find("b.ktx2"), std::string::npos);
}

}  // namespace
