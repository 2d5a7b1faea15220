// An adversarial search for the largest error of a lookup (the presets' accuracy tests): random
// restarts plus a local optimiser. `error` takes a point of the unit box [0, 1]^dims (the caller maps it
// to the inputs, e.g. densely towards v = 1 and the horizon, where a layout is hardest pressed) and
// returns the error there. The search screens `screen` uniform random points, then runs Nelder-Mead
// maximising the error from the worst `starts` of them, each for at most `steps` iterations (clamped to
// the box; initial simplex 5 % of the box). A lower bound of the true max, but one that climbs to the
// local maxima a grid or a random sample only straddles.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <random>
#include <utility>
#include <vector>

namespace ms::testing {

struct MaxSearchResult {
    double max_error = 0;
    std::vector<double> at;  // unit-box point of the max
    std::size_t evaluations = 0;
};

inline MaxSearchResult search_max_error(const std::function<double(const std::vector<double>&)>& error, std::size_t dims,
                                        std::size_t screen, std::size_t starts, int steps, std::uint64_t seed) {
    MaxSearchResult best;
    auto value = [&](const std::vector<double>& x) {
        ++best.evaluations;
        const double e = error(x);
        if (e > best.max_error) best.max_error = e, best.at = x;
        return e;
    };
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u01(0, 1);
    std::vector<std::pair<double, std::vector<double>>> screened;
    for (std::size_t i = 0; i < std::max(screen, starts); ++i) {
        std::vector<double> x(dims);
        for (double& c : x) c = u01(rng);
        const double e = value(x);
        screened.emplace_back(e, std::move(x));
    }
    std::partial_sort(screened.begin(), screened.begin() + std::ptrdiff_t(starts), screened.end(),
                      [](const auto& a, const auto& b) { return a.first > b.first; });
    auto clamp_box = [](std::vector<double> x) {
        for (double& c : x) c = std::clamp(c, 0.0, 1.0);
        return x;
    };
    for (std::size_t s = 0; s < starts; ++s) {
        // Nelder-Mead on -error: the simplex's vertices and their values.
        std::vector<std::vector<double>> simplex(dims + 1, screened[s].second);
        std::vector<double> f(dims + 1);
        for (std::size_t k = 0; k <= dims; ++k) {
            if (k > 0) simplex[k][k - 1] += simplex[k][k - 1] > 0.5 ? -0.05 : 0.05;
            f[k] = -value(simplex[k]);
        }
        for (int it = 0; it < steps; ++it) {
            std::size_t hi = 0, lo = 0;
            for (std::size_t k = 1; k <= dims; ++k) {
                if (f[k] > f[hi]) hi = k;
                if (f[k] < f[lo]) lo = k;
            }
            std::size_t second = lo;
            for (std::size_t k = 0; k <= dims; ++k)
                if (k != hi && f[k] > f[second]) second = k;
            if (f[hi] - f[lo] < 1e-9) break;
            std::vector<double> centroid(dims, 0.0);
            for (std::size_t k = 0; k <= dims; ++k)
                if (k != hi)
                    for (std::size_t d = 0; d < dims; ++d) centroid[d] += simplex[k][d] / double(dims);
            auto along = [&](double t) {
                std::vector<double> x(dims);
                for (std::size_t d = 0; d < dims; ++d) x[d] = centroid[d] + t * (simplex[hi][d] - centroid[d]);
                return clamp_box(x);
            };
            const auto reflected = along(-1);
            const double fr = -value(reflected);
            if (fr < f[lo]) {
                const auto expanded = along(-2);
                const double fe = -value(expanded);
                if (fe < fr) simplex[hi] = expanded, f[hi] = fe;
                else simplex[hi] = reflected, f[hi] = fr;
            } else if (fr < f[second]) {
                simplex[hi] = reflected, f[hi] = fr;
            } else {
                const auto contracted = along(0.5);
                const double fc = -value(contracted);
                if (fc < f[hi]) {
                    simplex[hi] = contracted, f[hi] = fc;
                } else {  // shrink towards the best vertex
                    for (std::size_t k = 0; k <= dims; ++k)
                        if (k != lo) {
                            for (std::size_t d = 0; d < dims; ++d) simplex[k][d] = simplex[lo][d] + 0.5 * (simplex[k][d] - simplex[lo][d]);
                            f[k] = -value(simplex[k]);
                        }
                }
            }
        }
    }
    return best;
}

}  // namespace ms::testing
