// Nelder-Mead minimisation in the unit box [0, 1]^n, the local optimiser of the searches that state a
// maximum error (a fitted closed form's, jobs/design_closed_form.cpp; the presets', tests/repr): a
// simplex of n + 1 vertices, the first at x0 and the others a step away along each axis (away from the
// nearer wall), then reflection (-1), expansion (-2), contraction (1/2) and shrink towards the best vertex
// (1/2), every trial point clamped to the box; it stops after `max_iterations` or once the vertices'
// values span less than `spread`. Returns the best vertex and its value in *value.
#pragma once

#include <algorithm>
#include <cstddef>
#include <functional>
#include <vector>

namespace ms::fit {

inline std::vector<double> nelder_mead_unit_box(const std::function<double(const std::vector<double>&)>& f, const std::vector<double>& x0,
                                                int max_iterations, double spread, double step, double* value) {
    const std::size_t n = x0.size();
    auto clamp_box = [](std::vector<double> x) {
        for (double& c : x) c = std::clamp(c, 0.0, 1.0);
        return x;
    };
    std::vector<std::vector<double>> simplex(n + 1, x0);
    std::vector<double> fv(n + 1);
    for (std::size_t k = 0; k <= n; ++k) {
        if (k > 0) simplex[k][k - 1] += simplex[k][k - 1] > 0.5 ? -step : step;
        simplex[k] = clamp_box(simplex[k]);
        fv[k] = f(simplex[k]);
    }
    for (int it = 0; it < max_iterations; ++it) {
        std::size_t hi = 0, lo = 0;
        for (std::size_t k = 1; k <= n; ++k) {
            if (fv[k] > fv[hi]) hi = k;
            if (fv[k] < fv[lo]) lo = k;
        }
        std::size_t second = lo;
        for (std::size_t k = 0; k <= n; ++k)
            if (k != hi && fv[k] > fv[second]) second = k;
        if (fv[hi] - fv[lo] < spread) break;
        std::vector<double> centroid(n, 0.0);
        for (std::size_t k = 0; k <= n; ++k)
            if (k != hi)
                for (std::size_t d = 0; d < n; ++d) centroid[d] += simplex[k][d] / double(n);
        auto along = [&](double t) {
            std::vector<double> x(n);
            for (std::size_t d = 0; d < n; ++d) x[d] = centroid[d] + t * (simplex[hi][d] - centroid[d]);
            return clamp_box(x);
        };
        const auto reflected = along(-1);
        const double fr = f(reflected);
        if (fr < fv[lo]) {
            const auto expanded = along(-2);
            const double fe = f(expanded);
            if (fe < fr) simplex[hi] = expanded, fv[hi] = fe;
            else simplex[hi] = reflected, fv[hi] = fr;
        } else if (fr < fv[second]) {
            simplex[hi] = reflected, fv[hi] = fr;
        } else {
            const auto contracted = along(0.5);
            const double fc = f(contracted);
            if (fc < fv[hi]) {
                simplex[hi] = contracted, fv[hi] = fc;
            } else {  // shrink towards the best vertex
                for (std::size_t k = 0; k <= n; ++k)
                    if (k != lo) {
                        for (std::size_t d = 0; d < n; ++d) simplex[k][d] = simplex[lo][d] + 0.5 * (simplex[k][d] - simplex[lo][d]);
                        fv[k] = f(simplex[k]);
                    }
            }
        }
    }
    std::size_t lo = 0;
    for (std::size_t k = 1; k <= n; ++k)
        if (fv[k] < fv[lo]) lo = k;
    if (value) *value = fv[lo];
    return simplex[lo];
}

}  // namespace ms::fit
