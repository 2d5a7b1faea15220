// Evaluating the term on queries (included by <microshadow/microshadow.hpp>).
#pragma once

#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// The term at each query, in order.
std::vector<Estimate> evaluate(const std::vector<Query>& queries, const SamplingOptions& options = {});

}  // namespace microshadow
