// core/error_stats.hpp: the error statistics behind eval --compare, sweep summaries, scene and
// scene-bake reports and design's tables. Known answers on sets small enough to compute by hand, and a
// merge that gives the bits of one pass.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "core/error_stats.hpp"

namespace {

using ms::ErrorStats;
using ms::GroupedErrorStats;

std::uint64_t bits(double x) {
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
}

// Every figure of two statistics, bit for bit.
void expect_same_bits(const ErrorStats& a, const ErrorStats& b) {
    EXPECT_EQ(a.count(), b.count());
    for (auto get : {&ErrorStats::max_abs, &ErrorStats::sum, &ErrorStats::sum_abs, &ErrorStats::sum_sq, &ErrorStats::weight,
                     &ErrorStats::weighted_sum_sq, &ErrorStats::mean_abs, &ErrorStats::bias, &ErrorStats::rms,
                     &ErrorStats::weighted_rms})
        EXPECT_EQ(bits((a.*get)()), bits((b.*get)()));
    if (a.keeps_values() && b.keeps_values()) {
        EXPECT_EQ(bits(a.nearest_rank(0.99)), bits(b.nearest_rank(0.99)));
        EXPECT_EQ(bits(a.weighted_quantile(0.99)), bits(b.weighted_quantile(0.99)));
    }
}

// Errors and weights of many magnitudes (a fixed linear congruential sequence), so that sums of partial
// sums round differently from one pass.
void pairs(std::size_t n, std::vector<double>& e, std::vector<double>& w) {
    std::uint64_t x = 12345;
    auto next = [&] {
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        return double(x >> 11) / double(1ull << 53);
    };
    for (std::size_t i = 0; i < n; ++i) {
        e.push_back((next() - 0.5) * std::pow(10.0, -6 + 6 * next()));
        w.push_back(i % 7 == 0 ? 0.0 : next());
    }
}

}  // namespace

TEST(ErrorStats, StreamingFiguresOnAHandComputableSet) {
    // e = 1, -2, 3 with w = 1, 0, 3: sum w e^2 = 1 + 0 + 27 = 28 over sum w = 4.
    ErrorStats s;
    s.add(1, 1);
    s.add(-2, 0);
    s.add(3, 3);
    EXPECT_EQ(s.count(), 3u);
    EXPECT_EQ(s.max_abs(), 3.0);
    EXPECT_EQ(s.mean_abs(), 2.0);
    EXPECT_DOUBLE_EQ(s.bias(), 2.0 / 3.0);
    EXPECT_DOUBLE_EQ(s.rms(), std::sqrt(14.0 / 3.0));
    EXPECT_DOUBLE_EQ(s.weighted_rms(), std::sqrt(7.0));
    EXPECT_THROW(s.nearest_rank(0.99), std::logic_error);  // streaming only
}

TEST(ErrorStats, WeightedQuantileIsWhereTheWeightLies) {
    // |e| = 0.1, 0.2, 0.3, 0.4 carrying 60 %, 39.5 %, 0.25 %, 0.25 % of the weight, given out of order,
    // and a large error of weight 0: 99 % of the weight lies at |e| <= 0.2.
    ErrorStats s(ErrorStats::Keep::values);
    s.add(-0.3, 0.25);
    s.add(0.1, 60);
    s.add(5.0, 0);
    s.add(0.4, 0.25);
    s.add(-0.2, 39.5);
    EXPECT_EQ(s.weighted_quantile(0.99), 0.2);
    EXPECT_EQ(s.weighted_quantile(0.5), 0.1);
    EXPECT_EQ(s.weighted_quantile(1.0), 0.4);
    // The nearest-rank quantile ignores the weights: the ceil(0.99 x 5) = 5th smallest |e|.
    EXPECT_EQ(s.nearest_rank(0.99), 5.0);
    EXPECT_EQ(s.nearest_rank(0.5), 0.3);  // ceil(2.5) = 3rd of 0.1, 0.2, 0.3, 0.4, 5
    EXPECT_EQ(s.max_abs(), 5.0);
}

TEST(ErrorStats, NearestRankIsTheCeilingRank) {
    ErrorStats hundred(ErrorStats::Keep::values), two_hundred(ErrorStats::Keep::values);
    for (int i = 100; i >= 1; --i) hundred.add(-i);
    for (int i = 1; i <= 200; ++i) two_hundred.add(i);
    EXPECT_EQ(hundred.nearest_rank(0.99), 99.0);       // ceil(99) = 99th
    EXPECT_EQ(two_hundred.nearest_rank(0.99), 198.0);  // ceil(198) = 198th
    EXPECT_EQ(two_hundred.nearest_rank(0.0), 1.0);     // at least the first
    EXPECT_EQ(two_hundred.nearest_rank(1.0), 200.0);
    EXPECT_EQ(ms::nearest_rank_index(1, 0.99), 0u);
    EXPECT_EQ(ms::nearest_rank_index(101, 0.99), 99u);  // ceil(99.99) = 100th
    std::vector<float> layer = {0.5f, 0.25f, 1.0f, 0.75f};
    EXPECT_EQ(ms::nearest_rank(layer.begin(), layer.end(), 0.5), 0.5f);
}

TEST(ErrorStats, EmptyAndZeroWeightStatisticsAreZeros) {
    const ErrorStats empty(ErrorStats::Keep::values);
    EXPECT_EQ(empty.count(), 0u);
    for (double v : {empty.max_abs(), empty.mean_abs(), empty.bias(), empty.rms(), empty.weighted_rms(),
                     empty.nearest_rank(0.99), empty.weighted_quantile(0.99)})
        EXPECT_EQ(bits(v), bits(0.0));
    // Points of weight 0 count for the unweighted figures only.
    ErrorStats unweighted(ErrorStats::Keep::values);
    unweighted.add(0.5, 0);
    unweighted.add(-1.5, 0);
    EXPECT_EQ(unweighted.count(), 2u);
    EXPECT_EQ(unweighted.max_abs(), 1.5);
    EXPECT_DOUBLE_EQ(unweighted.rms(), std::sqrt(1.25));
    EXPECT_EQ(unweighted.weighted_rms(), 0.0);
    EXPECT_EQ(unweighted.weighted_quantile(0.99), 0.0);
    EXPECT_EQ(unweighted.nearest_rank(0.99), 1.5);
}

TEST(ErrorStats, MergeInOrderGivesTheBitsOfOnePass) {
    std::vector<double> e, w;
    pairs(1000, e, w);
    ErrorStats one_pass(ErrorStats::Keep::values);
    for (std::size_t i = 0; i < e.size(); ++i) one_pass.add(e[i], w[i]);
    bool partial_sums_differ = false;
    for (std::size_t cut : {1u, 137u, 500u, 999u}) {
        // The first part streaming (it is merged into), the rest in two kept parts, merged in order.
        ErrorStats first, second(ErrorStats::Keep::values), third(ErrorStats::Keep::values);
        const std::size_t cut2 = (cut + e.size()) / 2;
        for (std::size_t i = 0; i < e.size(); ++i) (i < cut ? first : i < cut2 ? second : third).add(e[i], w[i]);
        // What a merge of sums would give: not the bits of one pass (that is why merge replays).
        partial_sums_differ |= bits(first.sum_sq() + second.sum_sq() + third.sum_sq()) != bits(one_pass.sum_sq()) ||
                               bits(first.weighted_sum_sq() + second.weighted_sum_sq() + third.weighted_sum_sq()) !=
                                   bits(one_pass.weighted_sum_sq());
        // Merged into the streaming first part (the sums), and into a kept copy of it (the quantiles too).
        ErrorStats kept_first(ErrorStats::Keep::values);
        for (std::size_t i = 0; i < cut; ++i) kept_first.add(e[i], w[i]);
        for (ErrorStats* into : {&first, &kept_first}) {
            into->merge(second);
            into->merge(third);
            expect_same_bits(*into, one_pass);
        }
    }
    EXPECT_TRUE(partial_sums_differ);
    ErrorStats streamed;
    streamed.add(1);
    ErrorStats target;
    EXPECT_THROW(target.merge(streamed), std::logic_error);  // its values are gone
    EXPECT_NO_THROW(target.merge(ErrorStats()));              // nothing to replay
    // Into itself: its pairs twice.
    ErrorStats twice(ErrorStats::Keep::values);
    twice.add(1, 1);
    twice.add(-3, 2);
    twice.merge(twice);
    EXPECT_EQ(twice.count(), 4u);
    EXPECT_EQ(twice.sum(), -4.0);
}

TEST(ErrorStats, GroupedStatisticsFeedEachGroupOfAColumn) {
    GroupedErrorStats g(2, 2, ErrorStats::Keep::values);  // groups: 0 all, 1 a band
    const std::size_t all_and_band[2] = {0, 1}, all_only[1] = {0};
    g.add(0, all_and_band, 2, 0.5);
    g.add(0, all_only, 1, -1.0);
    g.add(1, all_and_band, 2, 2.0, 3.0);
    const std::size_t later = g.add_group();
    EXPECT_EQ(later, 2u);
    EXPECT_EQ(g.groups(), 3u);
    const std::size_t all_and_later[2] = {0, later};
    g.add(1, all_and_later, 2, -4.0);
    EXPECT_EQ(g.at(0, 0).count(), 2u);
    EXPECT_EQ(g.at(0, 1).count(), 1u);
    EXPECT_EQ(g.at(0, 2).count(), 0u);
    EXPECT_EQ(g.at(1, 0).count(), 2u);
    EXPECT_EQ(g.at(1, 1).max_abs(), 2.0);  // kept through add_group
    EXPECT_EQ(g.at(1, 1).weight(), 3.0);
    EXPECT_EQ(g.at(1, 2).sum(), -4.0);
    EXPECT_TRUE(g.at(1, 2).keeps_values());
    GroupedErrorStats whole = g;
    whole.merge(g);
    EXPECT_EQ(whole.at(1, 0).count(), 4u);
    EXPECT_THROW(whole.merge(GroupedErrorStats(2, 2)), std::invalid_argument);
}
