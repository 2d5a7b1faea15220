// The VNDF probability of a region of microfacet normals bounded by spherical caps, computed exactly
// as a line integral over the region's boundary (the derivation is above cap_region.cpp).
#pragma once

#include <vector>

#include "core/types.hpp"

namespace ms::exact {

// The cap {m : m.n > c} of the unit sphere of normals: n unit, 0 <= c < 1, s = sqrt(1 - c^2) passed in
// so that a caller holding sin^2 directly (narrow cones) keeps every digit of it.
struct Cap {
    Vec3 n;
    double c = 0, s = 1;
};

// How the boundary arcs are integrated: Gauss-Legendre with `high` nodes on every piece, `low` nodes
// for the error estimate |Q_high - Q_low|, pieces bisected until every complex pole of the integrand
// lies outside the Bernstein ellipse of parameter `rho` of its piece, then further while a piece's
// estimate exceeds its share of the tolerance.
// An arc whose closed form (partial fractions over the roots of its circle's quartic) carries an error
// bound within its share of the tolerance takes the closed form instead, unless `closed_form` is off.
struct ArcRule {
    int high = 12, low = 8;
    double rho = 4;
    bool closed_form = true;
};

// The rule used for a requested absolute tolerance on the term (estimated error of each value).
ArcRule arc_rule_for(double tolerance);

// The stretched view of a query: S = diag(alpha_x, alpha_y, 1) and a = normalize(S wi), the direction
// the spherical-cap sampler is centred on.
struct Microsurface {
    double alpha_x = 1, alpha_y = 1;
    Vec3 a;  // normalize(alpha_x wi.x, alpha_y wi.y, wi.z)
};
Microsurface make_microsurface(double alpha_x, double alpha_y, const Vec3& wi);

// The boundary integral of a region: B = closed line integral of a.(v x dv) / |v|^2 over the
// boundary of the intersection of the caps, with its estimated absolute error. The VNDF probability of
// the region is B / (pi (1 + a.z)) when the region lies in the VNDF's support {m.z > 0, m.wi > 0}.
struct BoundaryIntegral {
    double value = 0;
    double error = 0;       // quadrature estimate plus a rounding floor
    int quadrature_pieces = 0;
};
// `absolute_tolerance` applies to `value`; pieces share it in proportion to their length.
BoundaryIntegral boundary_integral(const Microsurface& surface, std::vector<Cap> caps, const ArcRule& rule,
                                   double absolute_tolerance);

// One arc psi in [lo, hi] of a cap's circle m(psi) = c n + s (cos psi e1 + sin psi e2), in the basis
// (e1, e2) boundary_integral uses, not clipped by other caps: the integral of a.(v x dv) / |v|^2 by the
// closed form where `rule` allows it and its bound meets `absolute_tolerance`, else by quadrature.
// Requires a circle that is no great circle (c > 0) and no circle round e_z of an isotropic surface.
struct ArcIntegral {
    double value = 0, error = 0;
    bool closed_form = false;
};
ArcIntegral integrate_arc(const Microsurface& surface, const Cap& cap, double lo, double hi, const ArcRule& rule,
                          double absolute_tolerance);

}  // namespace ms::exact
