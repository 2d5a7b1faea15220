// An adversarial search for the largest error of a lookup (the presets' accuracy tests): random
// restarts plus a local optimiser. `error` takes a point of the unit box [0, 1]^dims (the caller maps it
// to the inputs, e.g. densely towards v = 1 and the horizon, where a layout is hardest pressed) and
// returns the error there. The search screens `screen` uniform random points, then runs Nelder-Mead
// maximising the error from the worst `starts` of them, each for at most `steps` iterations (clamped to
// the box; initial simplex 5 % of the box; host/fit/nelder_mead.hpp). A lower bound of the true max, but one that climbs to the
// local maxima a grid or a random sample only straddles.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <random>
#include <utility>
#include <vector>

#include "fit/nelder_mead.hpp"

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
    // Nelder-Mead on -error from each start (fit/nelder_mead.hpp; value() keeps the best point seen).
    for (std::size_t s = 0; s < starts; ++s)
        fit::nelder_mead_unit_box([&](const std::vector<double>& x) { return -value(x); }, screened[s].second, steps, 1e-9, 0.05, nullptr);
    return best;
}

}  // namespace ms::testing
