// Point sets, replicate statistics and the host-side cone bookkeeping.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "sampling/point_set.hpp"

namespace ms {
namespace {

TEST(PointSet, ScrambledHammersleyIsANetInEveryReplicate) {
    // A (0,m,2)-net in base 2: every elementary box [a 2^-k, (a+1) 2^-k) x [b 2^-(m-k), ...) holds
    // exactly one of the n = 2^m points, for every k. Owen scrambling must preserve this.
    const PointSet ps = make_point_set({Sequence::sobol, 8 * 1024, 8, 42});
    const int m = 10;
    ASSERT_EQ(ps.points_per_replicate, 1u << m);
    for (std::uint32_t r = 0; r < ps.replicates; ++r)
        for (int k = 0; k <= m; ++k) {
            std::set<std::uint64_t> boxes;
            for (std::uint32_t i = 0; i < ps.points_per_replicate; ++i) {
                const std::uint64_t bx = std::uint64_t(ps.u1[r * 1024 + i] * double(1u << k));
                const std::uint64_t by = std::uint64_t(ps.u2[r * 1024 + i] * double(1u << (m - k)));
                boxes.insert(bx << 32 | by);
            }
            EXPECT_EQ(boxes.size(), 1u << m) << "replicate " << r << " k " << k;
        }
}

TEST(PointSet, DeterministicPerSeedAndIndependentAcrossSeeds) {
    const PointSet a = make_point_set({Sequence::sobol, 4096, 8, 7});
    const PointSet b = make_point_set({Sequence::sobol, 4096, 8, 7});
    const PointSet c = make_point_set({Sequence::sobol, 4096, 8, 8});
    EXPECT_EQ(a.u1, b.u1);
    EXPECT_EQ(a.u2, b.u2);
    EXPECT_NE(a.u1, c.u1);
    // Replicates differ from each other too.
    EXPECT_FALSE(std::equal(a.u1.begin(), a.u1.begin() + 512, a.u1.begin() + 512));
}

TEST(PointSet, RandomPointsAreUniform) {
    // Mean of n uniforms: standard error sqrt(1/12 / n); 5 sigma.
    const PointSet ps = make_point_set({Sequence::random, 1 << 16, 8, 3});
    double m1 = 0, m2 = 0;
    for (std::size_t i = 0; i < ps.u1.size(); ++i) m1 += ps.u1[i], m2 += ps.u2[i];
    const double n = double(ps.u1.size()), se = std::sqrt(1.0 / 12.0 / n);
    EXPECT_NEAR(m1 / n, 0.5, 5 * se);
    EXPECT_NEAR(m2 / n, 0.5, 5 * se);
    for (float u : ps.u1) ASSERT_TRUE(u >= 0.0f && u < 1.0f);
}

TEST(PointSet, RejectsBadPlansAndRoundsUp) {
    EXPECT_THROW(make_point_set({Sequence::sobol, 1000, 8, 0}), std::invalid_argument);
    EXPECT_THROW(make_point_set({Sequence::sobol, 64, 8, 0}), std::invalid_argument);  // 8 per replicate < 16
    EXPECT_THROW(make_point_set({Sequence::sobol, 4096, 0, 0}), std::invalid_argument);
    EXPECT_EQ(round_up_samples(65536, 8), 65536u);
    EXPECT_EQ(round_up_samples(100000, 8), 131072u);
    EXPECT_EQ(round_up_samples(1, 8), 128u);
}

TEST(PointSet, OwenScrambleIsABijectionOnPrefixes) {
    // Nested scrambling permutes the 2^k dyadic intervals at every level: distinct top-k bits map to
    // distinct top-k bits.
    const int k = 12;
    std::set<std::uint32_t> seen;
    for (std::uint32_t i = 0; i < (1u << k); ++i) seen.insert(owen_scramble(i << (32 - k), 0x1234567u) >> (32 - k));
    EXPECT_EQ(seen.size(), 1u << k);
    EXPECT_EQ(reverse_bits(1u), 0x80000000u);
    EXPECT_EQ(reverse_bits(reverse_bits(0xdeadbeefu)), 0xdeadbeefu);
}

TEST(Estimate, PooledRatioAndReplicateSpread) {
    const double cone[4] = {1, 2, 3, 2}, hemi[4] = {4, 4, 4, 4};
    const Estimate e = reduce_replicates(cone, hemi, 4);
    EXPECT_DOUBLE_EQ(e.term, 8.0 / 16.0);
    // ratios 0.25 0.5 0.75 0.5: mean 0.5, sum of squares 0.125, se = sqrt(0.125 / 12)
    EXPECT_DOUBLE_EQ(e.std_error, std::sqrt(0.125 / 12.0));
    const double zero[4] = {0, 0, 0, 0};
    const Estimate z = reduce_replicates(zero, zero, 4);
    EXPECT_EQ(z.term, 0.0);
    EXPECT_EQ(z.std_error, 0.0);
}

TEST(Estimate, StudentTQuantilesMatchTables) {
    EXPECT_NEAR(student_t_quantile(0.95, 10), 2.228, 1e-3);
    EXPECT_NEAR(student_t_quantile(0.99, 7), 3.499, 1e-3);
    EXPECT_NEAR(student_t_quantile(0.999, 7), 5.408, 1e-3);
    EXPECT_NEAR(student_t_quantile(0.95, 1000), 1.962, 1e-3);
}

TEST(Cone, MappingAndZeroRegion) {
    EXPECT_DOUBLE_EQ(cone_cos_theta(0.36, AoWeighting::cosine), 0.8);
    EXPECT_DOUBLE_EQ(cone_cos_theta(0.25, AoWeighting::uniform), 0.75);
    // Part 2's early-out for cosine weighting: 2 v + NdotL <= 1. The grid (v = k/64, NdotL odd/128)
    // never lies on the boundary, so float rounding of sqrt cannot decide a case.
    for (int k = 0; k <= 64; ++k)
        for (int j = 0; j < 64; ++j) {
            const double v = k / 64.0, l = (2 * j + 1) / 128.0;
            EXPECT_EQ(in_zero_region(cone_cos_theta(v, AoWeighting::cosine), l), 2 * v + l <= 1) << v << " " << l;
        }
    EXPECT_TRUE(in_zero_region(0.0, 0.0));  // light on the horizon
    EXPECT_TRUE(in_zero_region(0.0, -0.5));
}

}  // namespace
}  // namespace ms

namespace ms {
namespace {
TEST(PointSet, SharedPointSetsAreGeneratedOnceAndEqualFreshOnes) {
    const SamplingPlan plan{Sequence::sobol, 1 << 17, 8, 77};
    const auto a = shared_point_set(plan);
    const auto b = shared_point_set(plan);
    EXPECT_EQ(a.get(), b.get());
    const PointSet fresh = make_point_set(plan);  // also checks threaded generation == itself
    EXPECT_EQ(a->u1, fresh.u1);
    EXPECT_EQ(a->u2, fresh.u2);
    SamplingPlan other = plan;
    other.sequence = Sequence::random;
    EXPECT_NE(shared_point_set(other).get(), a.get());
}
}  // namespace
}  // namespace ms
