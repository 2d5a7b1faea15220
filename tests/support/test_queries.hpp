// Random query generators shared by the tests.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "core/types.hpp"

namespace ms::testing {

inline Vec3 direction(double cos_theta, double phi) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// Queries outside the zero region with cosines away from exact grazing; anisotropic when asked.
inline std::vector<Query> random_queries(std::size_t count, bool anisotropic, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<Query> out;
    while (out.size() < count) {
        Query q;
        q.visibility = 0.05 + 0.94 * u(rng);
        const double r = 0.1 + 0.9 * u(rng);
        q.alpha_x = r * r;
        q.alpha_y = anisotropic ? std::pow(0.1 + 0.9 * u(rng), 2) : q.alpha_x;
        // Azimuth drawn before the cosine, in separate statements: the order of evaluation of two
        // draws in one call's arguments is up to the compiler (GCC and clang differ).
        const double phi_i = 2 * M_PI * u(rng), cos_i = 0.05 + 0.95 * u(rng);
        q.wi = direction(cos_i, phi_i);
        const double phi_o = 2 * M_PI * u(rng), cos_o = 0.02 + 0.98 * u(rng);
        q.wo = direction(cos_o, phi_o);
        if (2 * q.visibility + q.wo.z <= 1) continue;  // zero region: exact, not a sampling test
        out.push_back(q);
    }
    return out;
}

}  // namespace ms::testing
