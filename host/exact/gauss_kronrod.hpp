// Gauss-Kronrod pairs on [-1, 1]: the n-point Gauss-Legendre rule and its (2n+1)-point Kronrod
// extension, which reuses the n Gauss nodes and adds n + 1 between them. One set of 2n+1 values gives
// both rules: the Kronrod sum (exact for polynomials of degree 3n+1) as the value and its difference to
// the Gauss sum (degree 2n-1) as an estimate of the Gauss rule's error, which bounds the Kronrod rule's
// once the Gauss rule converges.
#pragma once

namespace ms::exact {

struct KronrodRule {
    int gauss_nodes = 0;         // n
    int points = 0;              // 2n + 1
    const double* nodes;         // the 2n + 1 nodes, ascending; the Gauss nodes are those of odd index
    const double* kronrod_weights;  // 2n + 1 weights, summing to 2
    const double* gauss_weights;    // 2n + 1 weights, zero at the Kronrod-only nodes, summing to 2
};

// The pair for n = 8 (17 points) or n = 12 (25 points); other n are refused (std::invalid_argument).
const KronrodRule& gauss_kronrod(int gauss_nodes);

}  // namespace ms::exact
