#include "core/error_stats.hpp"

#include <stdexcept>

#include <nlohmann/json.hpp>
#include <string>

namespace ms {

void ErrorStats::merge(const ErrorStats& later) {
    if (later.count_ != later.kept_.size())
        throw std::logic_error("ErrorStats::merge: the later statistics did not keep their values");
    // Replayed, not summed: sum + later.sum would round differently from one pass.
    if (&later == this) {
        const auto pairs = kept_;  // add() grows kept_ while it is read
        for (const auto& [e, w] : pairs) add(e, w);
        return;
    }
    for (const auto& [e, w] : later.kept_) add(e, w);
}

double ErrorStats::nearest_rank(double q) const {
    if (keep_ != Keep::values) throw std::logic_error("ErrorStats::nearest_rank: the values were not kept");
    std::vector<double> values(kept_.size());
    for (std::size_t i = 0; i < kept_.size(); ++i) values[i] = std::fabs(kept_[i].first);
    return ms::nearest_rank(values.begin(), values.end(), q);
}

double ErrorStats::weighted_quantile(double q) const {
    if (keep_ != Keep::values) throw std::logic_error("ErrorStats::weighted_quantile: the values were not kept");
    if (!(weight_ > 0)) return 0;
    std::vector<std::pair<double, double>> by_size;
    by_size.reserve(kept_.size());
    for (const auto& [e, w] : kept_)
        if (w > 0) by_size.emplace_back(std::fabs(e), w);
    if (by_size.empty()) return 0;
    std::sort(by_size.begin(), by_size.end());
    // The target against the running total in the order of add (weight_), the cumulative in |e| order.
    const double target = q * weight_;
    double cumulative = 0;
    for (const auto& [a, w] : by_size) {
        cumulative += w;
        if (cumulative >= target) return a;
    }
    // Rounding can leave the cumulative a hair below q x total for q near 1: the largest error.
    return by_size.back().first;
}

std::size_t GroupedErrorStats::add_group() {
    std::vector<ErrorStats> cells;
    cells.reserve(columns_ * (groups_ + 1));
    for (std::size_t c = 0; c < columns_; ++c) {
        for (std::size_t g = 0; g < groups_; ++g) cells.push_back(std::move(cells_[c * groups_ + g]));
        cells.emplace_back(keep_);
    }
    cells_ = std::move(cells);
    return groups_++;
}

void GroupedErrorStats::merge(const GroupedErrorStats& later) {
    if (later.columns_ != columns_ || later.groups_ != groups_)
        throw std::invalid_argument("GroupedErrorStats::merge: " + std::to_string(later.columns_) + " x " +
                                    std::to_string(later.groups_) + " statistics into " + std::to_string(columns_) +
                                    " x " + std::to_string(groups_));
    for (std::size_t i = 0; i < cells_.size(); ++i) cells_[i].merge(later.cells_[i]);
}

void to_json(nlohmann::json& j, const LitErrorSummary& s) {
    j = {{"count", s.count},       {"lit_max_abs", s.lit_max_abs},   {"lit_rms", s.lit_rms},
         {"lit_p99", s.lit_p99},   {"term_max_abs", s.term_max_abs}, {"term_rms", s.term_rms}};
}

}  // namespace ms
