#include "core/estimate.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ms {

ReplicateRatioMean::ReplicateRatioMean(std::uint32_t replicates) : x_(replicates, 0.0) {
    if (replicates == 0) throw std::invalid_argument("ReplicateRatioMean: no replicates");
}

void ReplicateRatioMean::add(double weight, const double* cone, const double* hemisphere, std::size_t stride) {
    double cone_sum = 0, hemi_sum = 0;
    for (std::size_t r = 0; r < x_.size(); ++r) {
        const double c = cone[r * stride], h = hemisphere[r * stride];
        cone_sum += c;
        hemi_sum += h;
        x_[r] += weight * (h > 0 ? c / h : 0.0);
    }
    if (hemi_sum > 0) value_ += weight * (cone_sum / hemi_sum);
}

double ReplicateRatioMean::std_error() const {
    const std::size_t R = x_.size();
    if (R < 2) return 0;
    double mean = 0;
    for (double x : x_) mean += x;
    mean /= double(R);
    double ss = 0;
    for (double x : x_) ss += (x - mean) * (x - mean);
    return std::sqrt(ss / (double(R) * double(R - 1)));
}

Estimate reduce_replicates(const double* cone, const double* hemisphere, std::size_t replicates) {
    ReplicateRatioMean mean{std::uint32_t(replicates)};
    mean.add(1.0, cone, hemisphere);
    return mean.estimate();
}

double binomial_zero_bound(double total, double confidence) {
    if (!(total > 0)) return 1.0;
    return -std::expm1(std::log1p(-confidence) / total);  // 1 - (1 - c)^(1/n), accurate for large n
}

namespace {
// Regularised incomplete beta by Lentz's continued fraction (Numerical Recipes' formulation), enough
// for the t distribution's CDF: P(|T| > t) = I_{df/(df+t^2)}(df/2, 1/2).
double incomplete_beta_cf(double a, double b, double x) {
    const double tiny = 1e-300;
    double c = 1, d = 1 - (a + b) * x / (a + 1);
    d = 1 / (std::abs(d) < tiny ? tiny : d);
    double h = d;
    // The fraction needs O(sqrt(max(a, b))) terms (Numerical Recipes 6.4): 500 covers the t quantiles,
    // binomial bounds on billions of samples need more.
    const int terms = std::max(500, int(std::min(4.0e6, 10 * std::sqrt(a + b) + 100)));
    for (int m = 1; m < terms; ++m) {
        const double m2 = 2.0 * m;
        double aa = m * (b - m) * x / ((a + m2 - 1) * (a + m2));
        d = 1 + aa * d; d = 1 / (std::abs(d) < tiny ? tiny : d);
        c = 1 + aa / c; c = std::abs(c) < tiny ? tiny : c;
        h *= d * c;
        aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1));
        d = 1 + aa * d; d = 1 / (std::abs(d) < tiny ? tiny : d);
        c = 1 + aa / c; c = std::abs(c) < tiny ? tiny : c;
        const double delta = d * c;
        h *= delta;
        if (std::abs(delta - 1) < 1e-15) break;
    }
    return h;
}
double regularised_beta(double a, double b, double x) {
    if (x <= 0) return 0;
    if (x >= 1) return 1;
    const double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log(1 - x));
    if (x < (a + 1) / (a + b + 2)) return front * incomplete_beta_cf(a, b, x) / a;
    return 1 - front * incomplete_beta_cf(b, a, 1 - x) / b;
}
double two_sided_tail(double t, int df) { return regularised_beta(df / 2.0, 0.5, df / (df + t * t)); }
}  // namespace

double student_t_quantile(double confidence, int df) {
    if (!(confidence > 0 && confidence < 1) || df < 1) throw std::invalid_argument("student_t_quantile: bad arguments");
    const double tail = 1 - confidence;
    double lo = 0, hi = 1e6;
    for (int i = 0; i < 200; ++i) {  // bisection: the tail probability decreases in t
        const double mid = 0.5 * (lo + hi);
        (two_sided_tail(mid, df) > tail ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

double binomial_agreement_bound(double passed, double total, double confidence) {
    if (!(total > 0)) return 1.0;
    if (!(passed > 0) || !(passed < total)) return binomial_zero_bound(total, confidence);
    const double k = passed, n = total, f = k / n, tail = (1 - confidence) / 2;
    // P(X >= k | p) = I_p(k, n - k + 1) rises with p; P(X <= k | p) = 1 - I_p(k + 1, n - k) falls with p.
    // Bisection on each (the brackets hold the answer: the tails are 0 and 1 at the ends). 120 halvings
    // of [0, 1] reach 1e-36, far below the smallest bound (about 1 / n).
    double lo_a = 0, lo_b = f;
    for (int i = 0; i < 120; ++i) {
        const double mid = 0.5 * (lo_a + lo_b);
        (regularised_beta(k, n - k + 1, mid) < tail ? lo_a : lo_b) = mid;
    }
    double hi_a = f, hi_b = 1;
    for (int i = 0; i < 120; ++i) {
        const double mid = 0.5 * (hi_a + hi_b);
        (1 - regularised_beta(k + 1, n - k, mid) > tail ? hi_a : hi_b) = mid;
    }
    return std::max(hi_b - f, f - lo_a);  // the outer ends of the brackets: never smaller than the bound
}

Estimate reduce_count_replicates(const CountTally& tally, std::size_t replicates, double confidence) {
    Estimate e = reduce_replicates(tally.numerator, tally.denominator, replicates);
    // The quantile takes ~1e5 operations; a batch asks for the same one query after query.
    thread_local double cached_confidence = -1, cached_t = 1;
    thread_local std::size_t cached_replicates = 0;
    if (confidence != cached_confidence || replicates != cached_replicates) {
        cached_t = replicates > 1 ? student_t_quantile(confidence, int(replicates) - 1) : 1.0;
        cached_confidence = confidence;
        cached_replicates = replicates;
    }
    const double t = cached_t;
    double passed = 0, total = 0;
    for (std::size_t r = 0; r < replicates; ++r) {
        passed += tally.numerator_count[r];
        total += tally.denominator_count[r];
    }
    if (!(total > 0)) {
        e.std_error = 1.0 / t;  // no sample in the denominator: the ratio is anywhere in [0, 1]
        return e;
    }
    passed = std::min(passed, total);
    const bool passes_rare = passed <= total - passed;
    const double rare = passes_rare ? passed : total - passed;
    // Whether every replicate saw the rare outcome equally often: the spread then measures only the
    // denominators' jitter (~1e-9), not the uncertainty of the rare count.
    bool rare_counts_agree = true;
    for (std::size_t r = 1; r < replicates && rare_counts_agree; ++r) {
        const auto rare_of = [&](std::size_t i) {
            return passes_rare ? tally.numerator_count[i] : tally.denominator_count[i] - tally.numerator_count[i];
        };
        rare_counts_agree = rare_of(r) == rare_of(0);
    }
    if (e.std_error == 0 || rare_counts_agree || rare < kFewRareEvents)
        e.std_error = std::max(e.std_error, binomial_agreement_bound(passed, total, confidence) / t);
    return e;
}

}  // namespace ms
