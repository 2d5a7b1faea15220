// The VNDF probability of a region of microfacet normals bounded by spherical caps, computed exactly
// as a line integral over the region's boundary (the derivation is above cap_region.cpp).
#pragma once

#include <complex>
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
// Arcs take the closed form (partial fractions over the roots of their circle's quartic) instead where its
// error bound fits into the tolerance (boundary_integral shares it over the whole boundary), unless
// `closed_form` is off.
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

// The quartic z^2 |v(e^{i psi})|^2 = sum c_i z^i of a circle (v = p + q cos psi + r sin psi, z = e^{i psi})
// and its roots.
struct CircleQuartic {
    std::complex<double> c[5];
    std::complex<double> roots[4];
    int root_count = 0;  // 4, or 2 when the z^4 and z^0 terms vanish, 0 when both leading terms do
    double k0 = 0;       // the mean of |v|^2 (the scale of every coefficient)
};
CircleQuartic circle_quartic(const Vec3& p, const Vec3& q, const Vec3& r);

// What the closed form of an arc needs of its circle alone: the roots (0 and 1 inside the unit disc, 2 and 3
// their reflections 1 / conj(z)), 1 / (i P~4'(z_j)) at each, and
// delta, the bound on |P~4 - P4| on |z| = 1 of the polynomial the computed roots solve exactly.
// usable is false when the quartic degenerates (leading terms vanish, coincident roots) or its roots
// are too inaccurate for the bound (delta >= min_norm2 / 4).
struct ClosedFormRoots {
    bool usable = false;
    std::complex<double> roots[4];
    std::complex<double> inv_i_derivative[4];
    double delta = 0;
};
ClosedFormRoots closed_form_roots(const CircleQuartic& quartic, double min_norm2);

// The poles of 1 / |v(psi)|^2 in the upper half plane of psi (one period): at most the quartic's two roots
// inside the unit disc, kept without allocating.
struct PoleList {
    std::complex<double> items[4];
    int count = 0;
    const std::complex<double>* begin() const { return items; }
    const std::complex<double>* end() const { return items + count; }
};

// A cap's circle prepared once for a surface's stretch (it does not depend on wi): the basis and the
// parametrisation boundary_integral uses, the quartic, its closed-form roots and its poles. Passed to
// boundary_integral, it replaces the per-call root finding for the cap equal to `cap` (same axis and
// cosine), so a circle shared by many views (every azimuth and NdotV of a LUT row, with the light
// fixed) solves its quartic once. The integrand's numerator a.(v x dv) is linear in a, so roots and
// reciprocal derivatives serve every a.
struct PreparedCircle {
    Cap cap;
    double alpha_x = 1, alpha_y = 1;
    Vec3 e1, e2, p, q, r;
    CircleQuartic quartic;
    ClosedFormRoots closed;
    PoleList poles;  // of 1 / |v|^2 in the upper half plane (for quadrature)
    double min_norm2 = 1, speed_bound = 0;
};
PreparedCircle prepare_circle(double alpha_x, double alpha_y, const Cap& cap);

// The boundary integral of a region: B = closed line integral of a.(v x dv) / |v|^2 over the
// boundary of the intersection of the caps, with its estimated absolute error. The VNDF probability of
// the region is B / (pi (1 + a.z)) when the region lies in the VNDF's support {m.z > 0, m.wi > 0}.
struct BoundaryIntegral {
    double value = 0;
    double error = 0;       // quadrature estimate plus a rounding floor
    int quadrature_pieces = 0;
};
// `absolute_tolerance` applies to `value`: the closed forms' bounds are accepted where they fit together
// (the smallest per radian first), the arcs left to quadrature share the rest in proportion to their
// length. `prepared`
// (optional) must have been prepared for the surface's alpha_x, alpha_y.
BoundaryIntegral boundary_integral(const Microsurface& surface, std::vector<Cap> caps, const ArcRule& rule,
                                   double absolute_tolerance, const PreparedCircle* prepared = nullptr);
// The part of one cap's circle inside another cap, as boundary_integral finds it on its way (the whole
// circle, none of it, or one arc [lo, hi] of psi in the circle's basis, with e^{i lo} and e^{i hi}). Passed
// to boundary_integral for a pair of caps that stays fixed across many calls (a LUT row's cone caps round
// e_z and round wo, which the support {m.wi > 0} alone cuts differently from view to view), it is taken
// instead of computed: the same values bit for bit, without the pair's two arc angles.
struct CircleInCap {
    Cap circle, cap;
    enum Kind { whole, none, arc } kind = whole;
    double lo = 0, hi = 0;
    double lo_c = 1, lo_s = 0, hi_c = 1, hi_s = 0;  // cos and sin of lo and hi
};
CircleInCap circle_in_cap(const Cap& circle, const Cap& cap);
// The same on `cap_count` caps in place (at most 6; coincident ones are removed in place), without allocating;
// the pairs of caps found in `known_pairs` (bit for bit) are taken from there.
BoundaryIntegral boundary_integral(const Microsurface& surface, Cap* caps, std::size_t cap_count, const ArcRule& rule,
                                   double absolute_tolerance, const PreparedCircle* prepared = nullptr,
                                   const CircleInCap* known_pairs = nullptr, std::size_t known_pair_count = 0);

// The boundary integral of the intersection of three hemispheres {m.n_k > 0} (unit normals), as
// boundary_integral of the caps {n_k, 0, 1} computes it, from the circles' meeting points (no arc
// angles): the normalisation of P(cone), the hemisphere {m.z > 0, m.wo > 0} in the support
// {m.wi > 0}. Nearly coincident or opposite normals fall back to boundary_integral.
BoundaryIntegral hemisphere_integral(const Microsurface& surface, const Vec3& n1, const Vec3& n2, const Vec3& n3);

// One arc psi in [lo, hi] of a cap's circle m(psi) = c n + s (cos psi e1 + sin psi e2), in the basis
// (e1, e2) boundary_integral uses, not clipped by other caps: the integral of a.(v x dv) / |v|^2 by the
// closed form where `rule` allows it and its bound meets `absolute_tolerance`, else by quadrature.
// Requires a circle that is no great circle (c > 0) and of non-constant |v|^2 (not round e_z of an isotropic
// surface, alpha not 1).
struct ArcIntegral {
    double value = 0, error = 0;
    bool closed_form = false;
};
ArcIntegral integrate_arc(const Microsurface& surface, const Cap& cap, double lo, double hi, const ArcRule& rule,
                          double absolute_tolerance);

}  // namespace ms::exact
