// The closed-form approximation: the least-squares and Gauss-Newton layer recovers known
// models, the fit of a reference set recovers the coefficients that generated it, the JSON file
// round-trips and refuses damaged input, and the generated GLSL/HLSL compile with glslangValidator and
// compute on a Vulkan CPU device (lavapipe) what the C++ evaluation computes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "approx/analytic.hpp"
#include "cli_runner.hpp"
#include "exact/exact_term.hpp"
#include "fit/closed_form.hpp"
#include "fit/least_squares.hpp"
#include "jobs/design.hpp"
#include "jobs/design_closed_form.hpp"
#include "vulkan_compute.hpp"
#include "glslang.hpp"

namespace {

using ms::testing::RunResult;
using ms::testing::run_shell;

using ms::kPi;

// Points over the whole isotropic domain, drawn once (fixed seed).
std::vector<ms::design::ReferencePoint> random_points(std::size_t n, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u01(0, 1);
    std::vector<ms::design::ReferencePoint> p(n);
    for (auto& q : p) {
        q.visibility = u01(rng);
        q.n_dot_l = 1 - u01(rng);
        q.n_dot_v = 0.05 + 0.95 * u01(rng);
        q.roughness = 0.1 + 0.9 * u01(rng);
        q.relative_azimuth = kPi * u01(rng);
        q.weight = 1;
    }
    return p;
}

TEST(LeastSquares, RecoversAnExactPolynomialAndIgnoresAZeroWeightOutlier) {
    // y = 2 - 3x + 0.5 x^2 exactly at 50 points, plus one wild point of weight 0.
    ms::fit::Design a{3, {}};
    std::vector<double> y, w;
    for (int i = 0; i <= 50; ++i) {
        const double x = -1 + i / 25.0;
        a.rows.insert(a.rows.end(), {1, x, x * x});
        y.push_back(2 - 3 * x + 0.5 * x * x);
        w.push_back(1 + x * x);
    }
    a.rows.insert(a.rows.end(), {1, 0.3, 0.09});
    y.push_back(1e6);
    w.push_back(0);
    const auto c = ms::fit::weighted_least_squares(a, y, w);
    EXPECT_NEAR(c[0], 2, 1e-12);
    EXPECT_NEAR(c[1], -3, 1e-12);
    EXPECT_NEAR(c[2], 0.5, 1e-12);
    // A duplicated column is rank-deficient: its coefficient is 0 and the fit still exact.
    ms::fit::Design d{2, {}};
    for (int i = 0; i < 10; ++i) d.rows.insert(d.rows.end(), {double(i), double(i)});
    const auto e = ms::fit::weighted_least_squares(d, std::vector<double>{0, 2, 4, 6, 8, 10, 12, 14, 16, 18}, std::vector<double>(10, 1));
    EXPECT_NEAR(e[0] + e[1], 2, 1e-12);
    EXPECT_TRUE(e[0] == 0 || e[1] == 0);
    EXPECT_THROW(ms::fit::weighted_least_squares(a, y, std::vector<double>(y.size(), 0)), std::invalid_argument);
}

// The fit of closed_form_test's known model: a reference set whose values are exactly S(z) of known
// coefficients is fitted back to those coefficients (the linearised start is not exact, because the
// values near 0 and 1 are clamped before S^-1, so Gauss-Newton has to do the rest).
TEST(ClosedFormFit, RecoversTheCoefficientsThatGeneratedTheData) {
    for (unsigned order : {1u, 2u, 3u}) {
        SCOPED_TRACE(order);
        const std::size_t terms = ms::fit::closed_form_monomials(order).size();
        std::vector<double> truth(terms);
        std::mt19937_64 rng(order);
        std::uniform_real_distribution<double> coef(-0.6, 0.6);
        for (double& t : truth) t = coef(rng);
        truth[0] = 0.4;
        truth[1] = 2.5;  // the edge variable u dominates, as in the real term
        ms::fit::ClosedForm known;
        known.order = order;
        known.coefficients = truth;
        ms::design::ReferenceSet set;
        set.points = random_points(3000, 7);
        for (const auto& p : set.points)
            set.values.push_back({known(p.visibility, p.n_dot_l, p.n_dot_v, p.roughness, p.relative_azimuth), 0});
        const ms::fit::ClosedForm fitted = ms::design::fit_closed_form(set, order);
        ASSERT_EQ(fitted.coefficients.size(), terms);
        for (std::size_t k = 0; k < terms; ++k) EXPECT_NEAR(fitted.coefficients[k], truth[k], 1e-6) << "coefficient " << k;
        EXPECT_LT(fitted.provenance["fit_max_abs"].get<double>(), 1e-7);
    }
}

// The term is provably 0 for NdotL <= max(0, 1 - 2 v) (cosine AO): the form answers exactly 0 there
// whatever its polynomial says (before, a fit gave up to 0.14 there), and nothing just outside.
TEST(ClosedFormZero, ReturnsZeroInTheProvableZeroRegionOnly) {
    ms::fit::ClosedForm f;
    f.order = 1;
    f.coefficients = {5.0, 0.0};  // S(5) = 0.99 everywhere but in the zero region
    for (double v : {0.05, 0.2, 0.45}) {
        const double edge = 1 - 2 * v;
        EXPECT_EQ(f(v, edge, 0.7, 0.5, 1.0), 0.0) << v;
        EXPECT_EQ(f(v, 0.5 * edge, 0.7, 0.5, 1.0), 0.0) << v;
        EXPECT_GT(f(v, edge + 1e-9, 0.7, 0.5, 1.0), 0.9) << v;
    }
    EXPECT_EQ(f(0.9, 0.0, 0.7, 0.5, 1.0), 0.0) << "below the horizon";
    EXPECT_EQ(f(0.9, -0.3, 0.7, 0.5, 1.0), 0.0);
    EXPECT_GT(f(0.9, 0.01, 0.7, 0.5, 1.0), 0.9);
    f.weighting = ms::AoWeighting::uniform;  // edge 2 (1 - v)^2 - 1
    EXPECT_EQ(f(0.1, 2 * 0.81 - 1, 0.7, 0.5, 1.0), 0.0);
    EXPECT_GT(f(0.1, 2 * 0.81 - 1 + 1e-9, 0.7, 0.5, 1.0), 0.9);
}

// An exact reference set of n random points over the isotropic domain.
ms::design::ReferenceSet exact_set(std::size_t n, unsigned seed) {
    ms::design::ReferenceSet set;
    set.points = random_points(n, seed);
    for (const auto& p : set.points)
        set.values.push_back({ms::exact::exact_term_at_azimuth(p.visibility, p.roughness * p.roughness, p.n_dot_v, p.n_dot_l,
                                                               p.relative_azimuth, ms::AoWeighting::cosine)
                                  .term,
                              0});
    return set;
}

// The stated max error of a fit is searched over its region, not read off its training points: the
// search finds at least the training max (its starts include the worst training points), its point is
// where that error is (recomputed here), and between sparse training points it finds more.
TEST(ClosedFormSearch, StatedMaxIsFoundBetweenTheTrainingPoints) {
    const ms::design::ReferenceSet training = exact_set(200, 5);
    const ms::fit::ClosedForm form = ms::design::fit_closed_form(training, 2);
    const double at_points = form.provenance["fit_max_abs"].get<double>();
    const double stated = form.provenance["max_abs"].get<double>();
    const auto& at = form.provenance["max_abs_search"]["at"];
    const double v = at["visibility"], l = at["n_dot_l"], nv = at["n_dot_v"], r = at["roughness"];
    const double phi = at["relative_azimuth_deg"].get<double>() * kPi / 180;
    const double term = ms::exact::exact_term_at_azimuth(v, r * r, nv, l, phi, ms::AoWeighting::cosine, 1e-12).term;
    EXPECT_NEAR(std::fabs(form(v, l, nv, r, phi) - term), stated, 1e-7);
    EXPECT_GE(stated, at_points);
    EXPECT_GT(stated, at_points * 1.05) << "200 points leave most of the region unvisited";
    std::cout << "[ figures  ] closed-form-2 on 200 points: max over the points " << at_points << ", searched over the region "
              << stated << " (" << form.provenance["max_abs_search"]["evaluations"] << " evaluations)\n";
    // The domain it records is the training points' box.
    ASSERT_TRUE(form.provenance.contains("domain"));
    const ms::LookupDomain d = ms::LookupDomain::from_json(form.provenance["domain"], "fit");
    EXPECT_GE(d.roughness_min, 0.1);
    EXPECT_LE(d.roughness_max, 1.0);
    const ms::design::Candidate c = ms::design::closed_form_candidate(form, "");
    ASSERT_TRUE(c.domain.has_value());
    EXPECT_EQ(c.domain->describe(), d.describe());
}

TEST(ClosedFormFile, RoundTripsAndRefusesDamagedFiles) {
    ms::fit::ClosedForm f;
    f.order = 2;
    f.coefficients = {0.1, 2, -0.3, 0.25, 0.5, -1};
    f.provenance = {{"note", "test"}};
    const nlohmann::json j = ms::fit::to_json(f);
    const ms::fit::ClosedForm g = ms::fit::closed_form_from_json(nlohmann::json::parse(j.dump()), "x.json");
    EXPECT_EQ(g.order, 2u);
    EXPECT_EQ(g.coefficients, f.coefficients);
    EXPECT_EQ(g(0.7, 0.5, 0.4, 0.6, 1.0), f(0.7, 0.5, 0.4, 0.6, 1.0));
    nlohmann::json bad = j;
    bad["coefficients"].push_back(1.0);
    EXPECT_THROW(ms::fit::closed_form_from_json(bad, "x.json"), std::invalid_argument);
    bad = j;
    bad["order"] = 9;
    EXPECT_THROW(ms::fit::closed_form_from_json(bad, "x.json"), std::invalid_argument);
    bad = j;
    bad["format"] = "something else";
    EXPECT_THROW(ms::fit::closed_form_from_json(bad, "x.json"), std::invalid_argument);
}

TEST(ClosedFormCost, OrderOneIsCheaperInAluThanPart1sPzTerm) {
    // Both counted by design::count_alu from their GLSL.
    ms::fit::ClosedForm f;
    f.order = 1;
    f.coefficients = {0.3, 2.0};
    const unsigned closed = ms::design::count_alu(ms::fit::generate_closed_form_shader(f, ms::fit::ClosedFormLanguage::glsl, "t"));
    const unsigned pz = ms::design::count_alu(ms::approx::analytic_glsl(ms::analytic::AnalyticTerm::pz_analytic));
    std::cout << "[ figures  ] ALU per light: closed-form-1 " << closed << ", pz-analytic " << pz << "\n";
    // The form itself is cheaper than the PZ term; the zero region's early-out (return 0 where the term
    // provably is: max, multiply, subtract, compare) costs 4 more, which puts order 1 one ALU above it.
    f.coefficients = {0.3, 2.0};
    EXPECT_EQ(closed, pz + 1);
    EXPECT_LT(closed - 4, pz);
    // The counter itself: binary operators and calls count, literals (1e-05) and unary signs do not.
    EXPECT_EQ(ms::design::count_alu("float f(float a) { return -a * 1e-05 + pow(a, 2.0) / sqrt(a); }"), 7u);
    EXPECT_EQ(ms::design::count_alu("// a * b + c\nfloat g(float a) { return a < 0.5 ? 1.0 : fma(a, a, a); }"), 3u);
}

#ifdef MICROSHADOW_HAVE_VULKAN
using ms::testing::have_glslang;
using ms::testing::compile_spirv;

// The harness passes one vec4 per invocation; the closed form has five inputs, so invocation i reads
// inputs[2i] = (visibility, NdotL, NdotV, roughness) and inputs[2i + 1].x = VdotL and writes output
// 2i (odd outputs are unused). The texture binding is the harness's; the closed form reads none.
std::string closed_form_glsl_wrapper(const std::string& generated) {
    return "#version 450\nlayout(local_size_x = 64) in;\n"
           "layout(set = 0, binding = 0) uniform sampler2D unused;\n"
           "layout(std430, set = 0, binding = 1) readonly buffer Inputs { vec4 inputs[]; };\n"
           "layout(std430, set = 0, binding = 2) writeonly buffer Outputs { float outputs[]; };\n" +
           generated +
           "void main() {\n    uint i = gl_GlobalInvocationID.x;\n    if ((i & 1u) != 0u) { outputs[i] = 0.0; return; }\n"
           "    vec4 p = inputs[i];\n    outputs[i] = ms_micro_shadowing_fit(p.x, p.y, p.z, p.w, inputs[i + 1u].x);\n}\n";
}

std::string closed_form_hlsl_wrapper(const std::string& generated) {
    return generated + "[[vk::binding(0)]] Texture2D<float4> g_unused;\n[[vk::binding(1)]] SamplerState g_sampler;\n"
           "[[vk::binding(2)]] StructuredBuffer<float4> g_inputs;\n[[vk::binding(3)]] RWStructuredBuffer<float> g_outputs;\n"
           "[numthreads(64, 1, 1)] void main(uint3 id : SV_DispatchThreadID) {\n"
           "    if ((id.x & 1u) != 0u) { g_outputs[id.x] = 0.0; return; }\n    float4 p = g_inputs[id.x];\n"
           "    g_outputs[id.x] = ms_micro_shadowing_fit(p.x, p.y, p.z, p.w, g_inputs[id.x + 1].x);\n}\n";
}

class ClosedFormShader : public ms::testing::ScratchDirTest {
protected:
    ClosedFormShader() : ScratchDirTest("closed_form") {}
};

TEST_F(ClosedFormShader, GlslAndHlslOnLavapipeMatchTheCppEvaluation) {
    if (!have_glslang()) GTEST_SKIP() << "glslangValidator not installed (Debian glslang-tools; scripts/install-deps.sh)";
    // A fitted-looking form of each order with coefficients of the size real fits have.
    for (unsigned order : {1u, 2u, 3u}) {
        SCOPED_TRACE(order);
        ms::fit::ClosedForm f;
        f.order = order;
        std::mt19937_64 rng(100 + order);
        std::uniform_real_distribution<double> coef(-1, 1);
        for (std::size_t k = 0; k < ms::fit::closed_form_monomials(order).size(); ++k) f.coefficients.push_back(coef(rng));
        f.coefficients[1] = 3;
        const std::string base = path("order" + std::to_string(order));
        const auto glsl = compile_spirv(closed_form_glsl_wrapper(ms::fit::generate_closed_form_shader(f, ms::fit::ClosedFormLanguage::glsl, "t")),
                                  base + ".comp", "");
        const auto hlsl = compile_spirv(closed_form_hlsl_wrapper(ms::fit::generate_closed_form_shader(f, ms::fit::ClosedFormLanguage::hlsl, "t")),
                                  base + "_cs.hlsl", "-D -e main -S comp");
        ASSERT_FALSE(glsl.empty() || hlsl.empty());
        const auto points = random_points(1024, 11);
        std::vector<float> inputs;
        std::vector<double> expected, bound;
        for (const auto& p : points) {
            // VdotL of the float directions, as a renderer has it.
            const float nv = float(p.n_dot_v), nl = float(p.n_dot_l);
            const float vdl = nv * nl + std::sqrt(1 - nv * nv) * std::sqrt(1 - nl * nl) * float(std::cos(p.relative_azimuth));
            inputs.insert(inputs.end(), {float(p.visibility), nl, nv, float(p.roughness), vdl, 0, 0, 0});
            // The C++ evaluation at the same (float) inputs: t from VdotL exactly as the shader forms it.
            ms::fit::ClosedFormVariables x = ms::fit::closed_form_variables(float(p.visibility), nl, nv, float(p.roughness), 0,
                                                                             ms::AoWeighting::cosine);
            x.t = double(vdl) - double(nv) * double(nl);
            // The zero region NdotL <= max(0, 1 - 2 v), decided in float as the shader decides it: exactly 0.
            const float v32 = float(p.visibility);
            if (nl <= std::max(0.0f, 1.0f - 2.0f * v32)) {
                expected.push_back(0.0);
                bound.push_back(0.0);
                continue;
            }
            expected.push_back(f.at(x));
            // Float rounding (unit roundoff 6e-8): c, NdotL - c and t carry an absolute error of a few
            // roundoffs, u = (NdotL - c) / roughness^2 that over roughness^2; each monomial then carries
            // (its variables' errors) x (the other variables' sizes), at most sum |c_k| prod (|x| + 1)
            // times 1/roughness^2 and a few roundoffs; S' <= 1/2. 32 roundoffs of that bound it.
            const double vars[5] = {x.u, x.t, x.n_dot_v, x.roughness, x.c};
            const auto monomials = ms::fit::closed_form_monomials(order);
            double size = 0;
            for (std::size_t k = 0; k < monomials.size(); ++k) {
                double m = std::fabs(f.coefficients[k]);
                for (int v : monomials[k]) m *= std::fabs(vars[v]) + 1;
                size += m;
            }
            bound.push_back(1e-7 + 32 * 6e-8 * size / (x.roughness * x.roughness));
        }
        for (bool use_hlsl : {false, true}) {
            ms::testing::ComputeTexture texture;
            texture.width = texture.height = 1;
            texture.three_d = false;
            texture.vk_format = 109;  // VK_FORMAT_R32G32B32A32_SFLOAT
            texture.texels.assign(16, 0);
            const auto run = ms::testing::run_compute(use_hlsl ? hlsl : glsl, texture, inputs, use_hlsl);
            if (!run.skip.empty()) GTEST_SKIP() << run.skip;
            double worst = 0;
            for (std::size_t i = 0; i < points.size(); ++i) {
                const double d = std::fabs(run.values.at(2 * i) - expected[i]);
                worst = std::max(worst, d);
                EXPECT_LE(d, bound[i]) << (use_hlsl ? "hlsl" : "glsl") << " point " << i;
            }
            std::cout << "[ figures  ] closed-form-" << order << (use_hlsl ? " hlsl" : " glsl") << " on " << run.device
                      << ": max |shader - C++| = " << worst << " over " << points.size() << " points\n";
        }
    }
}
#endif

}  // namespace
