// The closed-form arc (partial fractions over the circle quartic's roots) against pole-aware
// Gauss-Legendre on the same arcs: every difference within the sum of the two error estimates, on
// generic arcs and on the families where the closed form degenerates (nearly isotropic circles round
// e_z, tiny circles, extreme anisotropy, arcs from a sliver to a full turn).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "core/types.hpp"
#include "exact/cap_region.hpp"

namespace {

using namespace ms;
using ms::kPi;

Vec3 normalized(const Vec3& v) {
    const double n = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    return {v.x / n, v.y / n, v.z / n};
}

struct Family {
    const char* name;
    int arcs = 0, closed = 0;
    double worst_ratio = 0;  // |difference| / (sum of estimates)
    double worst_scaled_error = 0;  // closed form's bound times alpha^2
};

enum FamilyId { kGeneric, kAnisotropic, kNearlyIsotropicRoundZ, kTinyCircle, kSmooth, kCount };

void compare_family(FamilyId id, Family& family, std::mt19937_64& rng, int count) {
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < count; ++i) {
        const double alpha = std::exp(std::log(id == kSmooth ? 0.003 : 0.01) * u(rng));
        const double ratio = id == kAnisotropic ? std::exp(std::log(30.0) * (2 * u(rng) - 1)) : 1.0;
        const double alpha_x = alpha, alpha_y = std::clamp(alpha * ratio, 0.003, 1.0);
        const double phi_i = 2 * kPi * u(rng), cos_i = 0.02 + 0.98 * u(rng);
        const double sin_i = std::sqrt(1 - cos_i * cos_i);
        const exact::Microsurface surface =
            exact::make_microsurface(alpha_x, alpha_y, Vec3{sin_i * std::cos(phi_i), sin_i * std::sin(phi_i), cos_i});
        exact::Cap cap;
        if (id == kNearlyIsotropicRoundZ) {
            // An axis within 1e-9 .. 1e-2 of e_z: the quartic's leading coefficient nearly vanishes.
            const double tilt = std::exp(std::log(1e-9) + (std::log(1e-2) - std::log(1e-9)) * u(rng));
            const double phi = 2 * kPi * u(rng);
            cap.n = normalized(Vec3{tilt * std::cos(phi), tilt * std::sin(phi), 1});
        } else {
            const double z = 2 * u(rng) - 1, phi = 2 * kPi * u(rng), s = std::sqrt(1 - z * z);
            cap.n = Vec3{s * std::cos(phi), s * std::sin(phi), z};
        }
        if (id == kTinyCircle) {
            cap.s = std::exp(std::log(1e-5) * u(rng));  // sin of the cap's angle 1e-5 .. 1
            cap.c = std::sqrt(1 - cap.s * cap.s);
        } else {
            cap.c = 0.01 + 0.98 * u(rng);
            cap.s = std::sqrt(1 - cap.c * cap.c);
        }
        const double lo = 2 * kPi * (u(rng) - 0.5);
        const double length = i % 5 == 0 ? 2 * kPi : 2 * kPi * std::pow(u(rng), 3);  // full turns and slivers
        const double hi = lo + std::max(length, 1e-9);
        exact::ArcRule closed_rule;  // closed form whenever usable at all
        const exact::ArcIntegral closed = exact::integrate_arc(surface, cap, lo, hi, closed_rule, 1.0);
        exact::ArcRule quadrature_rule{12, 8, 4.0, false};
        const exact::ArcIntegral reference = exact::integrate_arc(surface, cap, lo, hi, quadrature_rule, 1e-13);
        ASSERT_FALSE(reference.closed_form);
        family.arcs += 1;
        if (!closed.closed_form) continue;
        family.closed += 1;
        const double difference = std::fabs(closed.value - reference.value);
        const double bound = closed.error + reference.error;
        family.worst_ratio = std::max(family.worst_ratio, difference / bound);
        ASSERT_LE(difference, bound) << family.name << " arc " << i << ": closed " << closed.value << " +- "
                                     << closed.error << ", quadrature " << reference.value << " +- "
                                     << reference.error << " (alpha " << alpha_x << ", " << alpha_y << "; cap c "
                                     << cap.c << " s " << cap.s << "; psi " << lo << " .. " << hi << ")";
        // The bound is of use: the coefficients of |v|^2 ~ 1 / alpha^2 carry rounding relative to its
        // minimum 1, so the bound grows like ulp / alpha^2.
        const double alpha_min = std::min(alpha_x, alpha_y);
        family.worst_scaled_error = std::max(family.worst_scaled_error, closed.error * alpha_min * alpha_min);
    }
}

TEST(ExactClosedFormArc, AgreesWithGaussLegendreWithinTheSumOfTheirEstimates) {
    Family families[kCount] = {{"generic"}, {"anisotropic to 1:30"}, {"nearly isotropic round e_z"},
                               {"tiny circles"}, {"smooth (alpha to 0.003)"}};
    std::mt19937_64 rng(20261204);
    for (int id = 0; id < kCount; ++id) compare_family(FamilyId(id), families[id], rng, 1000);
    for (const Family& family : families)
        std::printf("%-28s %4d arcs, closed form on %4d, worst |difference| / bound %.3g, bound * alpha^2 %.3g\n",
                    family.name, family.arcs, family.closed, family.worst_ratio, family.worst_scaled_error);
    // The closed form serves the arcs it is meant for: all but the degenerate ones.
    EXPECT_GE(families[kGeneric].closed, 990);
    EXPECT_GE(families[kAnisotropic].closed, 990);
    EXPECT_GE(families[kSmooth].closed, 990);
}

// A direction with z uniform in [0.05, 1), any azimuth.
Vec3 direction_above_horizon(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0, 1);
    const double z = 0.05 + 0.95 * u(rng), phi = 2 * kPi * u(rng), s = std::sqrt(1 - z * z);
    return {s * std::cos(phi), s * std::sin(phi), z};
}

TEST(ExactClosedFormArc, BoundaryIntegralsAgreeWithAndWithoutTheClosedForm) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    int compared = 0;
    for (int i = 0; i < 400; ++i) {
        const double alpha_x = std::exp(std::log(0.005) * u(rng));
        const double alpha_y = i % 2 ? alpha_x : std::clamp(alpha_x * std::exp(std::log(30.0) * (2 * u(rng) - 1)), 0.003, 1.0);
        const Vec3 wi = direction_above_horizon(rng);
        const Vec3 wo = direction_above_horizon(rng);
        const exact::Microsurface surface = exact::make_microsurface(alpha_x, alpha_y, wi);
        // Cone round wo with a cap round e_z, in the VNDF's support (the hemisphere and {m.wi > 0}).
        const double c_cone = 0.05 + 0.9 * u(rng), c_z = 0.05 + 0.9 * u(rng);
        std::vector<exact::Cap> caps = {{wo, c_cone, std::sqrt(1 - c_cone * c_cone)},
                                        {Vec3{0, 0, 1}, c_z, std::sqrt(1 - c_z * c_z)},
                                        {wi, 0, 1}};
        const exact::ArcRule with = exact::arc_rule_for(1e-10);
        exact::ArcRule without = with;
        without.closed_form = false;
        const exact::BoundaryIntegral a = exact::boundary_integral(surface, caps, with, 1e-10);
        const exact::BoundaryIntegral b = exact::boundary_integral(surface, caps, without, 1e-10);
        ASSERT_LE(std::fabs(a.value - b.value), a.error + b.error) << "query " << i;
        EXPECT_LE(a.error, 1e-10) << "query " << i;
        compared += 1;
    }
    EXPECT_EQ(compared, 400);
}

// The tolerance is shared over the whole boundary: where the closed forms' bounds fit into it together,
// no arc takes quadrature, even one whose bound is far above its length's share (smooth surfaces, whose
// quartics carry bounds near 1e-10), and the values' estimates stay within the tolerance.
TEST(ExactClosedFormArc, ClosedFormsWhoseBoundsFitTogetherNeedNoQuadrature) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    int checked = 0;
    for (int i = 0; i < 300; ++i) {
        const double alpha_x = std::exp(std::log(0.002) + std::log(0.05 / 0.002) * u(rng));
        const double alpha_y = i % 2 ? alpha_x : std::clamp(alpha_x * std::exp(std::log(30.0) * (2 * u(rng) - 1)), 0.002, 1.0);
        const Vec3 wi = direction_above_horizon(rng);
        const Vec3 wo = direction_above_horizon(rng);
        const exact::Microsurface surface = exact::make_microsurface(alpha_x, alpha_y, wi);
        const double c_cone = 0.05 + 0.9 * u(rng);
        const double s_cone = std::sqrt(1 - c_cone * c_cone);
        const std::vector<exact::Cap> caps = {{wo, c_cone, s_cone}, {Vec3{0, 0, 1}, c_cone, s_cone}, {wi, 0, 1}};
        const exact::ArcRule rule = exact::arc_rule_for(1e-10);
        // At a loose tolerance every usable closed form is taken: its error is the sum of their bounds.
        const exact::BoundaryIntegral loose = exact::boundary_integral(surface, caps, rule, 1e-3);
        if (loose.quadrature_pieces > 0 || !(loose.error > 0)) continue;  // a degenerate quartic
        // A tolerance just above that sum (and the twentieth kept back for later allowances).
        const double tolerance = 1.1 * loose.error / 0.95;
        const exact::BoundaryIntegral shared = exact::boundary_integral(surface, caps, rule, tolerance);
        EXPECT_EQ(shared.quadrature_pieces, 0) << "query " << i;
        EXPECT_LE(shared.error, tolerance) << "query " << i;
        EXPECT_EQ(shared.value, loose.value) << "query " << i;
        // Against quadrature on every arc at a tight tolerance: within the two estimates.
        exact::ArcRule without = exact::arc_rule_for(1e-13);
        without.closed_form = false;
        const exact::BoundaryIntegral reference = exact::boundary_integral(surface, caps, without, 1e-13);
        EXPECT_LE(std::fabs(shared.value - reference.value), shared.error + reference.error) << "query " << i;
        checked += 1;
    }
    EXPECT_GE(checked, 250);
}

}  // namespace
