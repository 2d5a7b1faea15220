// Numerical stability at the extremes: the float OpenCL kernel against the double oracle on the SAME
// point set, over a grid of extreme roughness, anisotropy, view/light cosines and visibilities.
//
// Why the same points: both backends consume one ms::PointSet, so a difference is not sampling noise
// but the float kernel deciding a sample differently from the double oracle (a sample whose decisive
// dot product lies within float rounding of a cone boundary), or a systematic failure (a quantity the
// float kernel cannot represent). Each such "flip" moves the ratio by about 1 / hemisphere count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <sstream>

#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "core/query.hpp"
#include "exact/exact_term.hpp"
#include "integrands/term/term_integrand.hpp"
#include "jobs/eval.hpp"
#include "io/csv.hpp"
#include "device/runtime.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"

namespace ms {
namespace {

// The extremes of the domain. NdotV = 0 (wi at the horizon) is invalid input and tested separately.
const double kNdotV[] = {1e-7, 1e-3, 0.5, 1 - 1e-7, 1};
const double kNdotL[] = {0, 1e-7, 1e-3, 0.5, 1 - 1e-7, 1};
// Tiny visibilities down to 1e-12: float cos_t is 1 below ~6e-8, so these exercise the kernel's tangent
// form of the cone test (generic_term.cl). Below ~1e-12 the double oracle's own cosine test stops
// resolving 1 - cos_t = v/2 (double rounding ~1e-16), so it could no longer referee.
const double kVisibility[] = {0, 1e-12, 1e-10, 1e-7, 1e-5, 1e-3, 0.25, 0.5, 0.75, 1 - 1e-7, 1};
// Relative azimuth of wo to wi (radians); wi itself sits at 30 degrees, off both anisotropy axes.
const double kAzimuth[] = {0, M_PI / 2, M_PI};
constexpr double kPhiI = M_PI / 6;

struct Roughness {
    double ax, ay;
};
// alpha from 1e-4 to 1 isotropic, and alpha_x / alpha_y = 1000 both ways within [1e-4, 1].
const Roughness kRoughness[] = {{1e-4, 1e-4}, {1e-3, 1e-3}, {1e-2, 1e-2}, {0.1, 0.1}, {0.5, 0.5},
                                {1, 1},       {1, 1e-3},    {1e-3, 1},    {0.1, 1e-4}, {1e-4, 0.1}};

// A unit direction with the given cosine to the normal; exact (0,0,1) at cosine 1 (along the normal).
Vec3 direction(double cos_theta, double phi) {
    if (cos_theta == 1) return {0, 0, 1};
    const double s = std::sqrt((1 - cos_theta) * (1 + cos_theta));  // no cancellation near 1
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

struct Grid {
    std::vector<Query> queries;
    std::vector<std::string> labels;
    // Indices of queries that differ only in visibility (ascending), for the monotonicity check.
    std::vector<std::vector<std::size_t>> by_visibility;
};

Grid make_grid() {
    Grid g;
    for (const auto& r : kRoughness)
        for (double nv : kNdotV)
            for (double nl : kNdotL)
                for (double dphi : kAzimuth) {
                    if ((nv == 1 || nl == 1 || nl == 0) && dphi != 0) continue;  // azimuth undefined
                    std::vector<std::size_t> row;
                    for (double v : kVisibility) {
                        Query q;
                        q.visibility = v;
                        q.alpha_x = r.ax;
                        q.alpha_y = r.ay;
                        q.wi = direction(nv, kPhiI);
                        q.wo = direction(nl, kPhiI + dphi);
                        char label[200];
                        std::snprintf(label, sizeof label, "alpha=(%g,%g) NdotV=%.9g NdotL=%.9g dphi=%g deg v=%.9g",
                                      r.ax, r.ay, nv, nl, dphi * 180 / M_PI, v);
                        row.push_back(g.queries.size());
                        g.queries.push_back(q);
                        g.labels.push_back(label);
                    }
                    g.by_visibility.push_back(row);
                }
    return g;
}

std::unique_ptr<TermBackend> default_kernels() { return make_opencl_backend(ocl::select_devices("default")); }

// Small enough that the double oracle covers the ~4000-query grid in about a second per setting.
const SamplingPlan kPlan{Sequence::sobol, 4 * 1024, 4, 2024};

void expect_sane(const std::vector<Estimate>& r, const Grid& g, const std::string& who) {
    for (std::size_t i = 0; i < r.size(); ++i) {
        ASSERT_TRUE(std::isfinite(r[i].term) && std::isfinite(r[i].std_error)) << who << ": " << g.labels[i];
        ASSERT_GE(r[i].term, 0.0) << who << ": " << g.labels[i];
        ASSERT_LE(r[i].term, 1.0) << who << ": " << g.labels[i];
        ASSERT_GE(r[i].std_error, 0.0) << who << ": " << g.labels[i];
    }
    // Same points, growing cone: the cone condition set only grows with v, so tallies and the ratio
    // (same denominator) cannot decrease. Exact, no tolerance.
    for (const auto& row : g.by_visibility)
        for (std::size_t k = 1; k < row.size(); ++k)
            EXPECT_GE(r[row[k]].term, r[row[k - 1]].term) << who << ": not monotone at " << g.labels[row[k]];
}

// Cones the former cosine test could not resolve in float (1 - cos_t < 2^-12: up to 0.23 off at
// v = 1e-7). They are compared like every other query; the worst among them is reported apart.
bool tiny_cone(double visibility, AoWeighting ao) { return 1 - cone_cos_theta(visibility, ao) < 1.0 / 4096; }

struct Worst {
    double diff = 0;
    double flips = 0;  // the difference in samples: |diff| * hemisphere count
    std::string where;
    void update(double d, double f, const std::string& w) {
        if (d > diff) *this = {d, f, w};
    }
};

TEST(Stress, FloatKernelFollowsDoubleOracleAtTheExtremes) {
    const Grid g = make_grid();
    auto cl = default_kernels();
    auto oracle = make_oracle_backend();
    const PointSet points = make_point_set(kPlan);
    const std::size_t R = kPlan.replicates;
    // Two comparisons per query and weighting; Bonferroni keeps the family-wise false alarm <= 1e-3.
    const double k = student_t_quantile(1 - 1e-3 / double(2 * g.queries.size()), int(R) - 1);
    Worst worst, tiny_worst;
    std::size_t compared = 0, tiny = 0, sampled = 0;
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        const TermOptions opt{Form::height_correlated, ao};
        const auto a = evaluate(*cl, g.queries, opt, kPlan);
        EvalStats stats;
        const auto b = evaluate(*oracle, g.queries, opt, kPlan, &stats);
        sampled += stats.sampled;
        expect_sane(a, g, "opencl " + to_string(ao));
        expect_sane(b, g, "oracle " + to_string(ao));
        for (std::size_t i = 0; i < g.queries.size(); ++i) {
            const double diff = std::abs(a[i].term - b[i].term);
            // The kernel's hemisphere count: one sample decided differently moves the ratio by 1 / H.
            double hemi = 0;
            if (diff > 0) {
                const Tallies t = cl->tally({normalised(g.queries[i])}, opt, points);
                for (std::size_t r = 0; r < R; ++r) hemi += t.hemisphere[r];
            }
            const std::string where = g.labels[i] + " ao=" + to_string(ao);
            ++compared;
            worst.update(diff, diff * hemi, where);
            if (g.queries[i].visibility > 0 && tiny_cone(g.queries[i].visibility, ao)) {
                ++tiny;
                tiny_worst.update(diff, diff * hemi, where);
            }
            // Same points: what remains after the statistical error is at most one sample lying within
            // float rounding of a boundary (seen only where wo lies exactly on the cone, NdotL = cos_t).
            const double bound = k * std::hypot(a[i].std_error, b[i].std_error) + (hemi > 0 ? 1.0 / hemi : 0.0) + 1e-12;
            EXPECT_LE(diff, bound) << where << ": opencl " << a[i].term << " +- " << a[i].std_error << ", oracle "
                                   << b[i].term << " +- " << b[i].std_error;
        }
    }
    std::printf("[stress] %zu queries x 2 weightings (%zu sampled, %u x %u points each): %zu compared, worst "
                "|float - double| = %.3g (%.3g samples) at %s\n",
                g.queries.size(), sampled, kPlan.replicates, unsigned(kPlan.samples / kPlan.replicates), compared,
                worst.diff, worst.flips, worst.where.c_str());
    std::printf("[stress] of which tiny cones (1 - cos_t < 2^-12, 0 < v): %zu queries, worst %.3g (%.3g samples) at %s\n",
                tiny, tiny_worst.diff, tiny_worst.flips, tiny_worst.where.c_str());
}

TEST(Stress, FloatKernelResolvesConesOfEverySize) {
    // A family whose term hardly depends on the cone size: alpha = sin_t (the visible normals spread
    // over about the cone) and wo half a cone angle off the normal, so both cone conditions cut. The
    // former float cosine test was 0.04 off here at v = 1e-7 and counted nothing at 1e-9 (float cos_t
    // = 1); the tangent test must follow the oracle on the same points down to v = 1e-12, with a term
    // well inside (0, 1) so that agreement is not 0 = 0 or 1 = 1.
    auto cl = default_kernels();
    auto oracle = make_oracle_backend();
    const SamplingPlan plan{Sequence::sobol, 8 * 2048, 8, 77};
    const PointSet points = make_point_set(plan);
    const double visibilities[] = {1e-2, 1e-4, 1e-7, 1e-9, 1e-12};
    const double k = student_t_quantile(1 - 1e-3 / (2.0 * std::size(visibilities)), int(plan.replicates) - 1);
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        std::vector<Query> qs;
        for (double v : visibilities) {
            const double sin_t = std::sqrt(cone_sin2_theta(v, ao));
            const double half = 0.5 * std::asin(sin_t);  // from the sine: no cancellation for tiny angles
            Query q;
            q.visibility = v;
            q.alpha_x = sin_t;
            q.alpha_y = 0.7 * sin_t;
            q.wi = direction(0.6, 0.4);
            q.wo = {std::sin(half) * std::cos(2.0), std::sin(half) * std::sin(2.0), std::cos(half)};
            qs.push_back(q);
        }
        const TermOptions opt{Form::height_correlated, ao};
        const auto a = evaluate(*cl, qs, opt, plan);
        const auto b = evaluate(*oracle, qs, opt, plan);
        for (std::size_t i = 0; i < qs.size(); ++i) {
            const Tallies t = cl->tally({normalised(qs[i])}, opt, points);
            double hemi = 0;
            for (double h : t.hemisphere) hemi += h;
            ASSERT_GT(hemi, 0);
            const double bound = k * std::hypot(a[i].std_error, b[i].std_error) + 1.0 / hemi;
            EXPECT_GT(b[i].term, 0.05) << "v=" << qs[i].visibility << " ao=" << to_string(ao);
            EXPECT_LT(b[i].term, 0.95) << "v=" << qs[i].visibility << " ao=" << to_string(ao);
            EXPECT_LE(std::abs(a[i].term - b[i].term), bound)
                << "v=" << qs[i].visibility << " ao=" << to_string(ao) << ": opencl " << a[i].term << " +- "
                << a[i].std_error << ", oracle " << b[i].term << " +- " << b[i].std_error;
        }
    }
}

TEST(Stress, ViewAtTheHorizonIsRejected) {
    // wi.z = 0 makes the VNDF degenerate (the visible projected area is 0): invalid input, rejected
    // before any device work, however it is spelled.
    auto oracle = make_oracle_backend();
    for (const Vec3 wi : {Vec3{1, 0, 0}, Vec3{0, -1, 0}, Vec3{0.6, 0.8, 0}, Vec3{1, 0, -0.0}, Vec3{1, 0, -1e-300}}) {
        Query q;
        q.wi = wi;
        q.visibility = 0.5;
        EXPECT_THROW(validate_query(q), std::invalid_argument) << wi.x << "," << wi.y << "," << wi.z;
        EXPECT_THROW(evaluate(*oracle, {q}, {}, kPlan), std::invalid_argument);
    }
    // Grazing but valid: wi.z or wo.z so small that tan^2 overflows (z^2 underflows to 0). Smith
    // Lambda is then +inf (G1 = 0), never inf / inf; both backends must give a finite term in [0, 1].
    for (const auto& [wi, wo] : {std::pair{Vec3{1, 0, 1e-160}, direction(0.8, 0.3)},
                                 std::pair{Vec3{1, 0, 4.9e-324}, direction(0.8, 0.3)},
                                 std::pair{direction(0.5, 0.2), Vec3{0.8, 0.6, 1e-160}}}) {
        Query q;
        q.wi = wi;
        q.wo = wo;
        q.visibility = 0.9;  // outside the zero region even for wo at the horizon (2 v + NdotL > 1)
        for (auto* backend : {default_kernels().release(), make_oracle_backend().release()}) {
            std::unique_ptr<TermBackend> owned(backend);
            for (Form form : {Form::height_correlated, Form::uncorrelated}) {
                const auto r = evaluate(*owned, {q}, {form, AoWeighting::cosine}, kPlan);
                EXPECT_TRUE(std::isfinite(r[0].term) && r[0].term >= 0 && r[0].term <= 1)
                    << owned->name() << " " << to_string(form) << ": wi.z " << wi.z << " wo.z " << wo.z << ": " << r[0].term;
            }
        }
    }
}

TEST(Stress, BothFormsAgreeOnTheSamePointsAtTheExtremes) {
    // The Smith weight is constant per query apart from H(wo.wm) (generic_term.cl's header), so the
    // weighted oracle must give the same ratio in both forms, and the kernel (which drops the weight)
    // the same bits. Checked on the extreme grid's queries with 0 < v < 1 (tiny cones included) of one
    // roughness pair per anisotropy class to keep the double oracle's time small.
    const Grid g = make_grid();
    std::vector<Query> subset;
    for (std::size_t i = 0; i < g.queries.size(); ++i) {
        const Query& q = g.queries[i];
        const bool picked = (q.alpha_x == 1e-4 && q.alpha_y == 1e-4) || (q.alpha_x == 1 && q.alpha_y == 1e-3) ||
                            (q.alpha_x == 1e-4 && q.alpha_y == 0.1);
        if (picked && q.visibility > 0 && q.visibility < 1) subset.push_back(q);
    }
    auto cl = default_kernels();
    auto oracle = make_oracle_backend();
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        const auto hc = evaluate(*oracle, subset, {Form::height_correlated, ao}, kPlan);
        const auto un = evaluate(*oracle, subset, {Form::uncorrelated, ao}, kPlan);
        const auto k_hc = evaluate(*cl, subset, {Form::height_correlated, ao}, kPlan);
        const auto k_un = evaluate(*cl, subset, {Form::uncorrelated, ao}, kPlan);
        for (std::size_t i = 0; i < subset.size(); ++i) {
            // Equal up to the rounding of two compensated double sums and one division.
            EXPECT_NEAR(hc[i].term, un[i].term, 1e-12) << i;
            EXPECT_EQ(k_hc[i].term, k_un[i].term) << i;
            EXPECT_EQ(k_hc[i].std_error, k_un[i].std_error) << i;
        }
    }
}


// ---- The sampled term's error bars where few samples decide them -------------------------------------
// Replicates that agree on a rare count, a denominator no sample reached, and many small replicates
// with one rare sample among them. The bars are checked against the exact evaluator (host/exact, an
// independent method) or, for the replicate statistics alone, against counts drawn with a known
// probability.
constexpr double kBarsFamilyRisk = 0.001;

Query bars_query(double v, double ax, double ay, Vec3 wi, Vec3 wo) {
    Query q;
    q.visibility = v;
    q.alpha_x = ax;
    q.alpha_y = ay;
    q.wi = wi;
    q.wo = wo;
    return q;
}

// Sampled estimates of `queries` on the double oracle (the kernels count the same samples; the bars
// come from the integrand's reduction, which both share).
std::vector<Estimate> sampled_terms(const std::vector<Query>& queries, std::uint64_t samples, std::uint32_t replicates,
                                    std::uint64_t seed) {
    SamplingPlan plan;
    plan.samples = samples;
    plan.replicates = replicates;
    plan.seed = seed;
    term::TermIntegrand integrand(
        1, [](std::uint64_t) { return term::Batch{}; }, [](std::uint64_t, std::vector<Estimate>&&) {}, plan, {});
    term::Batch batch;
    batch.queries = queries;
    batch.options.assign(queries.size(), TermOptions{});
    const auto tallier = term::make_oracle_tallier();
    return integrand.evaluate(*tallier, batch);
}

// Grazing views (NdotV 4e-7 .. 1e-5) of roughness 1.5e-4 .. 4.2e-4, where every replicate of the
// default plan at seed 0 counts the same few rare samples (1 or 2 cone hits, or 1 miss, of 8192): the
// replicate spread was only the denominators' jitter, 1.9e-9 .. 6.8e-9, for errors of 4e-6 .. 4.3e-5
// (866 to 22,800 standard errors). And lights of these views' kind where no sample of 4096 faces the
// light: the estimate is 0 with nothing known, where the term is 0.08 .. 0.80.
TEST(TermBars, AgreeingRareCountsAndEmptyDenominatorsCoverTheExactTerm) {
    const std::vector<Query> agreeing = {
        bars_query(0.91324237938990538, 0.00015127686031702931, 0.00015127686031702931,
                   {0.84672816983044197, -0.53202575728562096, 5.0178107334293533e-07},
                   {-0.18012961489668922, 0.9527242011932775, 0.24468330204123401}),
        bars_query(0.75976705280805013, 0.00033668325623928137, 0.00033668325623928137,
                   {0.94055208116238631, -0.33964949966241403, 4.1891220945424228e-07},
                   {0.41417324577957565, 0.87130363363513541, 0.26323088818491835}),
        bars_query(0.71755222920770589, 0.0001830598878869947, 0.0001830598878869947,
                   {-0.7610841339561274, -0.64865317464695371, 7.7897135802325443e-06},
                   {-0.50406621300045462, 0.19686277428422713, 0.84092942689175632}),
        bars_query(0.65538780634454918, 0.00041596570885041198, 0.00041596570885041198,
                   {0.61553272653800728, 0.78811132617060775, 1.1058595789990058e-05},
                   {0.77333175475191607, -0.59917364570646203, 0.20724125888236977}),
    };
    const std::vector<Query> unreached = {
        bars_query(0.999993728845852, 0.06047068744399883, 0.7172127751339021,
                   {-0.22248442490853673, 0.9749362404531541, 8.7887356161872e-05},
                   {-0.006495045264591366, -0.9999789068351387, 1.64867107066987e-05}),
        bars_query(0.9999930091700785, 0.5978135107997337, 0.002833593751698469,
                   {-0.9153408060568383, 0.4026800321649116, 2.1514723722369893e-05},
                   {0.525454521123343, 0.850821688857843, 3.5479979008545187e-07}),
        bars_query(0.9999951779529472, 0.3177944659011455, 0.000154380133019451,
                   {0.7581966034577179, -0.6520156871744628, 0.003667994491970258},
                   {-0.6249090432602976, -0.7806975647620846, 5.103930489809783e-06}),
    };
    const std::size_t n = agreeing.size() + unreached.size();
    const double t = student_t_quantile(1 - kBarsFamilyRisk / double(n), 7);  // Bonferroni over the family
    auto check = [&](const std::vector<Query>& queries, const std::vector<Estimate>& sampled) {
        for (std::size_t i = 0; i < queries.size(); ++i) {
            const exact::ExactValue e = exact::exact_term(normalised(queries[i]), AoWeighting::cosine);
            ASSERT_GT(e.term, 1e-5) << "query " << i << ": a non-trivial term";
            EXPECT_LE(std::abs(sampled[i].term - e.term), t * sampled[i].std_error + e.error)
                << "query " << i << ": sampled " << sampled[i].term << " +- " << sampled[i].std_error << ", exact "
                << e.term;
        }
    };
    check(agreeing, sampled_terms(agreeing, 65536, 8, 0));
    check(unreached, sampled_terms(unreached, 4096, 8, 0));
}

// The replicate statistics on counts whose distribution is known: R = 32 replicates of h = 2048
// independent samples, each in the numerator with probability p, for expected rare counts from 0.5 to
// 48 over all replicates. The 99.9 % bar (t with 31 degrees of freedom times the reported error) must
// miss p in at most 0.1 % of trials; the t bar alone misses in ~1-3 % of them below 8 rare samples
// (one rare sample in one replicate: a skewed mean). A binomial count of the trials' misses is
// compared with the largest the 0.1 % rate allows with probability 1 - 1e-3 (Chernoff bound).
TEST(TermBars, FewRareSamplesInManyReplicatesKeepTheStatedCoverage) {
    constexpr std::uint32_t R = 32;
    constexpr double h = 2048;
    const double t = student_t_quantile(0.999, int(R) - 1);
    std::mt19937_64 rng(20261204);
    const std::vector<double> expected_rare = {0.5, 1, 2, 3, 5, 8, 12, 20, 32, 48};
    const int trials_each = 2000;
    int misses = 0, trials = 0;
    std::vector<double> cone(R), hemisphere(R, h);
    for (double lambda : expected_rare)
        for (int side = 0; side < 2; ++side) {  // rare passes (p small) and rare failures (p near 1)
            const double p = side == 0 ? lambda / (R * h) : 1 - lambda / (R * h);
            std::binomial_distribution<int> draw(int(h), p);
            for (int k = 0; k < trials_each; ++k) {
                for (std::uint32_t r = 0; r < R; ++r) cone[r] = draw(rng);
                const Estimate e = reduce_count_replicates({cone.data(), hemisphere.data(), cone.data(), hemisphere.data()}, R);
                misses += std::abs(e.term - p) > t * e.std_error;
                ++trials;
            }
        }
    // P(X >= m) <= exp(-mu) (e mu / m)^m for X ~ Binomial(trials, 0.001), mu = trials / 1000: the
    // smallest m with that below 1e-3.
    const double mu = trials * 0.001;
    int allowed = int(std::ceil(mu));
    while (-mu + allowed * std::log(M_E * mu / allowed) > std::log(1e-3)) ++allowed;
    EXPECT_LT(misses, allowed) << misses << " of " << trials << " bars missed p";
}

// No sample in the denominator: nothing is known of the ratio, so the bar spans [0, 1].
TEST(TermBars, AnEmptyDenominatorGivesABarOverTheWholeRange) {
    const std::vector<double> zeros(8, 0.0);
    const Estimate e = reduce_count_replicates({zeros.data(), zeros.data(), zeros.data(), zeros.data()}, 8);
    EXPECT_EQ(e.term, 0);
    EXPECT_NEAR(student_t_quantile(0.999, 7) * e.std_error, 1.0, 1e-12);
}

}  // namespace
}  // namespace ms
