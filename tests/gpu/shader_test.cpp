// Generated shaders: the GLSL and HLSL that `microshadow bake --shader-glsl/--shader-hlsl`
// and `microshadow shader` write compile with glslangValidator, and run as compute shaders on a Vulkan
// CPU device (Mesa lavapipe) over the bake's KTX2 texture they agree with the sweeps' `lut3d`
// comparator (ms::LutLookup on the EXR) on every point, the zero region's edge included: within 1e-5
// for float textures, one 8-bit step for RGBA8, exactly 0 wherever the lookup answers 0 by rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include <Imath/half.h>

#include <functional>

#include "cli_runner.hpp"
#include "lut/exr_lut.hpp"
#include "lut/lookup.hpp"
#include "vulkan_compute.hpp"
#include "glslang.hpp"
#include "wgpu_runner.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

using ms::testing::cli;

std::string read_text(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

using ms::testing::have_glslang;
using ms::testing::compile_spirv;

// GLSL compute wrapper: one lookup per input vec4 (visibility, NdotL, NdotV, roughness).
std::string glsl_wrapper(const std::string& generated, bool three_d, const std::string& prefix) {
    return std::string("#version 450\nlayout(local_size_x = 64) in;\n") +
           "layout(set = 0, binding = 0) uniform " + (three_d ? "sampler3D" : "sampler2D") + " lut;\n"
           "layout(std430, set = 0, binding = 1) readonly buffer Inputs { vec4 inputs[]; };\n"
           "layout(std430, set = 0, binding = 2) writeonly buffer Outputs { float outputs[]; };\n" +
           generated +
           "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    vec4 p = inputs[i];\n"
           "    outputs[i] = " + prefix + "_micro_shadowing(lut, p.x, p.y, p.z, p.w);\n}\n";
}

// HLSL compute wrapper (separate texture and sampler, as D3D binds them).
std::string hlsl_wrapper(const std::string& generated, bool three_d, const std::string& prefix) {
    return generated + "[[vk::binding(0)]] " + (three_d ? "Texture3D<float4>" : "Texture2D<float4>") + " g_lut;\n"
           "[[vk::binding(1)]] SamplerState g_linear_clamp;\n"
           "[[vk::binding(2)]] StructuredBuffer<float4> g_inputs;\n"
           "[[vk::binding(3)]] RWStructuredBuffer<float> g_outputs;\n"
           "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
           "    float4 p = g_inputs[id.x];\n"
           "    g_outputs[id.x] = " + prefix + "_micro_shadowing(g_lut, g_linear_clamp, p.x, p.y, p.z, p.w);\n}\n";
}

// A pixel-shader use of the HLSL (the form most engines have): must compile too.
std::string hlsl_pixel_wrapper(const std::string& generated, bool three_d, const std::string& prefix) {
    return generated + (three_d ? "Texture3D<float4>" : "Texture2D<float4>") + std::string(" g_lut : register(t0);\n") +
           "SamplerState g_linear_clamp : register(s0);\n"
           "float4 main(float4 p : TEXCOORD0) : SV_Target {\n"
           "    return " + prefix + "_micro_shadowing(g_lut, g_linear_clamp, p.x, p.y, p.z, p.w).xxxx;\n}\n";
}

using ms::testing::ktx2_texture;

struct LutShaderCase {
    std::string name, bake_args;
};

class ShaderTest : public ScratchDirTest {
protected:
    ShaderTest() : ScratchDirTest("shader") {}
};

// Layouts that exercise every part of the mapping: the seed 3D LUT (texel centres), a custom LUT with
// narrowed axis ranges, endpoint texels and roughness channels given out of order, the 2D LUT, and a
// uniform-AO LUT (the other zero region).
const std::vector<LutShaderCase> kCases = {
    {"seed3d", "--size 8 --samples 4096"},
    {"custom", "--layout custom --size-visibility 9 --size-n-dot-l 7 --size-n-dot-v 5 --texel endpoints "
               "--visibility-range 0.1,0.95 --n-dot-l-range 0.05,1 --n-dot-v-range 0.2,1 --roughness 0.8,0.3,0.55 --samples 4096"},
    {"seed2d", "--layout seed-2d --size 8 --samples 4096"},
    {"uniform", "--layout custom --size 6 --roughness 0.5 --ao-weighting uniform --samples 4096"},
};

TEST_F(ShaderTest, GeneratedGlslAndHlslCompile) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools; scripts/install-deps.sh)";
    for (const auto& c : kCases) {
        SCOPED_TRACE(c.name);
        const std::string base = path(c.name);
        const RunResult r = cli("bake -q " + c.bake_args + " --out " + base + ".exr --shader-glsl " + base + ".glsl --shader-hlsl " + base + ".hlsl");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        const bool three_d = c.name != "seed2d";
        // `microshadow shader` writes the same code from the EXR, given the prefix the bake's files took
        // from their names.
        const RunResult g = cli("shader " + base + ".exr --lang glsl --shader-prefix " + c.name);
        ASSERT_EQ(g.exit_code, 0) << g.output;
        EXPECT_EQ(g.output, read_text(base + ".glsl"));
        ASSERT_EQ(cli("shader " + base + ".exr --lang hlsl --out " + base + "2.hlsl --shader-prefix " + c.name).exit_code, 0);
        EXPECT_EQ(read_text(base + "2.hlsl"), read_text(base + ".hlsl"));
        compile_spirv(glsl_wrapper(read_text(base + ".glsl"), three_d, c.name), base + "_cs.comp", "");
        compile_spirv(hlsl_wrapper(read_text(base + ".hlsl"), three_d, c.name), base + "_cs.hlsl", "-D -e main -S comp");
        compile_spirv(hlsl_pixel_wrapper(read_text(base + ".hlsl"), three_d, c.name), base + "_ps.hlsl", "-D -e main -S frag");
        const std::string glsl = read_text(base + ".glsl");
        EXPECT_NE(glsl.find(c.name == "uniform" ? "n_dot_l + 1.0 <= 2.0 * cos_t * cos_t" : "2.0 * visibility + n_dot_l <= 1.0"), std::string::npos);
        EXPECT_NE(glsl.find("(alpha_x * alpha_y)^(1/4)"), std::string::npos);
    }
    EXPECT_EQ(cli("shader " + path("missing.exr") + " --lang glsl").exit_code, 2);
    // Every LUT format the bake writes gives the same code as its EXR (before: `shader` refused all but
    // .exr); only the quoted source file name differs.
    ASSERT_EQ(cli("lut export " + path("seed3d.exr") + " --out " + path("seed3d.ktx2") + " --encoding float16").exit_code, 0);
    const RunResult k = cli("shader " + path("seed3d.ktx2") + " --lang glsl --shader-prefix seed3d");
    EXPECT_EQ(k.exit_code, 0) << k.output;
    std::string from_exr = read_text(path("seed3d.glsl"));
    for (std::size_t at = from_exr.find("seed3d.exr"); at != std::string::npos; at = from_exr.find("seed3d.exr", at))
        from_exr.replace(at, 10, "seed3d.ktx2");
    EXPECT_EQ(k.output, from_exr);
}

// Random points over (and beyond) every axis range, plus every texel centre/endpoint, the domain's
// edges (each axis's min and max, 0 and 1, beyond the roughness channels), v = 1, and the zero region's
// edge: points exactly on it (where its float arithmetic is exact: 2 v + NdotL = 1 with v in [1/4, 1/2],
// or 1 - v = k / 2048 for uniform AO) and one binary32 step either side of them, which only a lookup
// that decides the early-out in binary32, as the shader does, answers alike.
std::vector<float> sample_points(const ms::LutFile& lut, std::size_t n, bool cosine) {
    std::mt19937 rng(1234);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), r(0.02f, 1.05f);
    std::vector<float> p;
    for (std::size_t i = 0; i < n; ++i) {
        const float v = u(rng), l = std::max(1e-3f, u(rng)), z = u(rng), ro = r(rng);
        p.insert(p.end(), {v, l, z, ro});
    }
    for (std::uint32_t i = 0; i < lut.visibility().count; ++i)
        for (std::uint32_t j = 0; j < lut.n_dot_l().count; ++j) {
            const float z = float(lut.n_dot_v().value(std::min<std::uint32_t>(i, lut.n_dot_v().count - 1)));
            p.insert(p.end(), {float(lut.visibility().value(i)), float(std::max(1e-3, lut.n_dot_l().value(j))), z,
                               float(lut.channels[j % lut.channels.size()].roughness)});
        }
    std::vector<float> vs{0.0f, 1.0f, float(lut.visibility().min), float(lut.visibility().max)};
    std::vector<float> ls{1e-3f, 1.0f, float(std::max(1e-3, lut.n_dot_l().min)), float(lut.n_dot_l().max)};
    std::vector<float> zs{0.0f, 1.0f, float(lut.n_dot_v().min), float(lut.n_dot_v().max)};
    std::vector<float> rs{0.0f, 1.0f, 2.0f};
    for (const auto& c : lut.channels) rs.push_back(float(c.roughness));
    for (float v : vs)
        for (float l : ls)
            for (float z : zs)
                for (float ro : rs) p.insert(p.end(), {v, l, z, ro});
    // v = 1 at random NdotL, NdotV, roughness.
    for (std::size_t i = 0; i < 200; ++i) p.insert(p.end(), {1.0f, std::max(1e-3f, u(rng)), u(rng), r(rng)});
    // The zero region's edge, exactly, and one step either side.
    for (std::size_t i = 0; i < 600; ++i) {
        float v, l;
        if (cosine) {
            v = 0.25f + 0.25f * u(rng);
            l = 1.0f - 2.0f * v;  // exact: 2 v in [1/2, 1]
        } else {
            const float c = float(std::uniform_int_distribution<int>(1449, 2047)(rng)) / 2048.0f;  // cos_t^2 > 1/2: edge above 0
            v = 1.0f - c;
            l = 2.0f * c * c - 1.0f;  // exact: c has 11 bits, 2 c^2 - 1 at most 23
        }
        // On the edge; one binary32 step above (inside in binary32 arithmetic: the sum rounds back onto
        // the edge), one below; 2^-21 above (outside either way: the lookup reads texels there).
        if (i % 4 == 1) l = std::nextafter(l, 2.0f);
        if (i % 4 == 2) l = std::nextafter(l, -2.0f);
        if (i % 4 == 3) l += std::ldexp(1.0f, -21);
        p.insert(p.end(), {v, std::max(l, 1e-3f), u(rng), r(rng)});
    }
    return p;
}

struct Agreement {
    double max_diff = 0;
    std::size_t compared = 0, zero_region = 0;
};

// Every point against the C++ lookup, early-out included: where the lookup answers 0 by rule the shader
// must return exactly 0, elsewhere agree within `tolerance`.
Agreement compare(const ms::LutLookup& lookup, const std::vector<float>& points, const std::vector<float>& got,
                  double tolerance, const std::string& what) {
    Agreement a;
    std::size_t reported = 0;
    for (std::size_t i = 0; i < got.size(); ++i) {
        const float v = points[4 * i], l = points[4 * i + 1], z = points[4 * i + 2], r = points[4 * i + 3];
        if (ms::lookup_zero_region(lookup.ao_weighting(), v, l)) {
            ++a.zero_region;
            EXPECT_EQ(lookup(v, l, z, r), 0.0) << what;
            if (got[i] != 0.0f && reported++ < 3)
                ADD_FAILURE() << what << ": zero region must early-out at v " << v << " NdotL " << l << ": shader " << got[i];
            continue;
        }
        const double want = lookup(v, l, z, r);
        const double d = std::abs(double(got[i]) - want);
        a.max_diff = std::max(a.max_diff, d);
        ++a.compared;
        if (d > tolerance && reported++ < 3)
            ADD_FAILURE() << what << " at v " << v << " NdotL " << l << " NdotV " << z << " r " << r << ": shader " << got[i]
                          << " lut3d " << want;
    }
    return a;
}

TEST_F(ShaderTest, GlslAndHlslOnLavapipeAgreeWithTheLut3dComparator) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools; scripts/install-deps.sh)";
    for (const auto& c : kCases) {
        SCOPED_TRACE(c.name);
        const std::string base = path(c.name);
        for (const auto& [ext, extra] : std::vector<std::pair<std::string, std::string>>{
                 {".exr", " --shader-glsl " + base + ".glsl --shader-hlsl " + base + ".hlsl"},
                 {".ktx2", ""}, {"_h.ktx2", " --encoding float16"}, {"_8.ktx2", " --encoding unorm8"}}) {
            const RunResult r = cli("bake -q " + c.bake_args + extra + " --out " + base + ext);
            ASSERT_EQ(r.exit_code, 0) << r.output;
        }
        const auto lookup = ms::LutLookup::open(base + ".exr");
        const bool three_d = c.name != "seed2d", cosine = c.name != "uniform";
        const auto glsl = compile_spirv(glsl_wrapper(read_text(base + ".glsl"), three_d, c.name), base + "_cs.comp", "");
        const auto hlsl = compile_spirv(hlsl_wrapper(read_text(base + ".hlsl"), three_d, c.name), base + "_cs.hlsl", "-D -e main -S comp");
        ASSERT_FALSE(glsl.empty() || hlsl.empty()) << "the shaders did not compile";
        const std::vector<float> points = sample_points(lookup.file(), 4000, cosine);
        // Each texture is compared with the lut3d comparator on the values it stores (the EXR's texels
        // rounded as the encoding rounds them: Imath half, round(255 v) / 255) within 1e-5 (the
        // bar for float textures; float filtering and coordinate rounding are far below it), and with the
        // float EXR within 1e-5 (float32), 1e-5 + 2^-12 (float16: its rounding of values <= 1) and one
        // 8-bit step (RGBA8). The harness runs lavapipe with float filtering for 8-bit textures too
        // (GALLIVM_PERF=no_aos_sampling, see vulkan_compute.hpp); its default 8-bit fixed-point filter
        // adds up to about one more step (docs/engine.md).
        struct Enc {
            std::string ext;
            double tolerance_stored, tolerance_exr;
            std::function<float(float)> store;
        };
        const std::vector<Enc> encodings = {
            {".ktx2", 1e-5, 1e-5, [](float v) { return v; }},
            {"_h.ktx2", 1e-5, 1e-5 + std::ldexp(1.0, -12), [](float v) { return float(Imath::half(v)); }},
            {"_8.ktx2", 1e-5, 1.0 / 255.0, [](float v) { return float(std::lround(v * 255.0) / 255.0); }}};
        for (const auto& enc : encodings) {
            ms::LutFile stored = lookup.file();
            for (float& v : stored.data) v = enc.store(v);
            const ms::LutLookup stored_lookup(stored);
            const auto texture = ktx2_texture(base + enc.ext);
            for (bool use_hlsl : {false, true}) {
                const std::string what = c.name + enc.ext + (use_hlsl ? " hlsl" : " glsl");
                const auto run = ms::testing::run_compute(use_hlsl ? hlsl : glsl, texture, points, use_hlsl);
                if (!run.skip.empty()) GTEST_SKIP() << run.skip;
                ASSERT_EQ(run.values.size(), points.size() / 4);
                const Agreement a = compare(stored_lookup, points, run.values, enc.tolerance_stored, what);
                const Agreement f = compare(lookup, points, run.values, enc.tolerance_exr, what + " vs float EXR");
                EXPECT_GT(a.compared, 2500u) << what;
                EXPECT_GT(a.zero_region, 500u) << what;
                std::cout << "[ figures  ] " << what << " on " << run.device << ": max |shader - lut3d| = " << a.max_diff
                          << " (stored texels), " << f.max_diff << " (float EXR) over " << a.compared << " points; "
                          << a.zero_region << " zero-region points exactly 0\n";
            }
        }
    }
}

}  // namespace

namespace {

// WGSL compute wrapper: one lookup per input vec4, the texture and its sampler at bindings 0 and 1.
std::string wgsl_wrapper(const std::string& generated, bool three_d, const std::string& prefix) {
    return std::string("@group(0) @binding(0) var g_lut: ") + (three_d ? "texture_3d<f32>" : "texture_2d<f32>") + ";\n" +
           "@group(0) @binding(1) var g_sampler: sampler;\n"
           "@group(0) @binding(2) var<storage, read> g_inputs: array<vec4<f32>>;\n"
           "@group(0) @binding(3) var<storage, read_write> g_outputs: array<f32>;\n" +
           generated +
           "@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n"
           "    if (id.x >= arrayLength(&g_outputs)) { return; }\n"
           "    let p = g_inputs[id.x];\n"
           "    g_outputs[id.x] = " + prefix + "_micro_shadowing(g_lut, g_sampler, p.x, p.y, p.z, p.w);\n}\n";
}

// WGSL: `bake --shader-wgsl` and `shader --lang wgsl` write the same code; run through wgpu on the
// machine's adapter (lavapipe) over the bake's float32 and float16 KTX2 textures it agrees with the lut3d
// comparator as the GLSL does (1e-5 on the stored texels; exactly 0 in the zero region), on random
// points over and beyond every axis, every texel centre or endpoint and the domain's corners.
TEST_F(ShaderTest, WgslThroughWgpuAgreesWithTheLut3dComparator) {
    std::vector<ms::testing::WgpuJob> jobs;
    struct Check {
        std::string what;
        ms::LutLookup stored;
        std::vector<float> points;
    };
    std::vector<Check> checks;
    for (const auto& c : kCases) {
        SCOPED_TRACE(c.name);
        const std::string base = path(c.name);
        RunResult r = cli("bake -q " + c.bake_args + " --out " + base + ".ktx2 --shader-wgsl " + base + ".wgsl");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        ASSERT_EQ(cli("lut export " + base + ".ktx2 --out " + base + "_h.ktx2 --encoding float16").exit_code, 0);
        r = cli("shader " + base + ".ktx2 --lang wgsl --shader-prefix " + c.name);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        std::string from_file = read_text(base + ".wgsl");
        EXPECT_EQ(r.output, from_file);
        EXPECT_EQ(from_file.find("ms_"), std::string::npos) << "every name carries the prefix";
        const bool three_d = c.name != "seed2d";
        const ms::LutLookup lookup(ms::read_lut(base + ".ktx2"));
        const std::vector<float> points = sample_points(lookup.file(), 2000, c.name != "uniform");
        for (const std::string& ext : {std::string(".ktx2"), std::string("_h.ktx2")}) {
            ms::LutFile stored = lookup.file();
            if (ext == "_h.ktx2")
                for (float& v : stored.data) v = float(Imath::half(v));
            jobs.push_back({wgsl_wrapper(from_file, three_d, c.name), {ms::testing::ktx2_texture(base + ext)}, points, points.size() / 4});
            checks.push_back({c.name + ext, ms::LutLookup(stored), points});
        }
    }
    const auto run = ms::testing::run_wgpu(jobs, dir_);
    if (!run.skip.empty()) GTEST_SKIP() << run.skip;
    ASSERT_EQ(run.outputs.size(), jobs.size());
    for (std::size_t j = 0; j < jobs.size(); ++j) {
        ASSERT_EQ(run.outputs[j].size(), checks[j].points.size() / 4) << checks[j].what;
        const Agreement a = compare(checks[j].stored, checks[j].points, run.outputs[j], 1e-5, checks[j].what + " wgsl");
        EXPECT_GT(a.compared, 1000u) << checks[j].what;
        EXPECT_GT(a.zero_region, 250u) << checks[j].what;
        std::cout << "[ figures  ] " << checks[j].what << " wgsl on " << run.device << ": max |shader - lut3d| = " << a.max_diff
                  << " over " << a.compared << " points; " << a.zero_region << " zero-region points exactly 0\n";
    }
}

}  // namespace
