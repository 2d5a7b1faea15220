// The exact term: T = P(cone) / P(hemisphere) under the VNDF of wi.
//
// Under the Smith profile the weight w = G2 / G1 of GenericM_m is H(wo.wm) times a constant of the
// query in both forms (uncorrelated: G1(wo) H(wo.wm); height-correlated: its quotient, whose G1 factors
// depend on wi and wo only), and every VNDF sample has wi.wm > 0 and wm.z > 0. So
//     cone = {m.z > c, m.wo > c} and hemisphere = {m.z > 0, m.wo > 0}, c = cos(theta) of the cone,
// each intersected with the support {m.wi > 0}, and the term is the ratio of their VNDF probabilities,
// which cap_region.cpp integrates along the regions' boundaries. The hemisphere's circles are all great
// circles, so P(hemisphere) is closed-form; the cone's circle round wo (and round e_z on an anisotropic
// surface) is integrated in closed form over its quartic's roots where the bounds fit the tolerance, by
// pole-aware Gauss-Legendre elsewhere.
#include "exact/exact_term.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <vector>

#include "core/cone.hpp"
#include "exact/cap_region.hpp"
#include "exact/gauss_kronrod.hpp"

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
    // From the three great circles' meeting points: no arc angles to find (hemisphere_integral).
    const BoundaryIntegral hemisphere = hemisphere_integral(surface, ez, wo, wi);
    if (!(hemisphere.value > 0)) return out;
    const double s = std::sqrt(s2);
    Cap cone_caps[3] = {{ez, c, s}, {wo, c, s}, {wi, 0, 1}};
    const BoundaryIntegral cone = boundary_integral(surface, cone_caps, 3, rule, tolerance * hemisphere.value);
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

// Where the term, as a function of the relative azimuth phi, is not analytic: the real azimuths in
// (0, pi) of the geometric events (sorted, with 0 and pi), and the complex solutions of the same event
// equations (singularities off the real axis, which slow any rule on a piece that comes near them).
struct AzimuthEvents {
    std::vector<double> breakpoints;
    std::vector<std::complex<double>> singularities;  // one of each conjugate pair (Im > 0), real part in [-pi, pi]
};

AzimuthEvents azimuth_events(double c, double s, double n_dot_v, double n_dot_l) {
    AzimuthEvents events;
    std::vector<double>& points = events.breakpoints;
    points = {0.0, kPi};
    const double sv = std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v));
    const double sl = std::sqrt(std::max(0.0, 1 - n_dot_l * n_dot_l));
    if (sv == 0 || sl == 0) return events;  // the term does not depend on the azimuth
    auto add_solutions = [&](double x, double y, double k) {
        // x cos phi + y sin phi = r cos(phi - centre) = k, folded into [0, pi] (the term is even in phi).
        const double r = std::hypot(x, y);
        if (r == 0) return;
        const double centre = std::atan2(y, x);
        const double ratio = k / r;
        if (std::fabs(ratio) <= 1) {
            const double w = std::acos(ratio);
            for (double phi : {centre - w, centre + w}) {
                phi = std::fabs(std::remainder(phi, 2 * kPi));
                if (phi > 1e-12 && phi < kPi - 1e-12) points.push_back(phi);
            }
            return;
        }
        // cos(phi - centre) = ratio outside [-1, 1]: phi - centre = +-i acosh(ratio) (ratio > 1) or
        // pi +- i acosh(-ratio) (ratio < -1).
        const double im = std::acosh(std::fabs(ratio));
        const double re = std::remainder(ratio > 0 ? centre : centre + kPi, 2 * kPi);
        events.singularities.emplace_back(re, im);
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
    return events;
}

struct MeanSum {
    double integral = 0, error = 0;
    int pieces = 0;
};

// The integral over one breakpoint interval [lo, hi] in the substitution phi = mid - half cos u,
// u in [0, pi], which turns a square-root onset at either end into an analytic function of u. On a piece
// [u0, u1] one Gauss-Kronrod pair (gauss_kronrod.hpp) gives the value, the Kronrod sum, and the estimate,
// its difference to the Gauss sum: the Gauss rule's error, which bounds the Kronrod rule's (the rules
// converge geometrically once every singularity lies outside the piece's Bernstein ellipse, and the
// Kronrod rule, exact to degree 3n+1 instead of 2n-1, then errs by about rho^(-n) times less). The
// Kronrod nodes interleave the Gauss nodes, so the pair resolves a feature between them as the Gauss
// rule on the two halves would: the difference cannot vanish by accident when the Gauss rule misses it.
class AzimuthInterval {
public:
    template <class Term>
    AzimuthInterval(const Term& term, double lo, double hi, const AzimuthEvents& events, const AzimuthRule& rule,
                    double tolerance, MeanSum& out)
        : mid_(0.5 * (lo + hi)), half_(0.5 * (hi - lo)), rule_(rule), pair_(gauss_kronrod(rule.nodes)), out_(out),
          // The quadrature's share of the mean's tolerance is half, spread over [0, pi] in proportion to
          // phi and, inside this interval, to u (an integral over [0, pi] in phi of 0.5 tolerance pi).
          tolerance_per_u_(0.5 * tolerance * (hi - lo) / kPi) {
        // The singularities' images in u: phi = mid - half cos u, with every translate by 2 pi k and the
        // mirror -phi (the term is even and periodic), nearest first.
        for (const std::complex<double>& z : events.singularities)
            for (double sign : {-1.0, 1.0})
                for (int k = -1; k <= 1; ++k) {
                    const std::complex<double> phi(sign * z.real() + 2 * kPi * k, z.imag());
                    const std::complex<double> u = std::acos((mid_ - phi) / half_);
                    if (std::fabs(u.imag()) < 12) singular_u_.push_back({u.real(), std::fabs(u.imag())});
                }
        piece(term, 0, kPi, 0);
    }

private:
    // Both sums of one pair on a piece, with the values' own estimated errors and the magnitude (the
    // scale of the sums' rounding), each weighted by the Kronrod weights.
    struct Sample {
        double kronrod = 0, gauss = 0, value_error = 0, magnitude = 0;
    };

    template <class Term>
    Sample sample(const Term& term, double u0, double u1) const {
        const double centre = 0.5 * (u0 + u1), radius = 0.5 * (u1 - u0);
        Sample s;
        for (int i = 0; i < pair_.points; ++i) {
            const double u = centre + radius * pair_.nodes[i];
            const double jacobian = radius * half_ * std::sin(u);
            const ExactValue v = term(mid_ - half_ * std::cos(u));
            const double wk = pair_.kronrod_weights[i] * jacobian;
            s.kronrod += wk * v.term;
            s.gauss += pair_.gauss_weights[i] * jacobian * v.term;
            s.value_error += wk * v.error;
            s.magnitude += wk * std::fabs(v.term);
        }
        return s;
    }

// Whether a singularity lies inside the Bernstein ellipse E_rho of [u0, u1] (foci u0, u1, sum of the
    // distances below (rho + 1/rho) times the half length); `split` is then where to cut: at its real part
    // when that lies well inside, otherwise graded towards it by 1 : 1.7.
    bool near_singularity(double u0, double u1, double& split) const {
        const double centre = 0.5 * (u0 + u1), radius = 0.5 * (u1 - u0);
        const double limit = (rule_.rho + 1.0 / rule_.rho) * radius;
        double best = std::numeric_limits<double>::infinity();
        for (const auto& z : singular_u_) {
            const double d = std::hypot(z.first - u0, z.second) + std::hypot(z.first - u1, z.second);
            if (d >= limit || d >= best) continue;
            best = d;
            const double margin = 0.25 * (u1 - u0);
            split = z.first > u0 + margin && z.first < u1 - margin ? z.first
                    : z.first <= centre ? u0 + (u1 - u0) / 2.7
                                        : u1 - (u1 - u0) / 2.7;
        }
        return best < limit;
    }

    template <class Term>
    void piece(const Term& term, double u0, double u1, int depth) {
        double split = 0;
        if (depth < 40 && out_.pieces + depth < kMaxPieces && near_singularity(u0, u1, split)) {
            piece(term, u0, split, depth + 1);
            piece(term, split, u1, depth + 1);
            return;
        }
        const Sample s = sample(term, u0, u1);
        const double estimate = std::fabs(s.kronrod - s.gauss);
        // A difference at the level of the values' own errors or of rounding cannot be reduced by
        // splitting; it is counted in the estimate all the same. (Both sums' value errors together: the Gauss
        // weights are at most 2.05 times the Kronrod weights at the same nodes, so 3x is within 2 % of it.)
        const double floor = 3 * s.value_error + 1e3 * std::numeric_limits<double>::epsilon() * s.magnitude;
        // Splitting stops at pieces of 1e-9 in u and after kMaxPieces pieces per interval: the estimate then
        // reports what was not reached.
        if (estimate > tolerance_per_u_ * (u1 - u0) && estimate > floor && u1 - u0 > 1e-9 &&
            out_.pieces + depth < kMaxPieces) {
            const double um = 0.5 * (u0 + u1);
            piece(term, u0, um, depth + 1);
            piece(term, um, u1, depth + 1);
            return;
        }
        out_.integral += s.kronrod;
        out_.error += estimate + s.value_error + 64 * std::numeric_limits<double>::epsilon() * s.magnitude;
        out_.pieces += 1;
    }

    static constexpr int kMaxPieces = 1024;
    double mid_, half_;
    AzimuthRule rule_;
    const KronrodRule& pair_;
    MeanSum& out_;
    double tolerance_per_u_;
    std::vector<std::pair<double, double>> singular_u_;  // (real part, |imaginary part|)
};

}  // namespace

AzimuthRule azimuth_rule_for(double tolerance) {
    // The Gauss rule must integrate the substitution's Jacobian sin u on [0, pi] well below the tolerance
    // (Gauss-Legendre's relative error there: 4 nodes 1.6e-5, 6 nodes 4e-10, 8 nodes 3e-15), or its
    // difference to the Kronrod rule would never fall below the tolerance however small the piece. The
    // pair of 8 Gauss nodes (17 points; a Gauss rule of 6 nodes let its difference to the halves understate
    // the error by up to 0.7x on 1,000 random texels, 8 kept it below 0.21x), of 12 (25 points) below 1e-8,
    // and the grading rho = 2 (3.5 spent 60 % more terms for no better ratio).
    if (tolerance >= 1e-8) return {8, 2.0};
    return {12, 2.5};
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

ExactValue azimuth_mean_of(const std::function<ExactValue(double)>& term, double c, double s, double n_dot_v,
                           double n_dot_l, double tolerance) {
    ExactValue out;
    const double sv2 = 1 - n_dot_v * n_dot_v, sl2 = 1 - n_dot_l * n_dot_l;
    if (sv2 <= 0 || sl2 <= 0) return term(0.0);  // the azimuth does not change the term
    const AzimuthEvents events = azimuth_events(c, s, n_dot_v, n_dot_l);
    const AzimuthRule rule = azimuth_rule_for(tolerance);
    MeanSum sum;
    for (std::size_t i = 0; i + 1 < events.breakpoints.size(); ++i)
        AzimuthInterval(term, events.breakpoints[i], events.breakpoints[i + 1], events, rule, tolerance, sum);
    out.term = std::clamp(sum.integral / kPi, 0.0, 1.0);
    out.error = sum.error / kPi;
    out.quadrature_pieces = sum.pieces;
    return out;
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
    return azimuth_mean_of(
        [&](double phi) { return term_of(alpha, alpha, wi, lut_light(n_dot_l, phi), visibility, c, s2, value_tolerance); },
        c, std::sqrt(s2), n_dot_v, n_dot_l, tolerance);
}

}  // namespace ms::exact
