// Checking and normalising a query of the term: one rule for every reader (CSV, sweeps, scenes) and
// every job, so a query the CSV reader accepts is one the evaluator accepts.
#pragma once

#include "core/types.hpp"

namespace ms {

// Throws std::invalid_argument naming the problem if a query is not valid input:
// visibility in [0, 1], alpha_x and alpha_y > 0 and finite, non-zero finite directions, wi above the horizon.
void validate_query(const Query& q);
// The exact method's domain (host/exact): its boundary integrals lose every digit beyond an anisotropy
// max(alpha) / min(alpha) of ~1e8 (alpha_x 1e-9, alpha_y 0.25 gave 0.37 where the term is 0.74) and
// return NaN for alpha below ~1e-150 (alpha^2 nears the smallest normal double). Refused beyond these
// limits, with a factor of 10 of margin, naming the sampled method, which holds there.
inline constexpr double kExactMaxAnisotropy = 1e7;
inline constexpr double kExactMinAlpha = 1e-140;
// validate_query, then the exact method's domain above. Throws std::invalid_argument naming the limit.
void validate_exact_query(const Query& q);

// Unit-length copy of the query's directions, computed in double (hypot: no intermediate under- or
// overflow, so (1e-200, 0, 1e-200) is a valid direction).
Query normalised(const Query& q);

}  // namespace ms
