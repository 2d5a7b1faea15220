// The GLSL and HLSL of the 7-tap area-light approximation compile with glslangValidator and, run as
// compute shaders on lavapipe with a stand-in point term, give the C++ taps (jobs/area.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>

#include "cli_runner.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "jobs/area.hpp"
#include "jobs/area_shader.hpp"
#include "vulkan_compute.hpp"
#include "glslang.hpp"
#include "lut/shader/compose.hpp"
#include "wgpu_runner.hpp"

namespace {

using ms::testing::compile_spirv;

using ms::testing::run_shell;

// A smooth stand-in for the engine's lookup, in [0, 1]: the test checks the taps, not the term.
const char* kStubGlsl = "float ms_point_term(vec3 wi, vec3 wo) { return 0.5 + 0.3 * wo.z - 0.2 * wo.x * wo.y + 0.1 * wi.x * wo.x; }\n";
const char* kStubHlsl = "float ms_point_term(float3 wi, float3 wo) { return 0.5 + 0.3 * wo.z - 0.2 * wo.x * wo.y + 0.1 * wi.x * wo.x; }\n";
double stub(const ms::Vec3& wi, const ms::Vec3& wo) { return 0.5 + 0.3 * wo.z - 0.2 * wo.x * wo.y + 0.1 * wi.x * wo.x; }

// The WGSL taps (prefix "taps": they call taps_point_term, the stub) through wgpu: `per` input vec4 per
// query, `call` of the vec4s a, b, c, d = inputs[per i + 0..3]; the largest difference from `expected`.
double wgsl_taps_worst(const std::vector<float>& inputs, unsigned per, const std::string& call, const std::vector<double>& expected,
                       const std::string& dir, std::string* skip) {
    const std::string taps = ms::lutshader::compose(ms::area::taps_shader(ms::area::ShaderLanguage::wgsl), ms::area::ShaderLanguage::wgsl, "taps");
    std::string fetch;
    for (unsigned k = 0; k < per; ++k)
        fetch += std::string("    let ") + char('a' + k) + " = g_inputs[" + std::to_string(per) + "u * id.x + " + std::to_string(k) + "u];\n";
    const std::string wgsl =
        "@group(0) @binding(0) var<storage, read> g_inputs: array<vec4<f32>>;\n"
        "@group(0) @binding(1) var<storage, read_write> g_outputs: array<f32>;\n"
        "fn taps_point_term(wi: vec3<f32>, wo: vec3<f32>) -> f32 { return 0.5 + 0.3 * wo.z - 0.2 * wo.x * wo.y + 0.1 * wi.x * wo.x; }\n" +
        taps + "@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n"
               "    if (id.x >= arrayLength(&g_outputs)) { return; }\n" + fetch + "    g_outputs[id.x] = " + call + ";\n}\n";
    const auto run = ms::testing::run_wgpu({{wgsl, {}, inputs, expected.size()}}, dir);
    *skip = run.skip;
    if (!run.skip.empty() || run.outputs.size() != 1 || run.outputs[0].size() != expected.size()) return std::numeric_limits<double>::infinity();
    double worst = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) worst = std::max(worst, std::abs(run.outputs[0][i] - expected[i]));
    std::cout << "[ figures  ] taps WGSL on " << run.device << ": max |shader - C++| = " << worst << "\n";
    return worst;
}

// Three input vec4 per query: (wi, lobe), (centre, half_angle), (alpha_x, alpha_y, 0, 0).
std::string glsl_wrapper() {
    return std::string("#version 450\nlayout(local_size_x = 64) in;\n"
                       "layout(set = 0, binding = 0) uniform sampler3D unused;\n"
                       "layout(std430, set = 0, binding = 1) readonly buffer Inputs { vec4 inputs[]; };\n"
                       "layout(std430, set = 0, binding = 2) writeonly buffer Outputs { float outputs[]; };\n") +
           kStubGlsl + ms::area::taps_shader(ms::area::ShaderLanguage::glsl) +
           "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    if (3u * i + 2u >= uint(inputs.length())) return;\n"
           "    vec4 a = inputs[3u * i], b = inputs[3u * i + 1u], c = inputs[3u * i + 2u];\n"
           "    outputs[i] = ms_area_light_taps(a.xyz, b.xyz, b.w, c.x, c.y, int(a.w));\n}\n";
}

std::string hlsl_wrapper() {
    return std::string(kStubHlsl) + ms::area::taps_shader(ms::area::ShaderLanguage::hlsl) +
           "[[vk::binding(0)]] Texture3D<float4> g_unused;\n[[vk::binding(1)]] SamplerState g_sampler;\n"
           "[[vk::binding(2)]] StructuredBuffer<float4> g_inputs;\n[[vk::binding(3)]] RWStructuredBuffer<float> g_outputs;\n"
           "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
           "    uint n, stride; g_inputs.GetDimensions(n, stride);\n    if (3 * id.x + 2 >= n) return;\n"
           "    float4 a = g_inputs[3 * id.x], b = g_inputs[3 * id.x + 1], c = g_inputs[3 * id.x + 2];\n"
           "    g_outputs[id.x] = ms_area_light_taps(a.xyz, b.xyz, b.w, c.x, c.y, int(a.w));\n}\n";
}

TEST(AreaShaderTest, TapsShaderMatchesTheCppTapsOnLavapipe) {
    if (run_shell("command -v glslangValidator >/dev/null 2>&1").exit_code != 0)
        GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools)";
    const std::string dir = std::filesystem::temp_directory_path() / ("microshadow_area_shader_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto glsl = compile_spirv(glsl_wrapper(), dir + "/taps.comp", "");
    const auto hlsl = compile_spirv(hlsl_wrapper(), dir + "/taps.hlsl", "-D -e main -S comp");
    ms::testing::ComputeTexture tex;
    tex.width = tex.height = tex.depth = 1;
    tex.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
    tex.texels.assign(16, 0);
    // Random sphere lights as in the study (sizes up to 30 degrees, straddling the horizon too), both
    // lobes, narrow and wide GGX lobes, anisotropy up to 1:4.
    std::mt19937_64 rng(25);
    std::uniform_real_distribution<double> u(0, 1);
    const std::size_t n = 256;
    std::vector<float> inputs;
    std::vector<double> expected;
    for (std::size_t i = 0; i < n; ++i) {
        ms::area::AreaQuery q;
        q.lobe = i % 2 ? ms::area::Lobe::ggx : ms::area::Lobe::lambert;
        const double nv = 0.1 + 0.9 * u(rng), phi_v = 6.283185307 * u(rng);
        q.wi = {std::sqrt(1 - nv * nv) * std::cos(phi_v), std::sqrt(1 - nv * nv) * std::sin(phi_v), nv};
        const double gamma = ms::area::radians(0.5 + 29.5 * u(rng));
        const double el = -gamma + (ms::kPi / 2 + gamma) * u(rng), az = 6.283185307 * u(rng);
        q.light.sphere.centre = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
        q.light.sphere.half_angle = gamma;
        const double r = 0.1 + 0.9 * u(rng);
        q.alpha_x = r * r;
        q.alpha_y = q.alpha_x * (0.25 + 0.75 * u(rng));
        // The C++ reference in double, from the float inputs the shader sees.
        for (ms::Vec3* v : {&q.wi, &q.light.sphere.centre}) *v = {double(float(v->x)), double(float(v->y)), double(float(v->z))};
        q.light.sphere.half_angle = double(float(gamma));
        q.alpha_x = double(float(q.alpha_x)), q.alpha_y = double(float(q.alpha_y));
        inputs.insert(inputs.end(), {float(q.wi.x), float(q.wi.y), float(q.wi.z), float(q.lobe == ms::area::Lobe::ggx),
                                     float(q.light.sphere.centre.x), float(q.light.sphere.centre.y),
                                     float(q.light.sphere.centre.z), float(q.light.sphere.half_angle), float(q.alpha_x),
                                     float(q.alpha_y), 0, 0});
        double num = 0, den = 0;
        const ms::area::AreaQuery nq = ms::area::normalised(q);
        for (const auto& t : ms::area::sphere_taps(q)) num += t.weight * stub(nq.wi, t.wo), den += t.weight;
        expected.push_back(den > 0 ? num / den : 0.0);
    }
    for (int lang = 0; lang < 2; ++lang) {
        const auto run = ms::testing::run_compute(lang ? hlsl : glsl, tex, inputs, lang == 1);
        if (!run.skip.empty()) GTEST_SKIP() << run.skip;
        ASSERT_GE(run.values.size(), n);
        double worst = 0;
        std::size_t where = 0;
        for (std::size_t i = 0; i < n; ++i)
            if (std::abs(run.values[i] - expected[i]) > worst) worst = std::abs(run.values[i] - expected[i]), where = i;
        // float32: the tap directions carry ~1e-6 rad and the weights ~1e-5 relative rounding; the result is a
        // weighted mean of stub values spread over less than 1, so 1e-4 bounds the difference.
        EXPECT_LT(worst, 1e-4) << (lang ? "HLSL" : "GLSL") << " on " << run.device << ", query " << where << ": "
                               << run.values[where] << " against " << expected[where];
    }
    // The WGSL, through wgpu, to the same bound.
    std::string skip;
    const double wgsl_worst = wgsl_taps_worst(inputs, 3, "taps_area_light_taps(a.xyz, b.xyz, b.w, c.x, c.y, i32(a.w))", expected, dir, &skip);
    std::filesystem::remove_all(dir);
    if (!skip.empty()) GTEST_SKIP() << skip;
    EXPECT_LT(wgsl_worst, 1e-4) << "WGSL";
}

// Four input vec4 per query: (wi, lobe), (p0, alpha_x), (e1, alpha_y), (e2, 0).
std::string rect_glsl_wrapper() {
    return std::string("#version 450\nlayout(local_size_x = 64) in;\n"
                       "layout(set = 0, binding = 0) uniform sampler3D unused;\n"
                       "layout(std430, set = 0, binding = 1) readonly buffer Inputs { vec4 inputs[]; };\n"
                       "layout(std430, set = 0, binding = 2) writeonly buffer Outputs { float outputs[]; };\n") +
           kStubGlsl + ms::area::taps_shader(ms::area::ShaderLanguage::glsl) +
           "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    if (4u * i + 3u >= uint(inputs.length())) return;\n"
           "    vec4 a = inputs[4u * i], b = inputs[4u * i + 1u], c = inputs[4u * i + 2u], d = inputs[4u * i + 3u];\n"
           "    outputs[i] = ms_rect_light_taps(a.xyz, b.xyz, c.xyz, d.xyz, b.w, c.w, int(a.w));\n}\n";
}

std::string rect_hlsl_wrapper() {
    return std::string(kStubHlsl) + ms::area::taps_shader(ms::area::ShaderLanguage::hlsl) +
           "[[vk::binding(0)]] Texture3D<float4> g_unused;\n[[vk::binding(1)]] SamplerState g_sampler;\n"
           "[[vk::binding(2)]] StructuredBuffer<float4> g_inputs;\n[[vk::binding(3)]] RWStructuredBuffer<float> g_outputs;\n"
           "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
           "    uint n, stride; g_inputs.GetDimensions(n, stride);\n    if (4 * id.x + 3 >= n) return;\n"
           "    float4 a = g_inputs[4 * id.x], b = g_inputs[4 * id.x + 1], c = g_inputs[4 * id.x + 2], d = g_inputs[4 * id.x + 3];\n"
           "    g_outputs[id.x] = ms_rect_light_taps(a.xyz, b.xyz, c.xyz, d.xyz, b.w, c.w, int(a.w));\n}\n";
}

TEST(AreaShaderTest, RectTapsShaderMatchesTheCppTapsOnLavapipe) {
    if (run_shell("command -v glslangValidator >/dev/null 2>&1").exit_code != 0)
        GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools)";
    const std::string dir = std::filesystem::temp_directory_path() / ("microshadow_rect_shader_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto glsl = compile_spirv(rect_glsl_wrapper(), dir + "/rect.comp", "");
    const auto hlsl = compile_spirv(rect_hlsl_wrapper(), dir + "/rect.hlsl", "-D -e main -S comp");
    ms::testing::ComputeTexture tex;
    tex.width = tex.height = tex.depth = 1;
    tex.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
    tex.texels.assign(16, 0);
    // Random rectangles as the rect study draws them (jobs/area.hpp, random_rect_points): sizes up to 30
    // degrees, tilted, straddling the horizon too; both lobes, narrow and wide GGX lobes, anisotropy.
    const std::size_t n = 256;
    const auto points = ms::area::random_rect_points(n, 30, 26);
    std::vector<float> inputs;
    std::vector<double> expected;
    std::mt19937_64 rng(27);
    std::uniform_real_distribution<double> u(0, 1);
    for (std::size_t i = 0; i < n; ++i) {
        ms::area::AreaQuery q = points[i].query;
        q.alpha_y = q.alpha_x * (0.25 + 0.75 * u(rng));
        auto f = [](ms::Vec3 v) { return ms::Vec3{double(float(v.x)), double(float(v.y)), double(float(v.z))}; };
        q.wi = f(q.wi);
        q.alpha_x = double(float(q.alpha_x)), q.alpha_y = double(float(q.alpha_y));
        auto& k = q.light.rect.corners;
        const ms::Vec3 p0 = f(k[0]), e1 = f({k[1].x - k[0].x, k[1].y - k[0].y, k[1].z - k[0].z}),
                       e2 = f({k[3].x - k[0].x, k[3].y - k[0].y, k[3].z - k[0].z});
        // The C++ reference from the float inputs the shader sees (p2 closes the rectangle exactly).
        k = {p0, ms::Vec3{p0.x + e1.x, p0.y + e1.y, p0.z + e1.z}, ms::Vec3{p0.x + e1.x + e2.x, p0.y + e1.y + e2.y, p0.z + e1.z + e2.z},
             ms::Vec3{p0.x + e2.x, p0.y + e2.y, p0.z + e2.z}};
        inputs.insert(inputs.end(), {float(q.wi.x), float(q.wi.y), float(q.wi.z), float(q.lobe == ms::area::Lobe::ggx),
                                     float(p0.x), float(p0.y), float(p0.z), float(q.alpha_x), float(e1.x), float(e1.y),
                                     float(e1.z), float(q.alpha_y), float(e2.x), float(e2.y), float(e2.z), 0});
        double num = 0, den = 0;
        const ms::area::AreaQuery nq = ms::area::normalised(q);
        for (const auto& t : ms::area::rect_taps(q)) num += t.weight * stub(nq.wi, t.wo), den += t.weight;
        expected.push_back(den > 0 ? num / den : 0.0);
    }
    for (int lang = 0; lang < 2; ++lang) {
        const auto run = ms::testing::run_compute(lang ? hlsl : glsl, tex, inputs, lang == 1);
        if (!run.skip.empty()) GTEST_SKIP() << run.skip;
        ASSERT_GE(run.values.size(), n);
        double worst = 0;
        std::size_t where = 0;
        for (std::size_t i = 0; i < n; ++i)
            if (std::abs(run.values[i] - expected[i]) > worst) worst = std::abs(run.values[i] - expected[i]), where = i;
        // As for the sphere: float32 directions and weights, a weighted mean of stub values spread over < 1.
        EXPECT_LT(worst, 1e-4) << (lang ? "HLSL" : "GLSL") << " on " << run.device << ", query " << where << ": "
                               << run.values[where] << " against " << expected[where];
    }
    std::string skip;
    const double wgsl_worst =
        wgsl_taps_worst(inputs, 4, "taps_rect_light_taps(a.xyz, b.xyz, c.xyz, d.xyz, b.w, c.w, i32(a.w))", expected, dir, &skip);
    std::filesystem::remove_all(dir);
    if (!skip.empty()) GTEST_SKIP() << skip;
    EXPECT_LT(wgsl_worst, 1e-4) << "WGSL";
}

TEST(AreaShaderTest, CliWritesBothLanguages) {
    const std::string cli = MICROSHADOW_CLI;
    const auto g = run_shell(cli + " area shader --lang glsl");
    ASSERT_EQ(g.exit_code, 0);
    EXPECT_NE(g.output.find("float ms_area_light_taps(vec3 wi"), std::string::npos);
    const auto h = run_shell(cli + " area shader --lang hlsl");
    ASSERT_EQ(h.exit_code, 0);
    EXPECT_NE(h.output.find("float ms_area_light_taps(float3 wi"), std::string::npos);
    EXPECT_NE(h.output.find("float ms_rect_light_taps(float3 wi, float3 p0"), std::string::npos);
    EXPECT_EQ(h.output.find("vec3"), std::string::npos);
    const auto w = run_shell(cli + " area shader --lang wgsl");
    ASSERT_EQ(w.exit_code, 0);
    EXPECT_NE(w.output.find("fn ms_area_light_taps(wi: vec3<f32>"), std::string::npos) << w.output;
    EXPECT_EQ(run_shell(cli + " area shader --lang msl 2>&1").exit_code, 2);
}

}  // namespace
