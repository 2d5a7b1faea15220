// The C++ evaluator's per-query path (exact_term::make_cpu_evaluator().terms): isotropic queries of a
// batch are grouped by their row (visibility, alpha, NdotL, AO weighting) and evaluated through one
// exact::AzimuthGrid per row, the view's relative azimuth taken from the query's own vectors; the other
// queries go to exact::exact_term. Checked here: that every isotropic value is its row's grid value (the
// frame: relative azimuth of wo from wi, in any absolute orientation), that values agree with
// exact_term within both estimates and with exact_term at a 1000x tighter tolerance within the grid's
// estimate plus the reference's, that results come back in input order whatever the mix, and that the
// threaded evaluator returns the same bits as the single-threaded one; and the exact-rows benchmark's
// smoke run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "core/query.hpp"
#include "core/types.hpp"
#include "exact/azimuth_grid.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#if __has_include("bench.hpp")  // bench/CMakeLists.txt links the benchmarks into this test binary
#include <string>

#include "bench.hpp"
#endif

namespace ms {
namespace {

Vec3 row_test_direction(double cos_theta, double azimuth) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(azimuth), s * std::sin(azimuth), cos_theta};
}

// A batch shaped like a job's references: rows of (visibility, alpha, NdotL, weighting), each with a
// few to many (NdotV, relative azimuth) values, every query at its own random absolute azimuth (so the
// relative azimuth must come from both vectors) with either sign of the relative azimuth; singleton
// rows, anisotropic queries and alpha above 1 (which go to exact_term) mixed in; the whole batch shuffled.
struct RowBatch {
    std::vector<Query> queries;
    std::vector<AoWeighting> weighting;
};
RowBatch row_test_batch(unsigned seed, int rows) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    RowBatch b;
    const double alphas[] = {0.002, 0.01, 0.05, 0.2, 0.5, 0.9, 1.0};
    for (int r = 0; r < rows; ++r) {
        const double v = r % 19 == 0 ? 1e-4 : r % 23 == 0 ? 0.9999 : u(rng);
        const double alpha = r % 3 == 0 ? alphas[r % 7] : 0.002 + 0.998 * u(rng) * u(rng);
        const double nl = r % 17 == 0 ? 1.0 : r % 13 == 0 ? 0.01 : 0.02 + 0.98 * u(rng);
        const AoWeighting w = r % 2 ? AoWeighting::cosine : AoWeighting::uniform;
        const int values = r % 5 == 0 ? 1 : r % 5 == 1 ? 2 : 3 + int(u(rng) * 40);
        const bool anisotropic = r % 11 == 5, rough = r % 29 == 7;
        for (int k = 0; k < values; ++k) {
            const double nv = k % 9 == 4 ? 1.0 : 0.02 + 0.98 * u(rng);
            const double phi = (2 * u(rng) - 1) * kPi, base = 2 * kPi * u(rng);
            Query q;
            q.visibility = v;
            q.alpha_x = q.alpha_y = rough ? 1.0 + 2 * u(rng) : alpha;
            if (anisotropic) q.alpha_y = alpha * (1.5 + 4 * u(rng));
            // Lengths other than 1: the evaluator takes normalised queries, and normalising moves wo.z by
            // an ulp or so depending on the azimuth.
            const double len_i = 0.5 + u(rng), len_o = 0.5 + u(rng);
            const Vec3 wi = row_test_direction(nv, base), wo = row_test_direction(nl, base + phi);
            q.wi = {wi.x * len_i, wi.y * len_i, wi.z * len_i};
            q.wo = {wo.x * len_o, wo.y * len_o, wo.z * len_o};
            b.queries.push_back(normalised(q));
            b.weighting.push_back(w);
        }
    }
    std::vector<std::size_t> perm(b.queries.size());
    for (std::size_t i = 0; i < perm.size(); ++i) perm[i] = i;
    std::shuffle(perm.begin(), perm.end(), rng);
    RowBatch s;
    for (std::size_t i : perm) {
        s.queries.push_back(b.queries[i]);
        s.weighting.push_back(b.weighting[i]);
    }
    return s;
}

bool row_test_isotropic(const Query& q) { return q.alpha_x == q.alpha_y && q.alpha_x <= 1; }

// Every value within both estimates of exact_term's at the same tolerance and of exact_term's at a
// 1000x tighter one (an independent check of the value: its estimate bounds the reference's error).
TEST(ExactTermRows, GridValuesAgreeWithThePerQueryEvaluatorWithinBothEstimates) {
    for (const double tolerance : {1e-10, 1e-7}) {
        const RowBatch b = row_test_batch(36, 260);
        std::vector<exact::ExactValue> got;
        exact_term::make_cpu_evaluator(1)->terms(b.queries, b.weighting, tolerance, got);
        ASSERT_EQ(got.size(), b.queries.size());
        double worst_same = 0, worst_tight = 0;
        std::size_t isotropic = 0;
        for (std::size_t i = 0; i < b.queries.size(); ++i) {
            const exact::ExactValue same = exact::exact_term(b.queries[i], b.weighting[i], tolerance);
            const exact::ExactValue tight = exact::exact_term(b.queries[i], b.weighting[i], tolerance * 1e-3);
            const double d_same = std::fabs(got[i].term - same.term), d_tight = std::fabs(got[i].term - tight.term);
            EXPECT_LE(d_same, got[i].error + same.error) << "query " << i << " tolerance " << tolerance;
            EXPECT_LE(d_tight, got[i].error + tight.error) << "query " << i << " tolerance " << tolerance;
            EXPECT_LE(got[i].error, tolerance) << "query " << i;
            if (got[i].error + same.error > 0) worst_same = std::max(worst_same, d_same / (got[i].error + same.error));
            if (got[i].error + tight.error > 0) worst_tight = std::max(worst_tight, d_tight / (got[i].error + tight.error));
            isotropic += row_test_isotropic(b.queries[i]);
        }
        EXPECT_GT(isotropic, b.queries.size() / 2);
        std::printf("tolerance %g: %zu queries (%zu isotropic), worst |rows - exact_term| / both estimates %.3g, "
                    "against 1000x tighter %.3g\n",
                    tolerance, b.queries.size(), isotropic, worst_same, worst_tight);
    }
}

// The frame: each isotropic value is exactly the grid value of its row (its own visibility, alpha, wo.z
// and weighting) at (wi.z, azimuth of wo from wi); anisotropic queries and alpha above 1 are exact_term's
// values. Failed before the grouping (every value was exact_term's).
TEST(ExactTermRows, IsotropicQueriesTakeTheirRowsGridValueAtTheRelativeAzimuth) {
    const RowBatch b = row_test_batch(7, 120);
    std::vector<exact::ExactValue> got;
    exact_term::make_cpu_evaluator(1)->terms(b.queries, b.weighting, exact::kDefaultTolerance, got);
    std::size_t on_grid = 0;
    for (std::size_t i = 0; i < b.queries.size(); ++i) {
        const Query& q = b.queries[i];
        ASSERT_EQ(exact_term::on_grid(q), row_test_isotropic(q));
        if (!row_test_isotropic(q)) {
            const exact::ExactValue want = exact::exact_term(q, b.weighting[i]);
            EXPECT_EQ(got[i].term, want.term) << "query " << i;
            EXPECT_EQ(got[i].error, want.error) << "query " << i;
            continue;
        }
        // The evaluator's relative azimuth is the difference of the two vectors' own azimuths.
        const double phi = exact_term::relative_azimuth(q);
        const double phi_wi = std::atan2(q.wi.y, q.wi.x), phi_wo = std::atan2(q.wo.y, q.wo.x);
        if (std::hypot(q.wi.x, q.wi.y) > 1e-12 && std::hypot(q.wo.x, q.wo.y) > 1e-12)
            EXPECT_LE(std::fabs(std::remainder(phi - (phi_wo - phi_wi), 2 * kPi)), 1e-14) << "query " << i;
        const exact::AzimuthGrid grid(q.visibility, q.alpha_x, q.wo.z, b.weighting[i]);
        const exact::ExactValue want = grid.term(q.wi.z, phi);
        EXPECT_EQ(got[i].term, want.term) << "query " << i;
        EXPECT_EQ(got[i].error, want.error) << "query " << i;
        // The term is even in the azimuth: the mirrored view gives it within both estimates.
        const exact::ExactValue mirrored = grid.term(q.wi.z, -phi);
        EXPECT_NEAR(got[i].term, mirrored.term, want.error + mirrored.error + 1e-15) << "query " << i;
        ++on_grid;
    }
    EXPECT_GT(on_grid, b.queries.size() / 2);
}

// A value depends on its query alone: each query evaluated in a batch of its own gives the bits it got
// in the shuffled batch with its row's other queries (a job's values must not depend on how its queries
// are cut into work items, e.g. a scene's tiles).
TEST(ExactTermRows, AValueDoesNotDependOnTheRestOfItsBatch) {
    const RowBatch b = row_test_batch(5, 60);
    std::vector<exact::ExactValue> together;
    const auto evaluator = exact_term::make_cpu_evaluator(1);
    evaluator->terms(b.queries, b.weighting, 1e-9, together);
    for (std::size_t i = 0; i < b.queries.size(); ++i) {
        std::vector<exact::ExactValue> alone;
        evaluator->terms({b.queries[i]}, {b.weighting[i]}, 1e-9, alone);
        ASSERT_EQ(alone.size(), 1u);
        EXPECT_EQ(alone[0].term, together[i].term) << "query " << i;
        EXPECT_EQ(alone[0].error, together[i].error) << "query " << i;
    }
}

// A threaded evaluator splits the batch's runs over threads: the same bits as one thread.
TEST(ExactTermRows, ThreadedEvaluatorReturnsTheSameBits) {
    const RowBatch b = row_test_batch(11, 150);
    std::vector<exact::ExactValue> one, three;
    exact_term::make_cpu_evaluator(1)->terms(b.queries, b.weighting, 1e-8, one);
    exact_term::make_cpu_evaluator(3)->terms(b.queries, b.weighting, 1e-8, three);
    ASSERT_EQ(one.size(), three.size());
    for (std::size_t i = 0; i < one.size(); ++i) {
        EXPECT_EQ(one[i].term, three[i].term) << "query " << i;
        EXPECT_EQ(one[i].error, three[i].error) << "query " << i;
    }
}

#if __has_include("bench.hpp")
// The exact-rows benchmark (bench/exact_rows.cpp) at its smoke size, so it cannot rot; no timing is
// asserted, but its comparison is: on every set the rows' values agree with exact_term's within the sum
// of both estimates.
TEST(ExactTermRows, BenchmarkRunsAndItsValuesAgreeWithinBothEstimates) {
    bench::Options opt;
    opt.smoke = true;
    const bench::Table t = bench::run_exact_rows(opt);
    ASSERT_EQ(t.rows.size(), 10u);  // 5 sets x 2 tolerances
    const auto over = std::find(t.columns.begin(), t.columns.end(), "max_difference_over_estimates");
    ASSERT_NE(over, t.columns.end());
    for (const auto& row : t.rows)
        EXPECT_LE(std::stod(row[std::size_t(over - t.columns.begin())]), 1.0) << row[0] << " at " << row[1];
}
#endif

}  // namespace
}  // namespace ms
