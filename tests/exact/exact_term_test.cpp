// The exact method (host/exact/) against the two sampled methods and against itself.
//
// Tolerances: exact values against sampled estimates use the Bonferroni-corrected two-sided Student-t
// quantile (family-wise 99.9 % over all queries of a test) times the replicate standard error, plus the
// exact value's own estimated error; exact against exact at another tolerance uses the sum of both
// estimated errors plus a rounding allowance of 64 ulps of 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <thread>
#include <vector>

#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "core/types.hpp"
#include "exact/exact_term.hpp"
#include "exact/gauss_legendre.hpp"
#include "grid/atlas.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "jobs/verify.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"
#include "sanitizers.hpp"

namespace {

using namespace ms;
using ms::kPi;

Vec3 direction(double cos_theta, double phi) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// Queries from every family the method must hold on: isotropic and anisotropic to 1:1000, grazing
// views (z 0.01) and lights, tiny (v 1e-4) and full (v 0.9999) cones, alpha at 1e-3 and 1, and the
// coincident directions wo = e_z, wo = wi, wi = e_z.
std::vector<Query> stress_queries(std::size_t count, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Query> out;
    for (std::size_t i = 0; out.size() < count; ++i) {
        Query q;
        const int family = int(i % 8);
        q.visibility = family == 3 ? 1e-4 * (1 + u(rng)) : family == 4 ? 1 - 1e-4 * u(rng) : 0.02 + 0.97 * u(rng);
        const double r = std::exp(std::log(0.03) * u(rng));  // roughness 0.03 .. 1: alpha 1e-3 .. 1
        q.alpha_x = r * r;
        const double ratio = family == 1 ? std::exp(std::log(1000.0) * (2 * u(rng) - 1)) : 1.0;
        q.alpha_y = std::clamp(q.alpha_x * ratio, 1e-3, 1.0);
        const double phi_i = 2 * kPi * u(rng);
        const double cos_i = family == 2 ? 0.01 + 0.02 * u(rng) : 0.05 + 0.95 * u(rng);
        q.wi = direction(cos_i, phi_i);
        const double phi_o = 2 * kPi * u(rng);
        const double cos_o = family == 5 ? 0.005 + 0.03 * u(rng) : 0.02 + 0.98 * u(rng);
        q.wo = direction(cos_o, phi_o);
        if (family == 6) q.wo = (i / 8) % 2 ? Vec3{0, 0, 1} : q.wi;      // wo = e_z or wo = wi
        if (family == 7) q.wi = Vec3{0, 0, 1};                           // wi = e_z
        out.push_back(q);
    }
    return out;
}

TEST(ExactTerm, AgreesWithTheSampledKernelWithinBonferroniBars) {
    const std::vector<Query> queries = stress_queries(2000, 19);
    SamplingPlan sampled;
    sampled.samples = 1 << 18;
    sampled.replicates = 16;
    sampled.seed = 5;
    auto backend = make_opencl_backend(ocl::select_devices("default"));
    const std::vector<Estimate> mc = evaluate(*backend, queries, TermOptions{}, sampled);
    const double t = student_t_quantile(1 - 1e-3 / double(queries.size()), int(sampled.replicates) - 1);
    std::size_t interior = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const exact::ExactValue e = exact::exact_term(queries[i], AoWeighting::cosine);
        if (e.term > 0 && e.term < 1) ++interior;
        EXPECT_LE(std::fabs(e.term - mc[i].term), t * mc[i].std_error + e.error + 1e-12)
            << "query " << i << ": exact " << e.term << " +- " << e.error << ", sampled " << mc[i].term << " +- "
            << mc[i].std_error << " (t " << t << ")";
    }
    EXPECT_GT(interior, queries.size() / 2);  // the families are not all trivial
}

TEST(ExactTerm, AgreesWithTheScalarOracleOnAnisotropicAndUniformQueries) {
    // The oracle keeps the Smith weights the exact method drops: both forms, both AO weightings.
    const std::vector<Query> queries = stress_queries(96, 23);
    SamplingPlan plan;
    // Under the sanitizers a quarter of the samples (the instrumented oracle is 3x slower): the bars
    // come from the same replicate statistics, only wider.
    plan.samples = ms::testing::kAsan ? 1 << 14 : 1 << 16;
    plan.replicates = 16;
    plan.seed = 9;
    const PointSet points = make_point_set(plan);
    const double t = student_t_quantile(1 - 1e-3 / double(4 * queries.size()), 15);
    for (Form form : {Form::height_correlated, Form::uncorrelated})
        for (AoWeighting weighting : {AoWeighting::cosine, AoWeighting::uniform})
            for (std::size_t i = 0; i < queries.size(); ++i) {
                TermOptions options;
                options.form = form;
                options.ao_weighting = weighting;
                const Estimate o = oracle::generic_m_g(queries[i], options, points);
                const exact::ExactValue e = exact::exact_term(queries[i], weighting);
                double bar = t * o.std_error;
                if (o.std_error == 0) {
                    // The replicates agree exactly (no sample, or every sample, passed the cone): the exact
                    // binomial bound on the pass fraction at the same family-wise confidence.
                    const oracle::Tally tally = oracle::tally(queries[i], options, points);
                    double passed = 0, total = 0;
                    for (std::size_t r = 0; r < tally.cone_count.size(); ++r) {
                        passed += tally.cone_count[r];
                        total += tally.hemisphere_count[r];
                    }
                    bar = binomial_agreement_bound(passed, total, 1 - 1e-3 / double(4 * queries.size()));
                }
                EXPECT_LE(std::fabs(e.term - o.term), bar + e.error + 1e-12)
                    << "query " << i << " form " << to_string(form) << " weighting " << to_string(weighting) << ": exact " << e.term << " oracle " << o.term << " +- " << o.std_error << " t " << t;
            }
}

TEST(ExactTerm, AgreesWithItselfAtAHigherOrder) {
    const std::vector<Query> queries = stress_queries(3000, 29);
    double worst = 0;
    for (std::size_t i = 0; i < queries.size(); ++i)
        for (double tolerance : {1e-6, 1e-10}) {
            const exact::ExactValue a = exact::exact_term(queries[i], AoWeighting::cosine, tolerance);
            const exact::ExactValue b = exact::exact_term(queries[i], AoWeighting::cosine, 1e-13);
            const double d = std::fabs(a.term - b.term);
            worst = std::max(worst, d);
            EXPECT_LE(d, a.error + b.error + 64 * 2.2e-16) << "query " << i << " at tolerance " << tolerance;
            EXPECT_LE(a.error, tolerance) << "query " << i << ": the estimate must meet the tolerance asked";
        }
    EXPECT_LT(worst, 1e-6);
}

TEST(ExactTerm, ExactCasesAndSymmetries) {
    Query q;
    q.visibility = 1;
    q.wi = direction(0.3, 0.2);
    q.wo = direction(0.4, 2.0);
    EXPECT_EQ(exact::exact_term(q, AoWeighting::cosine).term, 1.0);
    q.visibility = 0.2;  // 2 v + NdotL = 0.8 <= 1: the zero region
    EXPECT_EQ(exact::exact_term(q, AoWeighting::cosine).term, 0.0);
    q.wo = {0.6, 0, -0.8};  // below the horizon
    q.visibility = 0.7;
    EXPECT_EQ(exact::exact_term(q, AoWeighting::cosine).term, 0.0);
    // An isotropic surface depends on the relative azimuth only; mirroring wo across the view plane is a
    // symmetry of every surface whose axes contain that plane.
    q.alpha_x = q.alpha_y = 0.3;
    q.wi = direction(0.5, 0.0);
    q.wo = direction(0.7, 1.1);
    const double base = exact::exact_term(q, AoWeighting::cosine).term;
    Query rotated = q;
    rotated.wi = direction(0.5, 0.9);
    rotated.wo = direction(0.7, 2.0);
    EXPECT_NEAR(exact::exact_term(rotated, AoWeighting::cosine).term, base, 1e-12);
    q.alpha_y = 0.05;
    Query mirrored = q;
    mirrored.wo.y = -q.wo.y;
    EXPECT_NEAR(exact::exact_term(mirrored, AoWeighting::cosine).term, exact::exact_term(q, AoWeighting::cosine).term, 1e-12);
}

TEST(ExactTerm, AzimuthMeanMatchesACompositeRuleOfItsTerms) {
    // An independent quadrature of the mean: composite Simpson on 1024 intervals of the exact term (its
    // error at the kinks where a cap meets a circle is O(h^1.5), ~ 2e-5 for h = pi / 1024 at unit slope).
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> u(0, 1);
    for (int k = 0; k < 12; ++k) {
        const double v = 0.3 + 0.69 * u(rng), r = 0.1 + 0.9 * u(rng), nv = 0.05 + 0.95 * u(rng), nl = 0.05 + 0.95 * u(rng);
        const exact::ExactValue mean = exact::exact_azimuth_mean(v, r * r, nv, nl, AoWeighting::cosine, 1e-9);
        const int n = 1024;
        double sum = 0;
        for (int i = 0; i <= n; ++i) {
            const double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
            sum += w * exact::exact_term_at_azimuth(v, r * r, nv, nl, kPi * i / n, AoWeighting::cosine, 1e-12).term;
        }
        const double simpson = sum / (3.0 * n);
        EXPECT_NEAR(mean.term, simpson, 1e-4) << "v " << v << " r " << r << " NdotV " << nv << " NdotL " << nl;
        EXPECT_LE(mean.error, 1e-9);
    }
}

TEST(ExactTerm, ExactBakeAgreesWithTheSampledBake) {
    // A small layout at a fixed azimuth (no azimuth quadrature on either side): every texel within the
    // sampled texel's Bonferroni bar plus the exact estimate.
    BakeSpec spec = default_bake_spec(LutLayout::custom, 6);
    spec.azimuth_mean = false;
    spec.azimuth_degrees = 60;
    spec.roughness = {0.2, 0.7};
    spec.samples = 1 << 18;
    spec.replicates = 16;
    spec.backend.kind = schedule::Backend::Kind::opencl;
    const BakeResult sampled = bake_lut(spec);
    BakeSpec exact_spec = spec;
    exact_spec.method = Method::exact;
    exact_spec.tolerance = 1e-7;  // the float texels' resolution (the spec refuses less)
    exact_spec.backend.kind = schedule::Backend::Kind::oracle;    // the C++ evaluator
    const BakeResult exact = bake_lut(exact_spec);
    ASSERT_EQ(sampled.value.size(), exact.value.size());
    const double t = student_t_quantile(1 - 1e-3 / double(exact.value.size()), 15);
    for (std::size_t i = 0; i < exact.value.size(); ++i)
        EXPECT_LE(std::fabs(double(exact.value[i]) - sampled.value[i]),
                  t * sampled.std_error[i] + exact.std_error[i] + 1e-7 /* float texels */)
            << "texel " << i;
    EXPECT_LE(exact.max_std_error, 1e-7);  // quadrature estimate plus the float rounding of each texel
    EXPECT_TRUE(exact.tolerance_met);
}

TEST(ExactTerm, EvalRecordsTheMethodAndRefusesBadTolerances) {
    std::vector<Query> queries = stress_queries(40, 37);
    auto backend = make_oracle_backend(2);
    SamplingPlan plan;
    plan.method = Method::exact;
    plan.tolerance = 1e-9;
    EvalStats stats;
    const std::vector<Estimate> results = evaluate(*backend, queries, TermOptions{}, plan, &stats);
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const exact::ExactValue e = exact::exact_term(queries[i], AoWeighting::cosine, 1e-9);
        // The integrand normalises the query before the evaluator does: the same value to rounding.
        EXPECT_NEAR(results[i].term, e.term, 1e-14 + e.error);
        EXPECT_LE(results[i].std_error, 1e-9);
    }
    EXPECT_EQ(exact_provenance(plan).at("method"), "exact");
    plan.tolerance = 1e-20;
    EXPECT_THROW(evaluate(*backend, queries, TermOptions{}, plan), std::invalid_argument);
    Query bad = queries[0];
    bad.alpha_x = 0;  // the same query checks as the sampled method
    plan.tolerance = 1e-9;
    EXPECT_THROW(evaluate(*backend, {bad}, TermOptions{}, plan), std::invalid_argument);
}

}  // namespace

// Where the exact method runs: a CPU device's share goes to the C++ evaluator on its compute units
// (bit for bit the oracle backend's values: the same code, split into contiguous parts), the kernel
// runs there only when asked, and then agrees within the two error estimates.
TEST(ExactPlaces, CpuDevicesRunTheHostEvaluatorAndTheKernelOnRequest) {
    const std::vector<Query> queries = stress_queries(600, 23);
    std::vector<exact::ExactValue> one, four;
    const std::vector<AoWeighting> weighting(queries.size(), AoWeighting::cosine);
    exact_term::make_cpu_evaluator(1)->terms(queries, weighting, 1e-10, one);
    exact_term::make_cpu_evaluator(4)->terms(queries, weighting, 1e-10, four);
    ASSERT_EQ(one.size(), four.size());
    for (std::size_t i = 0; i < one.size(); ++i) {
        EXPECT_EQ(one[i].term, four[i].term) << "query " << i;
        EXPECT_EQ(one[i].error, four[i].error) << "query " << i;
    }

    const auto devices = ocl::select_devices("default");
    if (devices.empty() || devices.front().type != "CPU") GTEST_SKIP() << "the default device is not a CPU device";
    exact_term::ExactConfig config;
    EXPECT_TRUE(exact_term::runs_host_code(devices.front(), config));
    config.kernel_on_cpu_devices = true;
    EXPECT_FALSE(exact_term::runs_host_code(devices.front(), config));

    SamplingPlan plan;
    plan.method = Method::exact;
    plan.tolerance = 1e-10;
    auto oracle = make_oracle_backend(2);
    auto opencl = make_opencl_backend(devices);
    const std::vector<Estimate> reference = evaluate(*oracle, queries, TermOptions{}, plan);
    const std::vector<Estimate> host = evaluate(*opencl, queries, TermOptions{}, plan);
    plan.kernel_on_cpu_devices = true;
    const std::vector<Estimate> kernel = evaluate(*opencl, queries, TermOptions{}, plan);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        EXPECT_EQ(host[i].term, reference[i].term) << "query " << i;
        EXPECT_LE(std::fabs(kernel[i].term - reference[i].term), kernel[i].std_error + reference[i].std_error + 1e-12)
            << "query " << i;
        differ += kernel[i].term != reference[i].term;
    }
    // The kernel is other code (its own rounding): some values differ in their last bits, or it did not run.
    EXPECT_GT(differ, 0u) << "--exact-kernel did not run the kernel";
}

// ---- Whole exact bakes against an independent reference ----
// Every texel of whole exact bakes against an independent reference, within the texel's recorded
// estimate: the recorded error of an exact LUT is a bound, not a typical size.
//
// The reference is the mean over the azimuth of the exact term at a tight tolerance, integrated by a
// rule of its own: the azimuths where the term is not analytic found numerically (sign changes of the
// event functions on a fine scan, refined by bisection), each interval in the cosine substitution that
// makes a square-root onset analytic, and composite Gauss-Legendre there (4 panels of 12 nodes, checked
// against 2 panels: the coarser rule's error, far above the finer's); the difference of the two plus the terms' own estimated errors is the reference's uncertainty, which the
// check adds to the recorded estimate (and which must stay far below the tolerance, or the reference
// proves nothing).
namespace {

using namespace ms;

struct ReferenceMean {
    double value = 0, uncertainty = 0;
};

// Roots in (0, pi) of g, from sign changes on `scan` steps, each refined by bisection to rounding.
template <class F>
void add_roots(const F& g, int scan, std::vector<double>& roots) {
    double a = 0, ga = g(0.0);
    for (int i = 1; i <= scan; ++i) {
        const double b = kPi * i / scan, gb = g(b);
        if ((ga < 0) != (gb < 0)) {
            double lo = a, hi = b, glo = ga;
            for (int k = 0; k < 60 && hi - lo > 1e-15; ++k) {
                const double m = 0.5 * (lo + hi), gm = g(m);
                if ((gm < 0) == (glo < 0)) lo = m, glo = gm;
                else hi = m;
            }
            roots.push_back(0.5 * (lo + hi));
        }
        a = b;
        ga = gb;
    }
}

// Composite Gauss-Legendre with `panels` panels of `nodes` nodes over u in [0, pi] of
// T(mid - half cos u) half sin u; `error` gathers the terms' weighted estimated errors.
double composite_rule(double v, double alpha, double nv, double nl, double lo, double hi, int panels, int nodes,
                      double& error) {
    const exact::GaussRule& g = exact::gauss_legendre(nodes);
    const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
    double sum = 0;
    for (int p = 0; p < panels; ++p) {
        const double u0 = kPi * p / panels, u1 = kPi * (p + 1) / panels;
        for (int i = 0; i < nodes; ++i) {
            const double u = 0.5 * (u0 + u1) + 0.5 * (u1 - u0) * g.nodes[i];
            const double w = g.weights[i] * 0.5 * (u1 - u0) * half * std::sin(u);
            const exact::ExactValue t =
                exact::exact_term_at_azimuth(v, alpha, nv, nl, mid - half * std::cos(u), AoWeighting::cosine, 1e-11);
            sum += w * t.term;
            error += w * t.error;
        }
    }
    return sum;
}

ReferenceMean reference_mean(double v, double alpha, double nv, double nl) {
    const double c = cone_cos_theta(v, AoWeighting::cosine), s = std::sqrt(cone_sin2_theta(v, AoWeighting::cosine));
    const Vec3 wi{std::sqrt(1 - nv * nv), 0, nv};
    const double sl = std::sqrt(1 - nl * nl);
    auto wo = [&](double phi) { return Vec3{sl * std::cos(phi), sl * std::sin(phi), nl}; };
    auto dot3 = [](const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; };
    std::vector<double> cuts{0.0, kPi};
    // The cap round wo touches the great circle normal to wi.
    add_roots([&](double phi) { return std::pow(dot3(wi, wo(phi)), 2) - s * s; }, 512, cuts);
    // The circle round wo passes through a point where the circle round e_z meets that great circle:
    // the solutions of m.z = c, m.wi = 0, |m| = 1 (wi lies in the xz plane).
    const double mx = -c * nv / wi.x, my2 = 1 - c * c - mx * mx;
    if (my2 > 0)
        for (double sign : {-1.0, 1.0}) {
            const Vec3 meet{mx, sign * std::sqrt(my2), c};
            add_roots([&](double phi) { return dot3(meet, wo(phi)) - c; }, 512, cuts);
        }
    std::sort(cuts.begin(), cuts.end());
    ReferenceMean out;
    double value_error = 0;
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
        if (cuts[i + 1] - cuts[i] < 1e-14) continue;
        const double fine = composite_rule(v, alpha, nv, nl, cuts[i], cuts[i + 1], 4, 12, value_error);
        double unused = 0;
        const double coarse = composite_rule(v, alpha, nv, nl, cuts[i], cuts[i + 1], 2, 12, unused);
        out.value += fine;
        out.uncertainty += std::fabs(fine - coarse);
    }
    out.value /= kPi;
    out.uncertainty = (out.uncertainty + value_error) / kPi + 1e-14;
    return out;
}

struct BoundCheck {
    std::size_t checked = 0, outside = 0;
    double worst_ratio = 0, worst_error = 0, worst_reference_uncertainty = 0;
    // The same ratio over texels whose recorded error is mostly the quadrature's (above 4 half-ulps of
    // the float value, 2^-23), where the ratio says how tight the estimate is rather than the rounding.
    double worst_quadrature_ratio = 0;
    std::size_t quadrature_dominated = 0;
};

// Which evaluator bakes: the C++ evaluator (oracle backend) or the OpenCL kernel on the default device
// (a CPU device too; in double where the device has fp64, as PoCL's CPU device has).
enum class BakeEngine { cpp, kernel };

// Every computed texel of an exact bake of the seed-3d layout at `size` against the reference.
BoundCheck check_whole_bake(std::uint32_t size, double tolerance, BakeEngine engine = BakeEngine::cpp) {
    BakeSpec spec = default_bake_spec(LutLayout::seed_3d, size);
    spec.method = Method::exact;
    spec.tolerance = tolerance;
    if (engine == BakeEngine::cpp) {
        spec.backend.kind = schedule::Backend::Kind::oracle;  // the C++ evaluator
    } else {
        spec.exact_kernel_on_cpu = true;
    }
    const BakeResult bake = bake_lut(spec);
    EXPECT_TRUE(bake.tolerance_met);
    const std::uint32_t channels = std::uint32_t(spec.roughness.size());
    const AtlasShape shape{spec.visibility.count, spec.n_dot_l.count, spec.n_dot_v.count, channels};
    struct Texel {
        std::size_t at;
        double v, alpha, nv, nl;
    };
    std::vector<Texel> texels;
    for (std::uint32_t ch = 0; ch < channels; ++ch)
        for (std::uint32_t ivv = 0; ivv < spec.n_dot_v.count; ++ivv)
            for (std::uint32_t il = 0; il < spec.n_dot_l.count; ++il)
                for (std::uint32_t iv = 0; iv < spec.visibility.count; ++iv) {
                    const double v = spec.visibility.value(iv), nl = std::max(spec.n_dot_l.value(il), kMinNdotL);
                    const std::size_t at = shape.index(ch, iv, il, ivv);
                    // Exact 0 and 1 are written by rule (checked elsewhere); the rest are quadratures.
                    if (v >= 1 || in_zero_region(cone_cos_theta(v, AoWeighting::cosine), nl)) continue;
                    const double r = spec.roughness[ch];
                    texels.push_back({at, v, r * r, std::max(spec.n_dot_v.value(ivv), kMinNdotV), nl});
                }
    std::vector<ReferenceMean> reference(texels.size());
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads; ++t)
        pool.emplace_back([&, t] {
            for (std::size_t i = t; i < texels.size(); i += threads)
                reference[i] = reference_mean(texels[i].v, texels[i].alpha, texels[i].nv, texels[i].nl);
        });
    for (auto& t : pool) t.join();
    BoundCheck check;
    for (std::size_t i = 0; i < texels.size(); ++i) {
        const Texel& x = texels[i];
        const double stored = bake.value[x.at], recorded = bake.std_error[x.at];
        const double error = std::fabs(stored - reference[i].value);
        ++check.checked;
        check.worst_reference_uncertainty = std::max(check.worst_reference_uncertainty, reference[i].uncertainty);
        check.worst_error = std::max(check.worst_error, error);
        const double ratio = error > reference[i].uncertainty ? (error - reference[i].uncertainty) / recorded : 0.0;
        check.worst_ratio = std::max(check.worst_ratio, ratio);
        if (recorded > std::ldexp(1.0, -23)) {
            ++check.quadrature_dominated;
            check.worst_quadrature_ratio = std::max(check.worst_quadrature_ratio, ratio);
        }
        if (error > recorded + reference[i].uncertainty) {
            if (++check.outside <= 10)
                ADD_FAILURE() << "v " << x.v << " alpha " << x.alpha << " NdotV " << x.nv << " NdotL " << x.nl << ": stored "
                              << stored << " +- " << recorded << ", reference " << reference[i].value << " +- "
                              << reference[i].uncertainty;
        }
        EXPECT_LE(recorded, tolerance);
    }
    // The reference must resolve the tolerance, or the check is empty.
    EXPECT_LT(check.worst_reference_uncertainty, 0.01 * tolerance);
    std::printf("exact bake (%s) %u^3 x %u at %g: %zu texels, worst error %.3g, worst (error - reference uncertainty) / "
                "recorded estimate %.3g (%.3g over the %zu texels whose estimate is mostly quadrature), reference "
                "uncertainty <= %.2g\n",
                engine == BakeEngine::cpp ? "C++ evaluator" : "OpenCL kernel", size, channels, tolerance, check.checked, check.worst_error, check.worst_ratio,
                check.worst_quadrature_ratio, check.quadrature_dominated, check.worst_reference_uncertainty);
    return check;
}

TEST(ExactBakeBounds, EveryTexelOfA16CubedBakeIsWithinItsRecordedEstimate) {
    if (ms::testing::kAsan) GTEST_SKIP() << "whole-bake accuracy runs in the optimised build";
    const BoundCheck check = check_whole_bake(16, 1e-6);
    EXPECT_EQ(check.outside, 0u);
    EXPECT_GT(check.checked, 10000u);
}

// The kernel's azimuth means are bisected in the azimuth itself, without the C++ evaluator's grading:
// its own whole bake against the same reference (its estimate, from two Gauss rules on each piece, was
// up to 91x too small on 3 of these texels).
TEST(ExactBakeBounds, EveryTexelOfA16CubedKernelBakeIsWithinItsRecordedEstimate) {
    if (ms::testing::kAsan) GTEST_SKIP() << "whole-bake accuracy runs in the optimised build";
    const BoundCheck check = check_whole_bake(16, 1e-6, BakeEngine::kernel);
    EXPECT_EQ(check.outside, 0u);
    EXPECT_GT(check.checked, 10000u);
}

TEST(ExactBakeBounds, EveryTexelOfA24CubedBakeIsWithinItsRecordedEstimate) {
    if (ms::testing::kAsan) GTEST_SKIP() << "whole-bake accuracy runs in the optimised build";
    const BoundCheck check = check_whole_bake(24, 1e-6);
    EXPECT_EQ(check.outside, 0u);
    EXPECT_GT(check.checked, 30000u);
}

}  // namespace

namespace {

// `bake --verify` on an exact bake recomputes texels as the exact mean they are (an exact bake has no
// azimuth node rule): every texel of a 1e-4 bake passes, and every texel moved by 3 t of its recorded
// error plus 1e-6 (so that the float value moves however small its error) fails.
TEST(ExactBakeBounds, VerifyJudgesAnExactBakeAgainstTheExactMean) {
    using namespace ms;
    BakeSpec spec = default_bake_spec(LutLayout::seed_3d, 12);
    spec.method = Method::exact;
    spec.tolerance = 1e-4;
    spec.backend.kind = schedule::Backend::Kind::oracle;
    const BakeResult result = bake_lut(spec);
    const BakeVerification right = verify_bake(spec, result, result.value.size(), 0, 2, Method::exact);
    EXPECT_GT(right.checked, 4000u);
    EXPECT_EQ(right.failed, 0u) << right.worst_texel;
    EXPECT_LE(right.max_reference_error, 1e-9);
    BakeResult shifted = result;
    for (std::size_t i = 0; i < shifted.value.size(); ++i)
        if (shifted.std_error[i] > 0) {
            const double move = 3 * right.threshold * shifted.std_error[i] + 1e-6;
            shifted.value[i] += float(shifted.value[i] > 0.5 ? -move : move);
        }
    const BakeVerification caught = verify_bake(spec, shifted, shifted.value.size(), 0, 2, Method::exact);
    EXPECT_EQ(caught.failed, caught.checked);
}

}  // namespace
