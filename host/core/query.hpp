// Checking and normalising a query of the term: one rule for every reader (CSV, sweeps, scenes) and
// every job, so a query the CSV reader accepts is one the evaluator accepts.
#pragma once

#include "core/types.hpp"

namespace ms {

// Throws std::invalid_argument naming the problem if a query is not valid input:
// visibility in [0, 1], alpha_x and alpha_y > 0 and finite, non-zero finite directions, wi above the horizon.
void validate_query(const Query& q);
// Unit-length copy of the query's directions, computed in double (hypot: no intermediate under- or
// overflow, so (1e-200, 0, 1e-200) is a valid direction).
Query normalised(const Query& q);

}  // namespace ms
