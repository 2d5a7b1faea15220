// One error summary for the scene and scene-bake reports (core/error_stats.hpp LitErrorSummary): the
// lit statistics are of the pre-weighted errors, each point once (not the weighted mean that
// ErrorStats::weighted_rms is), and one JSON form names each figure with its weighting.
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/error_stats.hpp"

namespace ms {
namespace {

TEST(LitErrorSummary, NamesItsWeightingAndIsNotTheWeightedMean) {
    // Two lit points: errors 0.1 and 0.3 under lights N.L x intensity 1 and 0.5.
    ErrorStats lit(ErrorStats::Keep::values), term, weighted;
    const double e[2] = {0.1, 0.3}, w[2] = {1.0, 0.5};
    for (int i = 0; i < 2; ++i) {
        lit.add(e[i] * w[i]);
        term.add(e[i]);
        weighted.add(e[i], w[i]);
    }
    const LitErrorSummary s = LitErrorSummary::of(lit, term, lit.nearest_rank(0.99));
    EXPECT_EQ(s.count, 2u);
    EXPECT_DOUBLE_EQ(s.lit_max_abs, 0.15);
    EXPECT_DOUBLE_EQ(s.lit_rms, std::sqrt((0.01 + 0.0225) / 2));
    EXPECT_DOUBLE_EQ(s.lit_p99, 0.15);
    EXPECT_DOUBLE_EQ(s.term_max_abs, 0.3);
    EXPECT_DOUBLE_EQ(s.term_rms, std::sqrt((0.01 + 0.09) / 2));
    // The weighted mean sqrt(sum w e^2 / sum w) is another figure, under another name.
    EXPECT_NE(s.lit_rms, weighted.weighted_rms());
    const nlohmann::json j = s;
    EXPECT_EQ(j, (nlohmann::json{{"count", 2}, {"lit_max_abs", s.lit_max_abs}, {"lit_rms", s.lit_rms}, {"lit_p99", 0.15},
                                 {"term_max_abs", 0.3}, {"term_rms", s.term_rms}}));
    EXPECT_EQ(kErrorSummarySchema, 1);
}

}  // namespace
}  // namespace ms
