// Gauss-Legendre rules on [-1, 1], computed once (Newton iteration on the Legendre recurrence) and
// shared read-only by every thread.
#pragma once

#include <vector>

namespace ms::exact {

struct GaussRule {
    std::vector<double> nodes, weights;  // n nodes in (-1, 1), ascending; weights sum to 2
};

// The n-point rule, 1 <= n <= 64. Thread-safe; the rules are built on first use.
const GaussRule& gauss_legendre(int n);

}  // namespace ms::exact
