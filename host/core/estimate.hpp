// Turning per-replicate tallies into an estimate with a standard error.
#pragma once

#include <cstddef>

#include "core/types.hpp"

namespace ms {

// GenericM_g is a ratio of two integrals over the same samples. With R independent randomisations
// (replicates) of the point set, the pooled ratio sum(cone) / sum(hemisphere) is the estimate, and
// the spread of the per-replicate ratios gives its standard error:
//     se = sqrt( sum_r (ratio_r - mean ratio)^2 / (R (R - 1)) ).
// A replicate whose hemisphere sum is 0 contributes ratio 0 (the term's definition). When every
// hemisphere sum is 0 the term is 0 by definition, with error 0.
Estimate reduce_replicates(const double* cone, const double* hemisphere, std::size_t replicates);

// Two-sided Student-t quantile for the given confidence (e.g. 0.999) and degrees of freedom, used to
// turn a standard error with few replicates into an error bar that holds with that confidence.
double student_t_quantile(double confidence, int degrees_of_freedom);

}  // namespace ms
