// Turning per-replicate tallies into an estimate with a standard error: the one replicate-statistics
// reduction of the project (eval, bake slices, the azimuth quadrature check, verify, benchmarks).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/types.hpp"

namespace ms {

// The estimator. GenericM_g is a ratio of two integrals over the same samples, and a LUT texel with an
// azimuth policy is a weighted mean of such ratios over quadrature nodes a (weights w_a; a fixed query
// is one node of weight 1). With R independent randomisations (replicates) of the point set and
// per-replicate tallies (c_ar, h_ar):
//     value = sum_a w_a (sum_r c_ar) / (sum_r h_ar)                 (pooled ratio per node)
//     x_r   = sum_a w_a c_ar / h_ar                                  (replicate r's own estimate)
//     se    = sqrt( sum_r (x_r - mean x)^2 / (R (R - 1)) )
// x_r combines the nodes before the spread is taken, which accounts for the correlation between nodes
// that share points. A ratio with a zero denominator counts as 0 (the term's definition), so a node no
// replicate reaches adds nothing. se is a Student-t quantity with R - 1 degrees of freedom.
// Weights may be negative: the quadrature check reduces T_K - T_K/2 with the same code.
class ReplicateRatioMean {
public:
    explicit ReplicateRatioMean(std::uint32_t replicates);
    // Adds one node: cone[r * stride], hemisphere[r * stride] for r < replicates.
    void add(double weight, const double* cone, const double* hemisphere, std::size_t stride = 1);
    double value() const { return value_; }
    double std_error() const;
    Estimate estimate() const { return {value_, std_error()}; }

private:
    std::vector<double> x_;
    double value_ = 0;
};

// One node of weight 1: the pooled ratio sum(cone) / sum(hemisphere) and its standard error.
Estimate reduce_replicates(const double* cone, const double* hemisphere, std::size_t replicates);

// When no sample (or every sample) of `total` passed, the replicate spread is 0 although the term is
// not known exactly. The exact one-sided binomial bound at `confidence` on the fraction that a pass
// (or a failure) can have and still produce that outcome: 1 - (1 - confidence)^(1 / total).
double binomial_zero_bound(double total, double confidence);

// When the replicates agree exactly although some samples passed and some failed (a stratified point
// set can give every replicate the same count: v 0.95, alpha 0.05, wi = wo = normal has one failure
// in each replicate's 8192 points), the spread is 0 too and says nothing about the error. The exact
// binomial (Clopper-Pearson) bound on how far the true fraction can be from passed / total:
// max(p_hi - f, f - p_lo) with P(X >= passed | p_lo) = P(X <= passed | p_hi) = (1 - confidence) / 2,
// so that the interval holds with `confidence` on both sides together. At passed = 0 or
// passed = total only one side exists and the bound is binomial_zero_bound(total, confidence), bit
// for bit. `passed` and `total` may be weighted (non-integer) counts; total > 0, 0 <= passed <= total.
double binomial_agreement_bound(double passed, double total, double confidence);

// Two-sided Student-t quantile for the given confidence (e.g. 0.999) and degrees of freedom, used to
// turn a standard error with few replicates into an error bar that holds with that confidence.
double student_t_quantile(double confidence, int degrees_of_freedom);

}  // namespace ms
