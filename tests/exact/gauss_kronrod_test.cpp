// The tabulated Gauss-Kronrod pairs: each integrates the monomials exactly to the degree its theory
// gives (Gauss 2n-1, Kronrod 3n+1 for even n) and no further, and its Gauss half is the Gauss-Legendre
// rule the rest of the exact method uses. A digit mistyped up to the 12th place fails the first check.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "exact/gauss_kronrod.hpp"
#include "exact/gauss_legendre.hpp"

namespace {

using ms::exact::gauss_kronrod;
using ms::exact::KronrodRule;

double exact_monomial(int k) { return k % 2 ? 0.0 : 2.0 / (k + 1); }

// sum w_i x_i^k, and a bound on its rounding: each term has at most k + 2 roundings and the sum
// `points` more, each a relative eps of the running magnitude sum |w_i x_i^k|, plus the tables' own
// rounding to 17 significant digits (1e-17 relative in every weight and node).
struct RuleSum {
    double value = 0, rounding_bound = 0;
};
RuleSum apply(const KronrodRule& rule, const double* weights, int k) {
    RuleSum s;
    double magnitude = 0;
    for (int i = 0; i < rule.points; ++i) {
        const double term = weights[i] * std::pow(rule.nodes[i], k);
        s.value += term;
        magnitude += std::fabs(term);
    }
    const double eps = std::numeric_limits<double>::epsilon();
    s.rounding_bound = (k + 2 + rule.points) * eps * magnitude + (k + 1) * 1e-17 * magnitude * rule.points;
    return s;
}

class GaussKronrod : public ::testing::TestWithParam<int> {};

TEST_P(GaussKronrod, IntegratesMonomialsExactlyToItsDegreeAndNotBeyond) {
    const int n = GetParam();
    const KronrodRule& rule = gauss_kronrod(n);
    ASSERT_EQ(rule.gauss_nodes, n);
    ASSERT_EQ(rule.points, 2 * n + 1);
    const int kronrod_degree = 3 * n + 1, gauss_degree = 2 * n - 1;
    for (int k = 0; k <= kronrod_degree; ++k) {
        const RuleSum s = apply(rule, rule.kronrod_weights, k);
        EXPECT_LE(std::fabs(s.value - exact_monomial(k)), s.rounding_bound) << "Kronrod, x^" << k;
    }
    for (int k = 0; k <= gauss_degree; ++k) {
        const RuleSum s = apply(rule, rule.gauss_weights, k);
        EXPECT_LE(std::fabs(s.value - exact_monomial(k)), s.rounding_bound) << "Gauss, x^" << k;
    }
    // The first even degree beyond each rule's is not integrated exactly: the degrees above are the rules'.
    const int kronrod_beyond = kronrod_degree + 1 + (kronrod_degree + 1) % 2, gauss_beyond = gauss_degree + 1;
    const RuleSum k = apply(rule, rule.kronrod_weights, kronrod_beyond);
    const RuleSum g = apply(rule, rule.gauss_weights, gauss_beyond);
    EXPECT_GT(std::fabs(k.value - exact_monomial(kronrod_beyond)), 10 * k.rounding_bound);
    EXPECT_GT(std::fabs(g.value - exact_monomial(gauss_beyond)), 10 * g.rounding_bound);
}

TEST_P(GaussKronrod, ItsGaussHalfIsTheGaussLegendreRule) {
    const int n = GetParam();
    const KronrodRule& rule = gauss_kronrod(n);
    const ms::exact::GaussRule& g = ms::exact::gauss_legendre(n);
    for (int i = 0; i < rule.points; ++i) {
        if (i % 2 == 1) {
            // Both come from 17-digit tables or Newton's iteration: equal to a few ulps.
            EXPECT_NEAR(rule.nodes[i], g.nodes[std::size_t(i / 2)], 4e-16) << i;
            EXPECT_EQ(rule.gauss_weights[i], g.weights[std::size_t(i / 2)]) << i;
        } else {
            EXPECT_EQ(rule.gauss_weights[i], 0.0) << i;
        }
        if (i > 0) EXPECT_LT(rule.nodes[i - 1], rule.nodes[i]) << i;
    }
}

INSTANTIATE_TEST_SUITE_P(TabulatedPairs, GaussKronrod, ::testing::Values(8, 12));

TEST(GaussKronrodTables, AnUntabulatedPairIsRefusedByName) {
    EXPECT_THROW(gauss_kronrod(7), std::invalid_argument);
}

}  // namespace
