// The exact term: T = P(cone) / P(hemisphere) under the VNDF of wi.
//
// Under the Smith profile the weight w = G2 / G1 of GenericM_m is H(wo.wm) times a constant of the
// query in both forms (uncorrelated: G1(wo) H(wo.wm); height-correlated: its quotient, whose G1 factors
// depend on wi and wo only), and every VNDF sample has wi.wm > 0 and wm.z > 0. So
//     cone = {m.z > c, m.wo > c} and hemisphere = {m.z > 0, m.wo > 0}, c = cos(theta) of the cone,
// each intersected with the support {m.wi > 0}, and the term is the ratio of their VNDF probabilities,
// which cap_region.cpp integrates along the regions' boundaries. The hemisphere's circles are all great
// circles, so P(hemisphere) is closed-form; the cone's circle round wo (and round e_z on an anisotropic
// surface) is integrated by pole-aware Gauss-Legendre.
#include "exact/exact_term.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/cone.hpp"
#include "exact/cap_region.hpp"
#include "exact/gauss_legendre.hpp"

namespace ms::exact {

namespace {

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 unit(const Vec3& a) {
    // Scaled first so that components near the limits of double (1e-300, 1e300) normalise without
    // underflow or overflow of the squares.
    const double m = std::max({std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)});
    const Vec3 b{a.x / m, a.y / m, a.z / m};
    const double inv = 1.0 / std::sqrt(dot(b, b));
    return {b.x * inv, b.y * inv, b.z * inv};
}

// The term for unit wi (above the horizon) and unit wo, with the cone given by cos and sin^2.
ExactValue term_of(double alpha_x, double alpha_y, const Vec3& wi, const Vec3& wo, double visibility, double c,
                   double s2, double tolerance) {
    ExactValue out;
    if (!(wo.z > 0)) return out;              // light at or below the horizon: G1(wo) = 0
    if (visibility >= 1) {                    // the cone is the hemisphere
        out.term = 1;
        return out;
    }
    if (in_zero_region(c, wo.z)) return out;  // no normal can satisfy both cone conditions
    const Microsurface surface = make_microsurface(alpha_x, alpha_y, wi);
    const ArcRule rule = arc_rule_for(tolerance);
    const Vec3 ez{0, 0, 1};
    const BoundaryIntegral hemisphere = boundary_integral(surface, {{ez, 0, 1}, {wo, 0, 1}, {wi, 0, 1}}, rule, 0);
    if (!(hemisphere.value > 0)) return out;
    const double s = std::sqrt(s2);
    const BoundaryIntegral cone =
        boundary_integral(surface, {{ez, c, s}, {wo, c, s}, {wi, 0, 1}}, rule, tolerance * hemisphere.value);
    const double t = cone.value / hemisphere.value;
    out.term = std::clamp(t, 0.0, 1.0);
    out.error = (cone.error + std::fabs(t) * hemisphere.error) / hemisphere.value;
    out.quadrature_pieces = cone.quadrature_pieces + hemisphere.quadrature_pieces;
    return out;
}

Vec3 lut_view(double n_dot_v) { return {std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v)), 0, n_dot_v}; }
Vec3 lut_light(double n_dot_l, double phi) {
    const double sl = std::sqrt(std::max(0.0, 1 - n_dot_l * n_dot_l));
    return {sl * std::cos(phi), sl * std::sin(phi), n_dot_l};
}

// Azimuths in (0, pi) where the term is not analytic, plus the real parts of nearly-real ones (complex
// solutions within `near` of the axis), sorted, with 0 and pi.
std::vector<double> azimuth_breakpoints(double c, double s, double n_dot_v, double n_dot_l) {
    std::vector<double> points{0.0, kPi};
    const double sv = std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v));
    const double sl = std::sqrt(std::max(0.0, 1 - n_dot_l * n_dot_l));
    if (sv == 0 || sl == 0) return points;  // the term does not depend on the azimuth
    const double near = 0.5;                 // |Im phi| below which a complex event still splits
    auto add_solutions = [&](double x, double y, double k) {
        // x cos phi + y sin phi = k, folded into [0, pi] (the term is even in phi).
        const double r = std::hypot(x, y);
        if (r == 0) return;
        const double centre = std::atan2(y, x);
        const double ratio = k / r;
        std::vector<double> found;
        if (std::fabs(ratio) <= 1) {
            const double w = std::acos(ratio);
            found = {centre - w, centre + w};
        } else if (std::acosh(std::fabs(ratio)) < near) {
            found = {ratio > 0 ? centre : centre + kPi};
        }
        for (double phi : found) {
            phi = std::remainder(phi, 2 * kPi);
            phi = std::fabs(phi);
            if (phi > 1e-12 && phi < kPi - 1e-12) points.push_back(phi);
        }
    };
    // The cap round wo touches the great circle normal to wi: wi.wo = +-s.
    for (double sign : {-1.0, 1.0}) add_solutions(sv * sl, 0, sign * s - n_dot_v * n_dot_l);
    // The circle round wo passes through a meeting point X of the circle round e_z and the great
    // circle normal to wi: X = (x, +-y, c), x = -c NdotV / sin_v; X.wo = c.
    const double x = -c * n_dot_v / sv;
    const double y2 = 1 - c * c - x * x;
    if (y2 > 0) {
        const double y = std::sqrt(y2);
        for (double sign : {-1.0, 1.0}) add_solutions(x, sign * y, c * (1 - n_dot_l) / sl);
    }
    std::sort(points.begin(), points.end());
    points.erase(std::unique(points.begin(), points.end(), [](double a, double b) { return b - a < 1e-12; }),
                 points.end());
    return points;
}

struct MeanSum {
    double integral = 0, error = 0;
    int pieces = 0;
};

// The integral of T over [lo, hi] in the substitution phi = mid - half cos u, u in [0, pi], which turns a
// square-root onset at either end into an analytic function of u.
template <class Term>
void integrate_azimuth_piece(const Term& term, double lo, double hi, const AzimuthRule& rule, double tolerance,
                             int depth, MeanSum& out) {
    const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
    auto rule_sum = [&](int n, double& value_error) {
        const GaussRule& g = gauss_legendre(n);
        double sum = 0;
        for (int i = 0; i < n; ++i) {
            const double u = 0.5 * kPi * (1 + g.nodes[i]);
            const double jacobian = half * std::sin(u) * 0.5 * kPi;
            const ExactValue v = term(mid - half * std::cos(u));
            sum += g.weights[i] * jacobian * v.term;
            value_error += g.weights[i] * jacobian * v.error;
        }
        return sum;
    };
    double value_error_high = 0, value_error_low = 0;
    const double high = rule_sum(rule.high, value_error_high);
    const double low = rule_sum(rule.low, value_error_low);
    const double estimate = std::fabs(high - low);
    // The quadrature's share of the tolerance is half, spread over the azimuth range in proportion;
    // a difference at the level of the values' own errors or of rounding cannot be reduced by splitting.
    const double floor = value_error_high + value_error_low + 1e3 * std::numeric_limits<double>::epsilon() * (hi - lo);
    // Splitting stops at pieces of 1e-7 rad (no event is resolved more finely than the inputs) and after
    // 512 pieces per mean: the estimate then reports what was not reached.
    if (estimate > 0.5 * tolerance * (hi - lo) && estimate > floor && hi - lo > 1e-7 && out.pieces + depth < 512) {
        integrate_azimuth_piece(term, lo, mid, rule, tolerance, depth + 1, out);
        integrate_azimuth_piece(term, mid, hi, rule, tolerance, depth + 1, out);
        return;
    }
    out.integral += high;
    out.error += estimate + value_error_high;
    out.pieces += 1;
}

}  // namespace

AzimuthRule azimuth_rule_for(double tolerance) {
    // The low rule must integrate the substitution's Jacobian sin u on [0, pi] well below the tolerance
    // (Gauss-Legendre's relative error there: 3 nodes 1.4e-3, 4 nodes 1.6e-5, 6 nodes 4e-10, 8 nodes 3e-15),
    // or its difference to the high rule would never fall below the tolerance however small the piece.
    if (tolerance >= 1e-5) return {6, 4};
    if (tolerance >= 1e-8) return {8, 6};
    return {12, 8};
}

ExactValue exact_term(const Query& q, AoWeighting weighting, double tolerance) {
    const Vec3 wi = unit(q.wi), wo = unit(q.wo);
    const double c = cone_cos_theta(q.visibility, weighting);
    return term_of(q.alpha_x, q.alpha_y, wi, wo, q.visibility, c, cone_sin2_theta(q.visibility, weighting), tolerance);
}

ExactValue exact_term_at_azimuth(double visibility, double alpha, double n_dot_v, double n_dot_l, double phi,
                                 AoWeighting weighting, double tolerance) {
    return term_of(alpha, alpha, lut_view(n_dot_v), lut_light(n_dot_l, phi), visibility,
                   cone_cos_theta(visibility, weighting), cone_sin2_theta(visibility, weighting), tolerance);
}

ExactValue exact_azimuth_mean(double visibility, double alpha, double n_dot_v, double n_dot_l, AoWeighting weighting,
                              double tolerance) {
    const double c = cone_cos_theta(visibility, weighting), s2 = cone_sin2_theta(visibility, weighting);
    ExactValue out;
    if (!(n_dot_l > 0) || visibility <= 0) return out;
    if (visibility >= 1) {
        out.term = 1;
        return out;
    }
    if (in_zero_region(c, n_dot_l)) return out;
    const Vec3 wi = lut_view(n_dot_v);
    // Each value's own tolerance is a quarter of the mean's; the quadrature over the azimuth takes half.
    const double value_tolerance = 0.25 * tolerance;
    auto term = [&](double phi) { return term_of(alpha, alpha, wi, lut_light(n_dot_l, phi), visibility, c, s2, value_tolerance); };
    const double sv2 = 1 - n_dot_v * n_dot_v, sl2 = 1 - n_dot_l * n_dot_l;
    if (sv2 <= 0 || sl2 <= 0) return term(0.0);  // the azimuth does not change the term
    const std::vector<double> points = azimuth_breakpoints(c, std::sqrt(s2), n_dot_v, n_dot_l);
    const AzimuthRule rule = azimuth_rule_for(tolerance);
    MeanSum sum;
    for (std::size_t i = 0; i + 1 < points.size(); ++i)
        integrate_azimuth_piece(term, points[i], points[i + 1], rule, tolerance, 0, sum);
    out.term = std::clamp(sum.integral / kPi, 0.0, 1.0);
    out.error = sum.error / kPi;
    out.quadrature_pieces = sum.pieces;
    return out;
}

}  // namespace ms::exact
