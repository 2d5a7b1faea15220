#include "exact/gauss_legendre.hpp"

#include <array>
#include <cmath>
#include <stdexcept>

#include "core/types.hpp"

namespace ms::exact {

namespace {

constexpr int kMaxNodes = 64;

GaussRule build(int n) {
    GaussRule rule;
    rule.nodes.resize(n);
    rule.weights.resize(n);
    for (int i = 0; i < (n + 1) / 2; ++i) {
        // Tricomi's estimate of the i-th largest root, then Newton on P_n: quadratic convergence from
        // this start, 4-6 steps to 1 ulp for n <= 64.
        double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double dp = 0;
        for (int iter = 0; iter < 100; ++iter) {
            double p0 = 1, p1 = x;  // P_0, P_1, then the three-term recurrence up to P_n
            for (int k = 2; k <= n; ++k) {
                const double pk = ((2.0 * k - 1) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = pk;
            }
            if (n == 1) p0 = 1;
            dp = n * (x * p1 - p0) / (x * x - 1);  // P_n'(x) from P_n and P_{n-1}
            const double dx = p1 / dp;
            x -= dx;
            if (std::fabs(dx) < 1e-16) break;
        }
        const double w = 2.0 / ((1 - x * x) * dp * dp);
        rule.nodes[n - 1 - i] = x;
        rule.nodes[i] = -x;
        rule.weights[n - 1 - i] = w;
        rule.weights[i] = w;
    }
    if (n % 2 == 1) rule.nodes[n / 2] = 0;  // exactly the midpoint
    return rule;
}

struct Table {
    std::array<GaussRule, kMaxNodes + 1> rules;
    Table() {
        for (int n = 1; n <= kMaxNodes; ++n) rules[n] = build(n);
    }
};

}  // namespace

const GaussRule& gauss_legendre(int n) {
    if (n < 1 || n > kMaxNodes) throw std::invalid_argument("gauss_legendre: n must be in [1, 64]");
    static const Table table;  // C++11 guarantees one thread-safe construction
    return table.rules[n];
}

}  // namespace ms::exact
