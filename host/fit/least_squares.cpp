#include "fit/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ms::fit {

std::vector<double> weighted_least_squares(const Design& a, const std::vector<double>& y, const std::vector<double>& w,
                                           double rank_tolerance) {
    const std::size_t m = a.samples(), n = a.columns;
    if (n == 0 || a.rows.size() != m * n || y.size() != m || w.size() != m)
        throw std::invalid_argument("weighted_least_squares: design, values and weights disagree in size");
    // Column-major copy of sqrt(w) A and sqrt(w) y: Householder works down columns.
    std::vector<double> q(m * n), b(m);
    double total = 0;
    for (std::size_t i = 0; i < m; ++i) {
        if (!(w[i] >= 0)) throw std::invalid_argument("weighted_least_squares: negative or NaN weight");
        total += w[i];
        const double s = std::sqrt(w[i]);
        for (std::size_t k = 0; k < n; ++k) q[k * m + i] = s * a.rows[i * n + k];
        b[i] = s * y[i];
    }
    if (!(total > 0)) throw std::invalid_argument("weighted_least_squares: every weight is 0");
    std::vector<double> diag(n, 0);
    double largest = 0;
    for (std::size_t k = 0; k < n && k < m; ++k) {
        double* col = &q[k * m];
        double norm = 0;
        for (std::size_t i = k; i < m; ++i) norm += col[i] * col[i];
        norm = std::sqrt(norm);
        if (norm == 0) continue;
        // The reflection that maps col[k..] to (alpha, 0, ..., 0); alpha's sign is opposite to col[k]
        // so that v = col - alpha e_k does not cancel.
        const double alpha = col[k] > 0 ? -norm : norm;
        col[k] -= alpha;
        double vv = 0;
        for (std::size_t i = k; i < m; ++i) vv += col[i] * col[i];
        for (std::size_t j = k + 1; j < n; ++j) {
            double* other = &q[j * m];
            double dot = 0;
            for (std::size_t i = k; i < m; ++i) dot += col[i] * other[i];
            const double f = 2 * dot / vv;
            for (std::size_t i = k; i < m; ++i) other[i] -= f * col[i];
        }
        double dot = 0;
        for (std::size_t i = k; i < m; ++i) dot += col[i] * b[i];
        const double f = 2 * dot / vv;
        for (std::size_t i = k; i < m; ++i) b[i] -= f * col[i];
        diag[k] = alpha;
        largest = std::max(largest, std::fabs(alpha));
    }
    // Back substitution on R (diag on the diagonal, q[j * m + k] above it); rank-deficient columns -> 0.
    std::vector<double> c(n, 0);
    for (std::size_t kk = std::min(n, m); kk-- > 0;) {
        if (std::fabs(diag[kk]) <= rank_tolerance * largest) continue;
        double s = b[kk];
        for (std::size_t j = kk + 1; j < n; ++j) s -= q[j * m + kk] * c[j];
        c[kk] = s / diag[kk];
    }
    return c;
}

namespace {

double cost(const Design& a, const std::vector<double>& y, const std::vector<double>& w, const Link& link,
            const std::vector<double>& c) {
    double s = 0;
    for (std::size_t i = 0; i < y.size(); ++i) {
        double z = 0;
        for (std::size_t k = 0; k < a.columns; ++k) z += a.rows[i * a.columns + k] * c[k];
        const double r = y[i] - link.value(z);
        s += w[i] * r * r;
    }
    return s;
}

}  // namespace

std::vector<double> gauss_newton(const Design& a, const std::vector<double>& y, const std::vector<double>& w,
                                 const Link& link, std::vector<double> c, unsigned iterations,
                                 GaussNewtonReport* report) {
    if (c.size() != a.columns) throw std::invalid_argument("gauss_newton: start has the wrong size");
    const std::size_t m = a.samples(), n = a.columns;
    double current = cost(a, y, w, link, c);
    GaussNewtonReport local;
    GaussNewtonReport& rep = report ? *report : local;
    rep.initial_cost = current;
    Design j{n, std::vector<double>(m * n)};
    std::vector<double> residual(m);
    for (unsigned it = 0; it < iterations; ++it) {
        // Linearise link(A c + A d) ~ link(A c) + link'(A c) A d: the step d is the weighted least
        // squares solution of J d = residual with J = diag(link'(A c)) A.
        for (std::size_t i = 0; i < m; ++i) {
            double z = 0;
            for (std::size_t k = 0; k < n; ++k) z += a.rows[i * n + k] * c[k];
            const double d = link.derivative(z);
            for (std::size_t k = 0; k < n; ++k) j.rows[i * n + k] = d * a.rows[i * n + k];
            residual[i] = y[i] - link.value(z);
        }
        const std::vector<double> step = weighted_least_squares(j, residual, w);
        // Step halving: the full Gauss-Newton step can overshoot where the link saturates.
        bool improved = false;
        for (double scale = 1; scale > 1e-3; scale *= 0.5) {
            std::vector<double> trial = c;
            for (std::size_t k = 0; k < n; ++k) trial[k] += scale * step[k];
            const double t = cost(a, y, w, link, trial);
            if (t < current) {
                const double gain = (current - t) / std::max(current, 1e-300);
                c = trial;
                current = t;
                improved = gain > 1e-9;
                break;
            }
        }
        rep.iterations = it + 1;
        if (!improved) break;
    }
    rep.final_cost = current;
    return c;
}

}  // namespace ms::fit
