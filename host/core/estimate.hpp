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

// The estimate of a ratio of counts with an error bar that holds when the rarer outcome is rare.
//
// Derivation. Replicate r has h_r samples in the denominator and c_r of them in the numerator; the
// estimate is C / H (C = sum c_r, H = sum h_r) and the usual 99.9 % bar is t * se, t the Student-t
// quantile with R - 1 degrees of freedom and se from the spread of the replicate ratios c_r / h_r
// (ReplicateRatioMean). That bar assumes the replicate ratios are roughly normal. It fails when the
// rarer outcome among the H samples, k = min(C, H - C) of them, is seen only a few times:
//  - a replicate's rare count then takes a few integer values, and on a stratified point set it varies
//    little (a (0,m,2)-net puts nearly the same number of points into a small region every time), so
//    all R replicates give the same rare count with probability sum_c P(c)^R: 1 to 4 % of seeds for
//    grazing views of roughness 1e-4 with about one rare sample per replicate. The spread is then 0,
//    or only the jitter of the h_r (~1e-9), while C / H is off by a few counts: 300 to 20,000
//    reported standard errors. (The replicates are independent: over 300 seeds, agreement is as
//    frequent as sum_c P(c)^R predicts, and the counts of two replicates are uncorrelated.)
//  - with many small replicates (R = 32 of 2048 points) one rare sample in one replicate makes the
//    replicate mean skewed, and its bar (t = 3.6 at 31 degrees of freedom) misses in 1.3 % of such
//    queries instead of 0.1 %.
// The pooled counts do not depend on how the samples spread over replicates. Given the H samples in
// the denominator, each lies in the numerator with probability p (the ratio being estimated): with
// independent points C ~ Binomial(H, p), and the two-sided Clopper-Pearson interval [p_lo, p_hi] at
// confidence c covers p with probability >= c for every p and H (exact; one-sided at k = 0 or H;
// binomial_agreement_bound). A scrambled (0,m,2)-net's count has at most a small multiple of the
// binomial variance (Owen 1997: at most e times, for nested uniform scrambling), and less where it
// was measured (the coverage in docs/method.md). So where the
// spread cannot be trusted the bar is the larger of t * se and the binomial half-width
// B = max(p_hi - f, f - p_lo), f = C / H: when k < kFewRareEvents, when every replicate saw the rare
// outcome equally often, or when se = 0. Elsewhere the replicate ratios are close enough to normal for
// t * se alone (measured per range of k: docs/method.md). The bar is reported as std_error = bar / t,
// so that the usual t * std_error is it. H = 0 (no sample in the denominator) says nothing of the
// ratio, which lies in [0, 1]: the value stays 0 and the bar is 1.
struct CountTally {
    const double* numerator;        // per replicate: what the ratio sums (weights or counts)
    const double* denominator;
    const double* numerator_count;  // per replicate: how many samples passed each
    const double* denominator_count;
};
inline constexpr double kFewRareEvents = 64;
Estimate reduce_count_replicates(const CountTally& tally, std::size_t replicates, double confidence = 0.999);

// Two-sided Student-t quantile for the given confidence (e.g. 0.999) and degrees of freedom, used to
// turn a standard error with few replicates into an error bar that holds with that confidence.
double student_t_quantile(double confidence, int degrees_of_freedom);

}  // namespace ms
