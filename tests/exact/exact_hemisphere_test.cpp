// The term's hemisphere {m.z > 0, m.wo > 0, m.wi > 0} at grazing views and lights on strongly stretched
// surfaces, where its probability (~1e-5) is a small difference of parts near pi and S^-1 magnifies any
// inconsistency between the ends of its arcs ~1 / alpha times: against the same boundary in long double.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/cone.hpp"
#include "core/types.hpp"
#include "exact/cap_region.hpp"
#include "exact/exact_term.hpp"

namespace {

using namespace ms;
using Real = long double;

struct RealVec {
    Real x, y, z;
};
RealVec real_cross(const RealVec& a, const RealVec& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Real real_dot(const RealVec& a, const RealVec& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
RealVec real_normalized(const RealVec& a) {
    const Real n = std::sqrt(real_dot(a, a));
    return {a.x / n, a.y / n, a.z / n};
}

// The boundary integral of the hemisphere in extended precision: on great circle k the arc between the
// points where it meets the other two circles, normalize(n_k x n_j), and the angle v = S^-1 m sweeps
// round S n_k along it, weighted by a.normalize(S n_k).
Real hemisphere_reference(double alpha_x, double alpha_y, const Vec3& wi, const Vec3& wo) {
    const RealVec n[3] = {{0, 0, 1}, {wo.x, wo.y, wo.z}, {wi.x, wi.y, wi.z}};
    const RealVec a = real_normalized({alpha_x * Real(wi.x), alpha_y * Real(wi.y), Real(wi.z)});
    Real total = 0;
    for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3, l = (k + 2) % 3;
        const RealVec to_j = real_normalized(real_cross(n[k], n[j])), to_l = real_normalized(real_cross(n[k], n[l]));
        // The half circles inside hemispheres j and l run from -to_j to to_j and from -to_l to to_l.
        const bool later_start = -real_dot(to_l, n[j]) >= 0;
        const RealVec start = later_start ? RealVec{-to_l.x, -to_l.y, -to_l.z} : RealVec{-to_j.x, -to_j.y, -to_j.z};
        const RealVec end = later_start ? to_j : to_l;
        const RealVec axis = real_normalized({alpha_x * n[k].x, alpha_y * n[k].y, n[k].z});
        const RealVec vs{start.x / alpha_x, start.y / alpha_y, start.z}, ve{end.x / alpha_x, end.y / alpha_y, end.z};
        total += real_dot(a, axis) * std::atan2(std::max(Real(0), real_dot(real_cross(vs, ve), axis)), real_dot(vs, ve));
    }
    return total;
}

// Normalised as exact_term normalises its inputs (scaled by the largest component first), so that the
// reference sees the same directions to the last bit.
Vec3 unit_direction(const Vec3& v) {
    const double m = std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)});
    const Vec3 b{v.x / m, v.y / m, v.z / m};
    const double inv = 1.0 / std::sqrt(b.x * b.x + b.y * b.y + b.z * b.z);
    return {b.x * inv, b.y * inv, b.z * inv};
}

TEST(ExactHemisphere, GrazingViewsAndLightsOnStretchedSurfacesStayWithinTheEstimates) {
    if (std::numeric_limits<Real>::digits <= std::numeric_limits<double>::digits)
        GTEST_SKIP() << "long double is no wider than double here";
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> u(0, 1);
    auto grazing = [&] {
        const double z = std::exp(std::log(1e-4) + std::log(100.0) * u(rng)), phi = 2 * kPi * u(rng);
        const double s = std::sqrt(1 - z * z);
        return Vec3{s * std::cos(phi), s * std::sin(phi), z};
    };
    int checked = 0;
    for (int i = 0; i < 400; ++i) {
        Query q;
        q.visibility = 0.5 + 0.49 * u(rng);
        q.alpha_x = std::exp(std::log(0.1) * u(rng));
        q.alpha_y = std::exp(std::log(3e-4) + std::log(10.0) * u(rng));
        if (i % 2) std::swap(q.alpha_x, q.alpha_y);
        q.wi = grazing();
        q.wo = grazing();
        const double c = cone_cos_theta(q.visibility, AoWeighting::cosine);
        if (in_zero_region(c, q.wo.z)) continue;
        const Vec3 wi = unit_direction(q.wi), wo = unit_direction(q.wo);
        const exact::Microsurface surface = exact::make_microsurface(q.alpha_x, q.alpha_y, wi);
        const double reference = static_cast<double>(hemisphere_reference(q.alpha_x, q.alpha_y, wi, wo));
        const exact::BoundaryIntegral hemisphere = exact::hemisphere_integral(surface, Vec3{0, 0, 1}, wo, wi);
        EXPECT_LE(std::fabs(hemisphere.value - reference), hemisphere.error) << "query " << i;
        // The term against the cone at a 1000x tighter tolerance over the extended-precision hemisphere.
        const double s = std::sqrt(cone_sin2_theta(q.visibility, AoWeighting::cosine));
        const std::vector<exact::Cap> cone_caps = {{Vec3{0, 0, 1}, c, s}, {wo, c, s}, {wi, 0, 1}};
        const exact::BoundaryIntegral cone =
            exact::boundary_integral(surface, cone_caps, exact::arc_rule_for(1e-13), 1e-13 * reference);
        const exact::ExactValue term = exact::exact_term(q, AoWeighting::cosine);
        const double expected = std::clamp(cone.value / reference, 0.0, 1.0);
        EXPECT_LE(std::fabs(term.term - expected), term.error + cone.error / reference) << "query " << i;
        checked += 1;
    }
    EXPECT_GE(checked, 300);
}

}  // namespace
