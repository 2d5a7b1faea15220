// Error statistics of an approximation against a reference: the one accumulator behind eval --compare,
// sweep summaries, scene and scene-bake reports and design's tables.
//
// It takes (error, weight) pairs, error = approximation - reference and weight >= 0 (1 when a study
// does not weight; a study whose errors are already weighted passes those with weight 1).
//
// Streaming, in the order of add (bounded memory):
//   count            n
//   max_abs          max |e|
//   mean_abs, bias   sum |e| / n, sum e / n
//   rms              sqrt(sum e^2 / n)                 (unweighted)
//   weighted_rms     sqrt(sum w e^2 / sum w)           (0 when sum w = 0)
// With Keep::values the pairs are kept too, for the two quantiles (0 when there is nothing to rank):
//   nearest_rank(q)       the ceil(q n)-th smallest |e| (1-based, at least the first): an order statistic
//                         of the points, whatever their weights.
//   weighted_quantile(q)  the smallest |e| whose cumulative weight, |e| ascending (equal |e|: lighter
//                         first), reaches q x sum w: the error below which a share q of the weight lies.
//                         Points of weight 0 never decide it.
//
// Every sum is the plain left-to-right sum in the order the pairs were added: the reports print these
// doubles, and a sum of partial sums rounds differently. So merge() replays the later accumulator's kept
// pairs through add(): a run split into tiles or shards and merged in their order gives the same bits as
// one pass.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace ms {

class ErrorStats {
public:
    enum class Keep { streaming, values };

    ErrorStats() = default;
    explicit ErrorStats(Keep keep) : keep_(keep) {}

    void add(double error, double weight = 1.0) {
        const double a = std::fabs(error);
        ++count_;
        max_abs_ = std::max(max_abs_, a);
        sum_ += error;
        sum_abs_ += a;
        sum_sq_ += error * error;
        weight_ += weight;
        weighted_sq_ += weight * error * error;
        if (keep_ == Keep::values) kept_.emplace_back(error, weight);
    }
    // As if `later`'s pairs had been added after this one's, bit for bit. Throws std::logic_error when
    // `later` holds pairs it did not keep (its sums alone cannot continue this one's).
    void merge(const ErrorStats& later);

    bool keeps_values() const { return keep_ == Keep::values; }
    std::uint64_t count() const { return count_; }
    double max_abs() const { return max_abs_; }
    double sum() const { return sum_; }
    double sum_abs() const { return sum_abs_; }
    double sum_sq() const { return sum_sq_; }
    double weight() const { return weight_; }
    double weighted_sum_sq() const { return weighted_sq_; }

    double mean_abs() const { return count_ ? sum_abs_ / double(count_) : 0; }
    double bias() const { return count_ ? sum_ / double(count_) : 0; }
    double rms() const { return count_ ? std::sqrt(sum_sq_ / double(count_)) : 0; }
    double weighted_rms() const { return weight_ > 0 ? std::sqrt(weighted_sq_ / weight_) : 0; }

    // The quantiles above, q in [0, 1]. Throw std::logic_error without Keep::values.
    double nearest_rank(double q) const;
    double weighted_quantile(double q) const;

    // The kept (e, w) pairs in the order of add.
    const std::vector<std::pair<double, double>>& kept() const { return kept_; }

private:
    Keep keep_ = Keep::streaming;
    std::uint64_t count_ = 0;
    double max_abs_ = 0, sum_ = 0, sum_abs_ = 0, sum_sq_ = 0, weight_ = 0, weighted_sq_ = 0;
    std::vector<std::pair<double, double>> kept_;
};

// The 0-based index of the nearest-rank q-quantile among n > 0 values: ceil(q n) - 1, within [0, n - 1].
inline std::size_t nearest_rank_index(std::size_t n, double q) {
    const double rank = std::ceil(q * double(n));
    return rank <= 1 ? 0 : std::min(n - 1, std::size_t(rank) - 1);
}

// The nearest-rank q-quantile of the values in [first, last), which it reorders (std::nth_element);
// 0 for an empty range. For callers that hold their values already (a scene's error layers).
template <class RandomIt>
typename std::iterator_traits<RandomIt>::value_type nearest_rank(RandomIt first, RandomIt last, double q) {
    const auto n = std::size_t(last - first);
    if (n == 0) return 0;
    const auto at = first + std::ptrdiff_t(nearest_rank_index(n, q));
    std::nth_element(first, at, last);
    return *at;
}

// Error statistics per column (a comparator) and group (all points, a roughness band, a material):
// one ErrorStats per cell, each pair added to the cells of its column's groups.
class GroupedErrorStats {
public:
    GroupedErrorStats() = default;
    GroupedErrorStats(std::size_t columns, std::size_t groups, ErrorStats::Keep keep = ErrorStats::Keep::streaming)
        : columns_(columns), groups_(groups), keep_(keep), cells_(columns * groups, ErrorStats(keep)) {}

    std::size_t columns() const { return columns_; }
    std::size_t groups() const { return groups_; }
    // A new, empty group in every column; its index.
    std::size_t add_group();

    // The pair into column `column` of each of groups[0 .. count).
    void add(std::size_t column, const std::size_t* groups, std::size_t count, double error, double weight = 1.0) {
        for (std::size_t g = 0; g < count; ++g) at(column, groups[g]).add(error, weight);
    }
    ErrorStats& at(std::size_t column, std::size_t group) { return cells_[column * groups_ + group]; }
    const ErrorStats& at(std::size_t column, std::size_t group) const { return cells_[column * groups_ + group]; }
    // Cell by cell (ErrorStats::merge); std::invalid_argument for another shape.
    void merge(const GroupedErrorStats& later);

private:
    std::size_t columns_ = 0, groups_ = 0;
    ErrorStats::Keep keep_ = ErrorStats::Keep::streaming;
    std::vector<ErrorStats> cells_;  // [column][group], column-major
};

// The summary the scene and scene-bake reports give of a comparator's error against the reference at
// lit points, in one type with one JSON form (to_json), its weighting in its names:
//   lit_*    of the lit error |approximation - reference| x max(N.L, 0) x intensity: each point's
//            error multiplied by its light, every point counting once (the error a viewer sees in the
//            lit image; not the weighted mean sqrt(sum w e^2 / sum w) that ErrorStats::weighted_rms is)
//   term_*   of the term's own error |approximation - reference|, unweighted
// p99: the nearest-rank 99th percentile of the lit errors.
struct LitErrorSummary {
    std::uint64_t count = 0;  // lit points (pixels x lights, or sampled lookups)
    double lit_max_abs = 0, lit_rms = 0, lit_p99 = 0;
    double term_max_abs = 0, term_rms = 0;
    // From the statistics of the lit and of the unweighted errors at the same points.
    static LitErrorSummary of(const ErrorStats& lit, const ErrorStats& term, double lit_p99) {
        return {lit.count(), lit.max_abs(), lit.rms(), lit_p99, term.max_abs(), term.rms()};
    }
};
// The version of the JSON form of LitErrorSummary, written beside the summaries as "error_schema", and
// the sentence written as "error_weighting".
inline constexpr int kErrorSummarySchema = 1;
inline constexpr const char* kLitErrorWeighting =
    "lit_*: of |approximation - reference| x max(N.L, 0) x intensity per point, each point counted once; "
    "term_*: of |approximation - reference|, unweighted; p99: nearest rank";
// {"count", "lit_max_abs", "lit_rms", "lit_p99", "term_max_abs", "term_rms"} (nlohmann's to_json, so
// json(summary) writes it).
void to_json(nlohmann::json& j, const LitErrorSummary& s);

}  // namespace ms
