// Derivation. The spherical-cap sampler (Dupuy & Benyoub 2023) draws o uniformly on the cap
// {|o| = 1, o.z >= -a.z} of area 2 pi (1 + a.z), with a = normalize(S wi), S = diag(alpha_x, alpha_y, 1),
// and returns the normal m = normalize(S d), d = (o + a) / |o + a|. So the VNDF probability of a region
// R of normals is the area of its preimage in o over 2 pi (1 + a.z). In d the map o -> d has area element
// dA_o = 4 (a.d) domega_d (the alpha = 1 VNDF 2 (a.d) / (pi (1 + a.z)) times the cap's area), and
// 4 (a.d) domega = d[2 a.(d x dd)] on the unit sphere, a 1-form smooth everywhere. Stokes gives
//
//     P(R) = 1 / (pi (1 + a.z)) * closed integral over dR of a.(v x dv) / |v|^2,     v = S^-1 m,
//
// because d x dd = v x dv / |v|^2 for d = v / |v|, and m -> d = normalize(S^-1 m) preserves orientation
// (det S > 0), so the boundary may be traversed in m: counter-clockwise around each cap's axis.
//
// R is an intersection of caps {m.n_k > c_k}. Its boundary is made of arcs of the caps' circles
// m(psi) = c_k n_k + s_k (cos psi e1 + sin psi e2), (e1, e2, n_k) right-handed: the part of circle k
// inside cap j solves A cos psi + B sin psi > C with A = s_k e1.n_j, B = s_k e2.n_j,
// C = c_j - c_k n_k.n_j, the arc atan2(B, A) +- acos(C / hypot(A, B)). On an arc v = p + q cos psi +
// r sin psi (p = c_k S^-1 n_k, q = s_k S^-1 e1, r = s_k S^-1 e2), v x dv = [q x r + (p x r) cos psi -
// (p x q) sin psi] dpsi, and the integrand is that, dotted with a, over |v|^2.
//
// Three cases integrate in closed form:
//  - a great circle (c_k = 0): v stays in the plane normal to S n_k (v.S n_k = m.n_k = 0), so
//    v x dv = |v|^2 dtheta n^ with n^ = normalize(S n_k) and the arc gives (a.n^) times the angle v
//    sweeps round n^;
//  - the circle round e_z of an isotropic surface: |v|^2 = c^2 + s^2 / alpha^2 is constant, and any circle when
//    alpha_x = alpha_y = 1 (v = m, |v|^2 = c^2 + s^2 = 1);
//  - (both of the hemisphere's three circles are great circles, so P(hemisphere) is closed-form.)
// Every other arc integrates in closed form by partial fractions over the roots of the quartic below
// (closed_form_arc); where that form's error bound (roots and rounding) does not fit into the tolerance
// beside the other arcs' (boundary_integral), or the quartic degenerates, the arc is integrated by
// Gauss-Legendre on pieces. |v(psi)|^2 is a positive trigonometric
// polynomial of degree 2: with z = e^{i psi}, z^2 |v|^2 is a quartic whose roots come in pairs z, 1/conj(z),
// and each root inside the unit disc is a pole of the integrand at psi = arg z + i (-ln |z|). For smooth
// or strongly anisotropic surfaces those poles come within ~alpha (or ~alpha_y / alpha_x) of the real
// axis, where any fixed rule fails; a piece whose Bernstein ellipse of parameter rho excludes every pole
// converges like rho^(-2n), so pieces are bisected until it does.
#include "exact/cap_region.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <stdexcept>

#include "exact/gauss_legendre.hpp"

namespace ms::exact {

namespace {

constexpr double kTwoPi = 2 * kPi;

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
Vec3 scale(const Vec3& a, double k) { return {a.x * k, a.y * k, a.z * k}; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 unit(const Vec3& a) { return scale(a, 1.0 / std::sqrt(dot(a, a))); }

// An orthonormal pair (e1, e2) with e1 x e2 = n, continuous away from n = -e_z (Frisvad / Duff et al.'s
// branchless basis); n = e_z gives exactly (e_x, e_y).
void basis(const Vec3& n, Vec3& e1, Vec3& e2) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double b = n.x * n.y * a;
    e1 = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    e2 = {b, sign + n.y * n.y * a, -n.y};
}

// An arc psi in [lo, hi] of a circle, with e^{i lo} and e^{i hi} carried along from where the ends were
// found (the circles' meeting points, in closed form), so that the integrals need no sine or cosine of them.
// (Plain doubles rather than std::complex, whose constructor would zero every array of intervals.)
struct UnitPoint {
    double c, s;  // cos psi, sin psi
    std::complex<double> complex() const { return {c, s}; }
};
struct Interval {
    double lo, hi;
    UnitPoint e_lo, e_hi;
};

// A few intervals without allocation (boundary_integral runs ~10^8 times in a large exact bake): the
// arcs of one circle inside the other caps. Intersecting disjoint intervals, each shorter than a turn,
// with a periodic arc at most doubles their number, so n caps give at most 2^(n - 2) arcs.
struct ArcList {
    static constexpr std::size_t kCapacity = 16;  // enough for 6 caps
    Interval items[kCapacity];
    std::size_t count = 0;
    void push(const Interval& i) {
        if (count == kCapacity) throw std::length_error("boundary_integral: too many caps (at most 6)");
        items[count++] = i;
    }
    bool empty() const { return count == 0; }
    const Interval* begin() const { return items; }
    const Interval* end() const { return items + count; }
};

// Where circle k meets cap j (CircleInCap): the part of m(psi) = c_k n_k + s_k (cos psi e1 + sin psi e2)
// with m.n_j > c_j.
CircleInCap meet(const Cap& ck, const Cap& cj, const Vec3& e1, const Vec3& e2) {
    CircleInCap out;
    out.circle = ck;
    out.cap = cj;
    const Vec3 dn = sub(cj.n, ck.n);  // e1.n_j = e1.(n_j - n_k): no cancellation when the axes are close
    const double A = ck.s * dot(e1, dn), B = ck.s * dot(e2, dn);
    // C = c_j - c_k n_k.n_j written as (c_j - c_k) + c_k (1 - n_k.n_j), 1 - n_k.n_j = |n_j - n_k|^2 / 2.
    const double C = (cj.c - ck.c) + ck.c * 0.5 * dot(dn, dn);
    const double R = std::sqrt(A * A + B * B);
    if (C < -R) {  // circle k lies inside cap j
        out.kind = CircleInCap::whole;
        return out;
    }
    if (C >= R) {  // outside (or touching only): no boundary here
        out.kind = CircleInCap::none;
        return out;
    }
    const double centre = std::atan2(B, A);
    // half = acos(C / R), C / R in (-1, 1), as an argument: then e^{i half} below is its exact companion
    // (and sqrt((R - C)(R + C)) keeps the digits of a short arc that 1 - (C / R)^2 would cancel).
    const double sine_half = std::sqrt((R - C) * (R + C));
    const double half = std::atan2(sine_half, C);
    const std::complex<double> e_centre(A / R, B / R), e_half(C / R, sine_half / R);
    const std::complex<double> e_lo = e_centre * std::conj(e_half), e_hi = e_centre * e_half;
    out.kind = CircleInCap::arc;
    out.lo = centre - half;
    out.hi = centre + half;
    out.lo_c = e_lo.real(), out.lo_s = e_lo.imag(), out.hi_c = e_hi.real(), out.hi_s = e_hi.imag();
    return out;
}

bool same_cap(const Cap& a, const Cap& b) {
    return a.c == b.c && a.s == b.s && a.n.x == b.n.x && a.n.y == b.n.y && a.n.z == b.n.z;
}

// The parts of circle k that lie inside every other cap, as psi intervals (possibly one full turn).
// Into `arcs` (left empty when circle k bounds nothing). A pair found in `known` (bit for bit the same
// caps) is taken from there instead of computed.
void boundary_arcs(const Cap* caps, std::size_t cap_count, std::size_t k, const Vec3& e1, const Vec3& e2,
                   const CircleInCap* known, std::size_t known_count, ArcList& arcs) {
    arcs.count = 0;
    arcs.push({0.0, kTwoPi, {1, 0}, {1, 0}});
    bool full = true;
    for (std::size_t j = 0; j < cap_count; ++j) {
        if (j == k) continue;
        const CircleInCap* found = nullptr;
        for (std::size_t i = 0; i < known_count && !found; ++i)
            if (same_cap(known[i].circle, caps[k]) && same_cap(known[i].cap, caps[j])) found = &known[i];
        const CircleInCap meeting = found ? *found : meet(caps[k], caps[j], e1, e2);
        if (meeting.kind == CircleInCap::whole) continue;
        if (meeting.kind == CircleInCap::none) {
            arcs.count = 0;
            return;
        }
        const Interval allowed{meeting.lo, meeting.hi, {meeting.lo_c, meeting.lo_s}, {meeting.hi_c, meeting.hi_s}};
        ArcList next;
        for (const Interval& cur : arcs) {
            if (full) {
                next.push(allowed);
                continue;
            }
            for (int shift = -1; shift <= 1; ++shift) {
                const double allowed_lo = allowed.lo + shift * kTwoPi, allowed_hi = allowed.hi + shift * kTwoPi;
                const bool own_lo = cur.lo >= allowed_lo, own_hi = cur.hi <= allowed_hi;
                const double lo = own_lo ? cur.lo : allowed_lo, hi = own_hi ? cur.hi : allowed_hi;
                if (hi > lo) next.push({lo, hi, own_lo ? cur.e_lo : allowed.e_lo, own_hi ? cur.e_hi : allowed.e_hi});
            }
        }
        full = false;
        std::copy(next.begin(), next.end(), arcs.items);
        arcs.count = next.count;
        if (arcs.empty()) return;
    }
}

}  // namespace

namespace {

// Complex helpers for the hot paths, free of the C library's special-value handling (libgcc's complex
// division and glibc's hypot cost several times the arithmetic): |z| through the squared modulus while
// that stays in range (else std::abs), a / b through the conjugate, and the principal square root from
// two real ones, each to a few ulps (every caller checks its results afterwards or bounds their rounding).
double modulus(const std::complex<double>& z) {
    const double n = std::norm(z);
    return n < 1e290 && (n > 1e-290 || n == 0) ? std::sqrt(n) : std::abs(z);
}
std::complex<double> divide(const std::complex<double>& a, const std::complex<double>& b) {
    return a * std::conj(b) / std::norm(b);
}
std::complex<double> principal_sqrt(const std::complex<double>& z) {
    const double x = z.real(), y = z.imag();
    const double t = std::sqrt(0.5 * (modulus(z) + std::fabs(x)));  // no cancellation: both terms >= 0
    if (t == 0) return 0;
    return x >= 0 ? std::complex<double>(t, 0.5 * y / t) : std::complex<double>(0.5 * std::fabs(y) / t, std::copysign(t, y));
}

// The roots of x^4 + a3 x^3 + a2 x^2 + a1 x + a0 by Ferrari's method, as starting points of the iteration
// in circle_quartic (cancellation can cost them digits; the iteration restores them). False where the
// construction breaks down (a quadruple root, non-finite values): the caller then starts elsewhere.
bool ferrari_roots(std::complex<double> a3, std::complex<double> a2, std::complex<double> a1,
                   std::complex<double> a0, std::complex<double>* z) {
    using cd = std::complex<double>;
    // x = y - a3 / 4: y^4 + p y^2 + q y + r.
    const cd shift = 0.25 * a3, a3_2 = a3 * a3;
    const cd p = a2 - 0.375 * a3_2;
    const cd q = a1 - 0.5 * a2 * a3 + 0.125 * a3_2 * a3;
    const cd r = a0 - 0.25 * a1 * a3 + 0.0625 * a2 * a3_2 - (3.0 / 256) * a3_2 * a3_2;
    // Resolvent cubic m^3 + p m^2 + (p^2 / 4 - r) m - q^2 / 8: for a root m != 0 the quartic is
    // (y^2 + p / 2 + m)^2 - 2 m (y - q / (4 m))^2, a difference of squares.
    const cd b1 = 0.25 * p * p - r, b0 = -0.125 * q * q;
    // m = u - p / 3: u^3 + P u + Q (Cardano), the cube root taken of the larger of the two candidates.
    const cd P = b1 - p * p / 3.0;
    const cd Q = (2.0 / 27) * p * p * p - p * b1 / 3.0 + b0;
    const cd root = principal_sqrt(0.25 * Q * Q + P * P * P / 27.0);
    const cd plus = -0.5 * Q + root, minus = -0.5 * Q - root;
    const cd radicand = std::norm(plus) >= std::norm(minus) ? plus : minus;
    cd m = -p / 3.0;
    if (radicand != cd(0)) {
        // The three cube roots; the resolvent root of largest modulus keeps 2 m well away from 0.
        const cd cube = std::polar(std::cbrt(modulus(radicand)), std::arg(radicand) / 3);
        const cd turn(-0.5, 0.8660254037844386);
        cd c = cube;
        double best = -1;
        for (int k = 0; k < 3; ++k, c *= turn) {
            const cd candidate = c - divide(P, 3.0 * c) - p / 3.0;
            if (std::norm(candidate) > best) best = std::norm(candidate), m = candidate;
        }
    }
    const cd s = principal_sqrt(2.0 * m);
    if (!(std::norm(s) > 0)) return false;
    const cd half_q_over_s = 0.5 * divide(q, s);
    // y^2 + s y + (p / 2 + m - q / (2 s)) and y^2 - s y + (p / 2 + m + q / (2 s)); each quadratic's larger
    // root first, the other as the product over it (no cancellation).
    const cd linear[2] = {s, -s};
    const cd constant[2] = {0.5 * p + m - half_q_over_s, 0.5 * p + m + half_q_over_s};
    for (int k = 0; k < 2; ++k) {
        const cd disc = principal_sqrt(linear[k] * linear[k] - 4.0 * constant[k]);
        const cd big = -0.5 * (linear[k] + (std::real(std::conj(linear[k]) * disc) >= 0 ? disc : -disc));
        if (!(std::norm(big) > 0)) return false;
        z[2 * k] = big - shift;
        z[2 * k + 1] = divide(constant[k], big) - shift;
    }
    for (int i = 0; i < 4; ++i)
        if (!std::isfinite(z[i].real()) || !std::isfinite(z[i].imag())) return false;
    return true;
}

}  // namespace

CircleQuartic circle_quartic(const Vec3& p, const Vec3& q, const Vec3& r) {
    using cd = std::complex<double>;
    CircleQuartic out;
    const double k0 = dot(p, p) + 0.5 * (dot(q, q) + dot(r, r));
    const double k1 = 2 * dot(p, q), k2 = 2 * dot(p, r);
    const double k3 = 0.5 * (dot(q, q) - dot(r, r)), k4 = dot(q, r);
    // |v|^2 = k0 + k1 cos + k2 sin + k3 cos 2psi + k4 sin 2psi.
    const cd c4(0.5 * k3, -0.5 * k4), c3(0.5 * k1, -0.5 * k2), c2(k0, 0), c1(0.5 * k1, 0.5 * k2), c0(0.5 * k3, 0.5 * k4);
    out.c[0] = c0, out.c[1] = c1, out.c[2] = c2, out.c[3] = c3, out.c[4] = c4;
    out.k0 = k0;
    const double negligible = 1e-26 * k0 * k0;  // compared with squared moduli
    if (std::norm(c4) > negligible) {
        // Durand-Kerner on the monic quartic: converges for any start off the real axis and for
        // well-separated or clustered roots alike (4 unknowns, so each sweep costs ~ 30 flops). Started
        // from Ferrari's closed form it needs two or three sweeps instead of about ten.
        const cd inv4 = std::conj(c4) / std::norm(c4);
        const cd a3 = c3 * inv4, a2 = c2 * inv4, a1 = c1 * inv4, a0 = c0 * inv4;
        cd* z = out.roots;
        if (!ferrari_roots(a3, a2, a1, a0, z)) {
            // Distinct points on a spiral of the roots' mean modulus.
            const double radius = std::pow(std::abs(a0), 0.25);
            const cd seed(0.4, 0.9);
            cd w = 1;
            for (int i = 0; i < 4; ++i) {
                z[i] = radius * w;
                w *= seed;
            }
        }
        double previous_change = std::numeric_limits<double>::infinity();
        for (int iter = 0; iter < 200; ++iter) {
            double change = 0;
            for (int i = 0; i < 4; ++i) {
                const cd x = z[i];
                const cd value = (((x + a3) * x + a2) * x + a1) * x + a0;
                cd denom = 1;
                for (int j = 0; j < 4; ++j)
                    if (j != i) denom *= x - z[j];
                // value / denom through the conjugate: libgcc's general complex division is 10x slower.
                const double dn = std::norm(denom);
                const cd step = dn > 0 ? value * std::conj(denom) / dn : cd(1e-3, 1e-3);
                z[i] -= step;
                change = std::max(change, std::norm(step) / (1 + std::norm(z[i])));
            }
            // Converged, or stalled at rounding noise (relative steps of a few ulps that no longer shrink;
            // a double root converges linearly, its squared steps falling 4x a sweep): the roots' accuracy
            // is checked afterwards either way (closed_form_roots).
            if (change < 1e-30 || (change < 1e-24 && change > 0.5 * previous_change)) break;
            previous_change = change;
        }
        out.root_count = 4;
    } else if (std::norm(c3) > negligible) {
        // The z^4 and z^0 terms vanish: z (c3 z^2 + c2 z + c1), two roots (z = 0 and infinity are no poles).
        const cd disc = std::sqrt(c2 * c2 - 4.0 * c3 * c1);
        const cd big = -0.5 * (c2 + (std::real(std::conj(c2) * disc) >= 0 ? disc : -disc));
        out.roots[out.root_count++] = big / c3;
        if (big != cd(0)) out.roots[out.root_count++] = c1 / big;
    }
    return out;
}

namespace {

// The poles of 1 / |v(psi)|^2 in the upper half plane (one period): the roots inside the unit disc.
PoleList poles_of(const CircleQuartic& quartic) {
    PoleList poles;
    for (int i = 0; i < quartic.root_count; ++i) {
        const std::complex<double> z = quartic.roots[i];
        const double m2 = std::norm(z);
        if (!(m2 < 1) || m2 == 0) continue;
        const double im = -0.5 * std::log(m2);
        if (im > 12) continue;  // farther than any piece's ellipse can reach
        poles.items[poles.count++] = {std::arg(z), im};
    }
    return poles;
}

// Closed form of an arc. With z = e^{i psi}, f dpsi = (al0 + al1 cos psi + al2 sin psi) / |v|^2 dpsi equals
// (n2 z^2 + n1 z + n0) / (i P4(z)) dz, n2 = (al1 - i al2) / 2, n1 = al0, n0 = (al1 + i al2) / 2, P4 the
// circle's quartic. Over the computed roots z_j (exact roots of P~4 = c4 prod (z - z_j)) partial fractions
// are exact: f~ dpsi = sum_j rho_j dz / (z - z_j), rho_j = N(z_j) / (i c4 prod_{k != j} (z_j - z_k)), and
// dz / (z - z_j) = d log(e^{i psi} - z_j), whose continuous branch is i psi + Log(1 - z_j e^{-i psi}) for
// |z_j| < 1 and Log(1 - e^{i psi} / z_j) (plus a constant) for |z_j| > 1 (|1 - w| > 0 with |w| < 1 keeps
// the principal Log continuous). The error bound has two parts:
//  - the roots: P~4 - P4 = sum (c~_i - c_i) z^i is at most delta on |z| = 1, so |f - f~| <= |N| delta /
//    (|v|^2 |v~|^2) with |v|^2 >= m (the smallest eigenvalue of S^-2 on unit normals). |N| / |v|^2 is at
//    most max|N| / m, and also |v'| / |v| <= |v'|max / sqrt(m) (N = a.(v x v'), |a| = 1), the tighter one
//    for smooth surfaces (max|N| ~ 1 / alpha^2, |v'| ~ 1 / alpha); and integral 1 / |v~|^2 <=
//    integral 1 / |v|^2 / (1 - delta / m), the last integral computed by the same closed form;
//  - rounding: each term rho_j L_j carries a few ulps of |rho_j| |L_j|, and Log(1 - w) an absolute
//    ~ ulp / |1 - w| from forming 1 - w; the residue sum may cancel, so the bound sums the moduli.
struct ClosedFormArc {
    bool usable = false;
    double value = 0, error = 0;
};

}  // namespace

// The part of the closed form that depends on the circle only (not on a, nor on the arc): the roots'
// accuracy and 1 / (i P~4'(z_j)) at each root, so that a circle shared by many arcs and many a (every
// view of a LUT row) solves its quartic once.
ClosedFormRoots closed_form_roots(const CircleQuartic& quartic, double min_norm2) {
    using cd = std::complex<double>;
    constexpr double eps = std::numeric_limits<double>::epsilon();
    ClosedFormRoots out;
    if (quartic.root_count != 4) return out;  // vanishing leading coefficients: quadrature instead
    // The roots come in pairs z, 1 / conj(z) (the quartic is self-inversive: c_{4-i} = conj(c_i)), two
    // inside the unit disc. The two smallest computed roots are kept and the others taken as their
    // reflections (P~ below is the polynomial of these rounded values), so that closed_form_arc can take
    // each outer root's logarithms as the conjugates of its partner's.
    cd z[4];
    {
        int first = 0, second = 1;  // the indices of the smallest and second smallest moduli
        double norms[4];
        for (int j = 0; j < 4; ++j) norms[j] = std::norm(quartic.roots[j]);
        if (norms[1] < norms[0]) std::swap(first, second);
        for (int j = 2; j < 4; ++j) {
            if (norms[j] < norms[first]) second = first, first = j;
            else if (norms[j] < norms[second]) second = j;
        }
        z[0] = quartic.roots[first];
        z[1] = quartic.roots[second];
        if (!(norms[second] < 1) || !(norms[first] > 0)) return out;  // no two roots inside
        z[2] = z[0] / norms[first];
        z[3] = z[1] / norms[second];
    }
    const cd c4 = quartic.c[4];
    // Coefficients of c4 prod (z - z_j) from the elementary symmetric functions of the roots.
    const cd e1 = z[0] + z[1] + z[2] + z[3];
    const cd e2 = z[0] * z[1] + z[0] * z[2] + z[0] * z[3] + z[1] * z[2] + z[1] * z[3] + z[2] * z[3];
    const cd e3 = z[0] * z[1] * z[2] + z[0] * z[1] * z[3] + z[0] * z[2] * z[3] + z[1] * z[2] * z[3];
    const cd e4 = z[0] * z[1] * z[2] * z[3];
    const cd rebuilt[5] = {c4 * e4, -c4 * e3, c4 * e2, -c4 * e1, c4};
    double expansion_scale = modulus(c4), coefficient_scale = 0;
    for (int j = 0; j < 4; ++j) expansion_scale *= 1 + modulus(z[j]);
    double delta = 0;
    for (int i = 0; i < 5; ++i) {
        delta += modulus(rebuilt[i] - quartic.c[i]);
        coefficient_scale += modulus(quartic.c[i]);
    }
    // The expansion above (a few roundings per term, each term at most expansion_scale) and the
    // coefficients themselves (dot products of p, q, r: a few ulps of sum |c_i| >= k0) were rounded.
    delta += 8 * eps * (expansion_scale + coefficient_scale);
    if (!(delta < 0.25 * min_norm2)) return out;  // roots too inaccurate (or not converged)
    for (int j = 0; j < 4; ++j) {
        cd derivative = c4;
        for (int k = 0; k < 4; ++k)
            if (k != j) derivative *= z[j] - z[k];
        const double dn = std::norm(derivative);
        if (!(dn > 0)) return out;  // coincident roots
        // 1 / (i P~4'(z_j)) through the conjugate.
        out.inv_i_derivative[j] = cd(0, -1) * std::conj(derivative) / dn;
        out.roots[j] = z[j];
    }
    out.delta = delta;
    out.usable = true;
    return out;
}

namespace {

// Log(x_hi) - Log(x_lo) for x = 1 - w, |w| < 1, as one logarithm and one atan2: Re x > 0 puts both
// arguments in (-pi/2, pi/2), so their difference lies in (-pi, pi) and is the argument of
// x_hi conj(x_lo) exactly (no branch to choose), and the moduli's logarithms subtract as
// log(|x_hi|^2 / |x_lo|^2) / 2. Half the calls of two complex logarithms, and none of the library's
// extra-precise path for |x| near 1 (a sorted exact sum), which the bound below does not need: forming
// x = 1 - w already costs an ulp of 1 / |x| in the logarithm, and the bound allows 32 of them.
std::complex<double> log_ratio(const std::complex<double>& x_hi, const std::complex<double>& x_lo, double norm_hi,
                               double norm_lo) {
    const std::complex<double> turn = x_hi * std::conj(x_lo);
    return {0.5 * std::log(norm_hi / norm_lo), std::atan2(turn.imag(), turn.real())};
}

// `e_lo`, `e_hi`: e^{i lo} and e^{i hi}.
ClosedFormArc closed_form_arc(const ClosedFormRoots& prepared, double al0, double al1, double al2, double lo,
                              double hi, std::complex<double> e_lo, std::complex<double> e_hi, double min_norm2,
                              double speed_bound) {
    using cd = std::complex<double>;
    constexpr double eps = std::numeric_limits<double>::epsilon();
    ClosedFormArc out;
    if (!prepared.usable) return out;
    const cd* z = prepared.roots;
    const double delta = prepared.delta;
    const cd n2(0.5 * al1, -0.5 * al2), n1(al0, 0), n0(0.5 * al1, 0.5 * al2);
    cd sum_f = 0, sum_one = 0;
    double rounding_f = 0, rounding_one = 0;
    // Roots 0 and 1 lie inside the unit disc, 2 and 3 are their reflections 1 / conj(z) (closed_form_roots).
    // For the inner root w = z e^{-i psi}; for its reflection w' = e^{i psi} / z' = conj(w), so 1 - w' is
    // the conjugate of 1 - w (Re > 0: no branch cut between them) and so are the logarithms' differences.
    // (z' is the reflection rounded: conj(w) stands for e^{i psi} / z' to a few ulps, as forming that
    // quotient would, which the rounding bound's 1 / |x| terms cover.)
    for (int j = 0; j < 2; ++j) {
        const cd w_lo = z[j] * std::conj(e_lo), w_hi = z[j] * std::conj(e_hi);
        const cd one_minus_lo = 1.0 - w_lo, one_minus_hi = 1.0 - w_hi;
        const double norm_lo = std::norm(one_minus_lo), norm_hi = std::norm(one_minus_hi);
        // |x| >= 1 - |w| > 0 (no root on the unit circle); a ratio of norms that underflows would need a
        // root within 1e-150 of it: the bound below then comes out infinite and the arc takes quadrature.
        const cd log_difference = log_ratio(one_minus_hi, one_minus_lo, norm_hi, norm_lo);
        // |Log x| <= |log |x|| + pi / 2 <= 0.7 + 1 / |x| + pi / 2 for |x| < 2 (log(1 / t) < 1 / t).
        const double inverse_hi = 1.0 / std::sqrt(norm_hi), inverse_lo = 1.0 / std::sqrt(norm_lo);
        const double outer_log_size = 2 * (2.3 + inverse_hi + inverse_lo) + inverse_hi + inverse_lo;
        for (const int root : {j, j + 2}) {
            const bool inside = root == j;
            const cd inv_i_derivative = prepared.inv_i_derivative[root];
            const cd rho_f = ((n2 * z[root] + n1) * z[root] + n0) * inv_i_derivative;
            const cd rho_one = z[root] * inv_i_derivative;  // numerator of 1 / |v|^2: n1 = 1
            const cd dl = inside ? log_difference + cd(0, hi - lo) : std::conj(log_difference);
            sum_f += rho_f * dl;
            sum_one += rho_one * dl;
            const double log_size = outer_log_size + (inside ? std::fabs(hi) + std::fabs(lo) : 0.0);
            rounding_f += std::sqrt(std::norm(rho_f)) * log_size;
            rounding_one += std::sqrt(std::norm(rho_one)) * log_size;
        }
    }
    rounding_f *= 32 * eps;
    rounding_one *= 32 * eps;
    const double ratio = delta / (min_norm2 - delta);  // < 1/3
    // integral 1 / |v|^2 <= (closed form + its rounding) / (1 - ratio), from the same bound with N = 1.
    const double integral_one = (std::fabs(sum_one.real()) + rounding_one) / (1 - ratio);
    const double max_numerator = std::fabs(al0) + std::sqrt(al1 * al1 + al2 * al2);
    const double max_integrand = std::min(max_numerator / min_norm2, speed_bound / std::sqrt(min_norm2));
    out.value = sum_f.real();
    out.error = delta / (1 - delta / min_norm2) * max_integrand * integral_one + rounding_f;
    out.usable = std::isfinite(out.value) && std::isfinite(out.error);
    return out;
}

// Whether a translate (by 2 pi k) of `pole` lies inside the Bernstein ellipse E_rho of [lo, hi]. With
// t the pole mapped to [-1, 1], t is inside E_rho iff |t - 1| + |t + 1| < rho + 1 / rho (the ellipse with
// foci -1, 1 and semi-axes (rho +- 1/rho) / 2): two square roots, no complex arithmetic.
bool pole_inside_ellipse(double lo, double hi, std::complex<double> pole, double rho) {
    const double mid = 0.5 * (lo + hi), inv_half = 2.0 / (hi - lo);
    const double limit = rho + 1.0 / rho;
    const double shift = std::round((mid - pole.real()) / kTwoPi) * kTwoPi;
    const double y = pole.imag() * inv_half, y2 = y * y;
    for (int k = -1; k <= 1; ++k) {
        const double x = (pole.real() + shift + k * kTwoPi - mid) * inv_half;
        if (std::sqrt((x - 1) * (x - 1) + y2) + std::sqrt((x + 1) * (x + 1) + y2) < limit) return true;
    }
    return false;
}

struct ArcIntegrand {
    Vec3 p, q, r;
    double k, bc, bs;  // a.(q x r), a.(p x r), a.(p x q)
    double operator()(double psi) const {
        const double c = std::cos(psi), s = std::sin(psi);
        const Vec3 v{p.x + q.x * c + r.x * s, p.y + q.y * c + r.y * s, p.z + q.z * c + r.z * s};
        return (k + bc * c - bs * s) / dot(v, v);
    }
};

struct PieceSum {
    double value = 0, error = 0;
    int pieces = 0;
};

// The pole translate (by 2 pi k) nearest to [lo, hi] that lies inside the piece's Bernstein ellipse of
// parameter rho, if any: its real part (where a graded split puts the piece boundary).
bool pole_near_piece(double lo, double hi, const PoleList& poles, double rho, double& real_part) {
    bool found = false;
    double best = std::numeric_limits<double>::infinity();
    const double mid = 0.5 * (lo + hi);
    for (const auto& pole : poles) {
        if (!pole_inside_ellipse(lo, hi, pole, rho)) continue;
        const double x = pole.real() + std::round((mid - pole.real()) / kTwoPi) * kTwoPi;
        const double distance = std::fabs(x - mid) + pole.imag();
        if (distance < best) {
            best = distance;
            real_part = x;
            found = true;
        }
    }
    return found;
}

// One piece of an arc. A piece whose ellipse holds a pole is split: at the pole's real part when that
// lies well inside, otherwise graded towards the pole by the ratio 1 : 1.7 (a pole at distance e above
// an end needs pieces growing geometrically away from it; for rho = 4 a ratio up to 2.78 keeps it
// outside, bisection would spend log(2.78) / log(2) = 1.5x more pieces).
void integrate_piece(const ArcIntegrand& f, const PoleList& poles, double lo, double hi,
                     const ArcRule& rule, double tolerance_per_radian, int depth, PieceSum& out) {
    const double half = 0.5 * (hi - lo), mid = 0.5 * (hi + lo);
    double pole_x = 0;
    if (depth < 60 && pole_near_piece(lo, hi, poles, rule.rho, pole_x)) {
        double split;
        const double margin = 0.25 * (hi - lo);
        if (pole_x > lo + margin && pole_x < hi - margin) split = pole_x;
        else if (pole_x <= lo + margin) split = lo + (hi - lo) / 2.7;
        else split = hi - (hi - lo) / 2.7;
        integrate_piece(f, poles, lo, split, rule, tolerance_per_radian, depth + 1, out);
        integrate_piece(f, poles, split, hi, rule, tolerance_per_radian, depth + 1, out);
        return;
    }
    const GaussRule& gh = gauss_legendre(rule.high);
    const GaussRule& gl = gauss_legendre(rule.low);
    double qh = 0, ql = 0, magnitude = 0;
    for (int i = 0; i < rule.high; ++i) {
        const double fx = f(mid + half * gh.nodes[i]);
        qh += gh.weights[i] * fx;
        magnitude += gh.weights[i] * std::fabs(fx);
    }
    for (int i = 0; i < rule.low; ++i) ql += gl.weights[i] * f(mid + half * gl.nodes[i]);
    qh *= half;
    ql *= half;
    // The difference is the low rule's error (the high rule's is far smaller, every pole lying outside
    // the piece's ellipse E_rho): a conservative estimate of the value returned. (Extrapolating it by
    // rho^(-2 (high - low)) was measured to be up to 85x optimistic on the stress set.)
    const double difference = std::fabs(qh - ql);
    const double estimate = difference;
    // Below ~1e3 ulps of the piece's magnitude the difference is rounding, not truncation: accept.
    const double rounding_floor = 1e3 * std::numeric_limits<double>::epsilon() * half * magnitude;
    // Splitting for the tolerance stops at depth 40 and after 4096 pieces on one circle: the estimate then
    // reports what was not reached (never hit on the stress set at tolerances >= 1e-13).
    if (estimate > tolerance_per_radian * (hi - lo) && difference > rounding_floor && depth < 40 && out.pieces < 4096) {
        integrate_piece(f, poles, lo, mid, rule, tolerance_per_radian, depth + 1, out);
        integrate_piece(f, poles, mid, hi, rule, tolerance_per_radian, depth + 1, out);
        return;
    }
    out.value += qh;
    out.error += estimate + 64 * std::numeric_limits<double>::epsilon() * half * magnitude;
    out.pieces += 1;
}

// The angle v sweeps round axis n^ while psi runs over [lo, hi] on a great circle, through pieces shorter
// than pi in psi (antipodal m map to antipodal v, so such a piece sweeps less than pi and atan2 is exact).
double swept_angle(const Vec3& q, const Vec3& r, const Vec3& axis, const Interval& arc) {
    const double lo = arc.lo, hi = arc.hi;
    if (hi - lo >= kTwoPi * (1 - 1e-15)) return kTwoPi;
    const int pieces = static_cast<int>(std::ceil((hi - lo) / (0.75 * kPi)));
    double total = 0;
    auto point = [&](double c, double s) { return Vec3{q.x * c + r.x * s, q.y * c + r.y * s, q.z * c + r.z * s}; };
    Vec3 v0 = point(arc.e_lo.c, arc.e_lo.s);
    for (int i = 1; i <= pieces; ++i) {
        const double psi1 = lo + (hi - lo) * i / pieces;
        const Vec3 v1 = i == pieces ? point(arc.e_hi.c, arc.e_hi.s) : point(std::cos(psi1), std::sin(psi1));
        total += std::atan2(dot(cross(v0, v1), axis), dot(v0, v1));
        v0 = v1;
    }
    return total;
}

}  // namespace

ArcRule arc_rule_for(double tolerance) {
    if (tolerance >= 1e-5) return {6, 4, 3.0};
    if (tolerance >= 1e-8) return {8, 6, 3.5};
    return {12, 8, 4.0};
}

ArcIntegral integrate_arc(const Microsurface& surface, const Cap& cap, double lo, double hi, const ArcRule& rule,
                          double absolute_tolerance) {
    const double ax = surface.alpha_x, ay = surface.alpha_y;
    auto unstretch = [&](const Vec3& m) { return Vec3{m.x / ax, m.y / ay, m.z}; };
    Vec3 e1, e2;
    basis(cap.n, e1, e2);
    const Vec3 p = scale(unstretch(cap.n), cap.c), q = scale(unstretch(e1), cap.s), r = scale(unstretch(e2), cap.s);
    const Vec3& a = surface.a;
    const double k_const = dot(a, cross(q, r)), bc = dot(a, cross(p, r)), bs = dot(a, cross(p, q));
    const CircleQuartic quartic = circle_quartic(p, q, r);
    const double min_norm2 = (1 - 1e-12) * std::min({1.0, 1 / (ax * ax), 1 / (ay * ay)});
    ArcIntegral out;
    if (rule.closed_form) {
        // |v'(psi)| = |r cos psi - q sin psi| <= sqrt(|q|^2 + |r|^2).
        const double speed_bound = std::sqrt(dot(q, q) + dot(r, r));
        const ClosedFormArc closed =
            closed_form_arc(closed_form_roots(quartic, min_norm2), k_const, bc, -bs, lo, hi, std::polar(1.0, lo),
                            std::polar(1.0, hi), min_norm2, speed_bound);
        if (closed.usable && closed.error <= absolute_tolerance) {
            out.value = closed.value;
            out.error = closed.error;
            out.closed_form = true;
            return out;
        }
    }
    PieceSum sum;
    integrate_piece(ArcIntegrand{p, q, r, k_const, bc, bs}, poles_of(quartic), lo, hi, rule,
                    absolute_tolerance / (hi - lo), 0, sum);
    out.value = sum.value;
    out.error = sum.error;
    return out;
}

BoundaryIntegral hemisphere_integral(const Microsurface& surface, const Vec3& n1, const Vec3& n2, const Vec3& n3) {
    // On great circle k the part inside hemisphere j is the half circle from -u_kj to u_kj,
    // counter-clockwise round n_k, with u_kj = normalize(n_k x n_j): there m.n_j falls through 0
    // ((n_k x u_kj).n_j = ((n_k.n_j)^2 - 1) / |n_k x n_j| < 0). Two half circles of one circle, taken
    // from -u_kj at 0 to u_kj at pi, meet in [beta, pi] when the other's start -u_kl (at beta) lies in
    // the first (beta in [0, pi]), else in [0, beta - pi]: from -u_kl to u_kj, or from -u_kj to u_kl.
    // The result is continuous in the normals, including where all three circles meet in two points
    // (coplanar normals; beta -> 0 or pi), so the tie-break (>= 0) is harmless.
    const Vec3 n[3] = {n1, n2, n3};
    Vec3 u[3][3];  // u[k][j] = normalize(n_k x n_j) = -u[j][k]
    for (int k = 0; k < 3; ++k)
        for (int j = k + 1; j < 3; ++j) {
            // n_k x (n_j - n_k): no cancellation when the axes are close.
            const Vec3 dn = sub(n[j], n[k]);
            const Vec3 w = cross(n[k], dn);
            const double w2 = dot(w, w);
            if (!(w2 > 1e-60) || dot(dn, dn) < 1e-28) return boundary_integral(surface, std::vector<Cap>{{n1, 0, 1}, {n2, 0, 1}, {n3, 0, 1}},
                                                        ArcRule{}, 0);
            u[k][j] = scale(w, 1 / std::sqrt(w2));
            u[j][k] = scale(u[k][j], -1);
        }
    const double ax = surface.alpha_x, ay = surface.alpha_y;
    auto unstretch = [&](const Vec3& m) { return Vec3{m.x / ax, m.y / ay, m.z}; };
    BoundaryIntegral result;
    double magnitude = 0;
    for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3, l = (k + 2) % 3;
        const bool later_start = -dot(u[k][l], n[j]) >= 0;
        const Vec3 start = later_start ? scale(u[k][l], -1) : scale(u[k][j], -1);
        const Vec3 end = later_start ? u[k][j] : u[k][l];
        // The angle v = S^-1 m sweeps round n^ = normalize(S n_k): in [0, pi] for an arc of at most half a
        // turn (S^-1 keeps the plane's orientation), so a cross product rounded below 0 is 0.
        const Vec3 axis = unit(Vec3{ax * n[k].x, ay * n[k].y, n[k].z});
        const Vec3 vs = unstretch(start), ve = unstretch(end);
        const double swept = std::atan2(std::max(0.0, dot(cross(vs, ve), axis)), dot(vs, ve));
        const double part = dot(surface.a, axis) * swept;
        result.value += part;
        magnitude += std::fabs(part);
    }
    result.error = 32 * std::numeric_limits<double>::epsilon() * magnitude;
    return result;
}

PreparedCircle prepare_circle(double alpha_x, double alpha_y, const Cap& cap) {
    PreparedCircle out;
    out.cap = cap;
    out.alpha_x = alpha_x;
    out.alpha_y = alpha_y;
    basis(cap.n, out.e1, out.e2);
    // The same expressions as boundary_integral's, so that a prepared circle is the one it would compute.
    auto unstretch = [&](const Vec3& m) { return Vec3{m.x / alpha_x, m.y / alpha_y, m.z}; };
    out.p = scale(unstretch(cap.n), cap.c);
    out.q = scale(unstretch(out.e1), cap.s);
    out.r = scale(unstretch(out.e2), cap.s);
    out.min_norm2 = (1 - 1e-12) * std::min({1.0, 1 / (alpha_x * alpha_x), 1 / (alpha_y * alpha_y)});
    out.speed_bound = std::sqrt(dot(out.q, out.q) + dot(out.r, out.r));
    out.quartic = circle_quartic(out.p, out.q, out.r);
    out.closed = closed_form_roots(out.quartic, out.min_norm2);
    out.poles = poles_of(out.quartic);
    return out;
}

CircleInCap circle_in_cap(const Cap& circle, const Cap& cap) {
    Vec3 e1, e2;
    basis(circle.n, e1, e2);
    return meet(circle, cap, e1, e2);
}

Microsurface make_microsurface(double alpha_x, double alpha_y, const Vec3& wi) {
    Microsurface m;
    m.alpha_x = alpha_x;
    m.alpha_y = alpha_y;
    m.a = unit(Vec3{alpha_x * wi.x, alpha_y * wi.y, wi.z});
    return m;
}

namespace {

constexpr std::size_t kMaxCaps = 6;

// An arc of a circle with a non-constant |v|^2, with its closed form where that is usable. (No member
// initialisers: the array of them is filled as arcs are found, not zeroed on every call.)
struct PendingArc {
    std::size_t circle;
    const PreparedCircle* known;  // the prepared circle standing for it, if any
    Interval arc;
    bool closed;
    double value, error;
};

}  // namespace

BoundaryIntegral boundary_integral(const Microsurface& surface, std::vector<Cap> caps, const ArcRule& rule,
                                   double absolute_tolerance, const PreparedCircle* prepared) {
    return boundary_integral(surface, caps.data(), caps.size(), rule, absolute_tolerance, prepared);
}

BoundaryIntegral boundary_integral(const Microsurface& surface, Cap* caps, std::size_t cap_count, const ArcRule& rule,
                                   double absolute_tolerance, const PreparedCircle* prepared,
                                   const CircleInCap* known_pairs, std::size_t known_pair_count) {
    if (cap_count > kMaxCaps) throw std::length_error("boundary_integral: too many caps (at most 6)");
    // Coincident caps (wo = e_z, wo = wi, wi = e_z) would each exclude the other's circle (C = R = 0):
    // keep one of each.
    for (std::size_t i = 0; i < cap_count; ++i)
        for (std::size_t j = cap_count; j-- > i + 1;) {
            const Vec3 dn = sub(caps[i].n, caps[j].n);
            if (dot(dn, dn) < 1e-30 && std::fabs(caps[i].c - caps[j].c) < 1e-16) {
                std::copy(caps + j + 1, caps + cap_count, caps + j);
                --cap_count;
            }
        }
    const double ax = surface.alpha_x, ay = surface.alpha_y;
    const Vec3& a = surface.a;
    auto unstretch = [&](const Vec3& m) { return Vec3{m.x / ax, m.y / ay, m.z}; };
    // m(psi) = p' + cos psi e1 + sin psi e2 on a cap's circle, and v = S^-1 m = p + q cos psi + r sin psi: the
    // prepared circle's where it stands for the cap (bit for bit the same).
    auto parametrise = [&](const Cap& cap, const PreparedCircle* known, Vec3& e1, Vec3& e2) {
        if (known) e1 = known->e1, e2 = known->e2;
        else basis(cap.n, e1, e2);
    };
    auto stretch_free = [&](const Cap& cap, const PreparedCircle* known, const Vec3& e1, const Vec3& e2, Vec3& p, Vec3& q,
                            Vec3& r) {
        p = known ? known->p : scale(unstretch(cap.n), cap.c);
        q = known ? known->q : scale(unstretch(e1), cap.s);
        r = known ? known->r : scale(unstretch(e2), cap.s);
    };
    BoundaryIntegral result;
    double rounding = 0;
    // |v|^2 = |S^-1 m|^2 >= min(1, 1 / alpha_x^2, 1 / alpha_y^2) for unit m; the factor covers m's rounding.
    const double min_norm2 = (1 - 1e-12) * std::min({1.0, 1 / (ax * ax), 1 / (ay * ay)});
    // First every circle's arcs: great circles and constant |v|^2 in closed form at once, the other arcs
    // by the closed form where it is usable, with its error bound; which of those bounds are accepted,
    // and the tolerance of the arcs left to quadrature, is decided over the whole boundary below.
    PendingArc pending[kMaxCaps * ArcList::kCapacity];
    std::size_t pending_count = 0;
    double general_length = 0;  // of the arcs that are neither on great circles nor of constant |v|^2
    for (std::size_t k = 0; k < cap_count; ++k) {
        const Cap& cap = caps[k];
        // The prepared circle stands for this cap when it has the same axis and cosine (bit for bit: its
        // basis and parametrisation are then the ones computed below).
        const PreparedCircle* known = prepared && same_cap(cap, prepared->cap) ? prepared : nullptr;
        Vec3 e1, e2, p, q, r;
        parametrise(cap, known, e1, e2);
        ArcList arcs;
        boundary_arcs(caps, cap_count, k, e1, e2, known_pairs, known_pair_count, arcs);
        if (arcs.empty()) continue;
        stretch_free(cap, known, e1, e2, p, q, r);
        if (cap.c == 0) {
            const Vec3 axis = unit(Vec3{ax * cap.n.x, ay * cap.n.y, cap.n.z});
            const double weight = dot(a, axis);
            for (const Interval& arc : arcs) {
                const double part = weight * swept_angle(q, r, axis, arc);
                result.value += part;
                rounding += std::fabs(part);
            }
            continue;
        }
        const double k_const = dot(a, cross(q, r)), bc = dot(a, cross(p, r)), bs = dot(a, cross(p, q));
        // |v|^2 is constant round e_z on an isotropic surface, and on every circle when S = I (alpha 1: v = m,
        // |v|^2 = c^2 + s^2 = 1), where the quartic degenerates.
        const bool constant_norm = (ax == ay && cap.n.x == 0 && cap.n.y == 0) || (ax == 1 && ay == 1);
        if (constant_norm) {
            // Constant |v|^2: integrate the trigonometric numerator.
            const double norm2 = dot(p, p) + dot(q, q);
            for (const Interval& arc : arcs) {
                const double part = (k_const * (arc.hi - arc.lo) + bc * (arc.e_hi.s - arc.e_lo.s) +
                                     bs * (arc.e_hi.c - arc.e_lo.c)) /
                                    norm2;
                result.value += part;
                rounding += std::fabs(k_const * (arc.hi - arc.lo) / norm2) + (std::fabs(bc) + std::fabs(bs)) * 2 / norm2;
            }
            continue;
        }
        // The roots serve the closed form only; quadrature finds its poles again below (for the few arcs
        // it takes). Optional: nothing to construct where a prepared circle has them.
        std::optional<ClosedFormRoots> own_roots;
        if (!known && rule.closed_form) own_roots = closed_form_roots(circle_quartic(p, q, r), min_norm2);
        const ClosedFormRoots* roots = known ? &known->closed : own_roots ? &*own_roots : nullptr;
        const double speed_bound = std::sqrt(dot(q, q) + dot(r, r));  // |v'| = |r cos psi - q sin psi|
        for (const Interval& arc : arcs) {
            PendingArc& item = pending[pending_count++];
            item = PendingArc{k, known, arc, false, 0.0, 0.0};
            general_length += arc.hi - arc.lo;
            if (!rule.closed_form) continue;
            const ClosedFormArc closed =
                closed_form_arc(*roots, k_const, bc, -bs, arc.lo, arc.hi, arc.e_lo.complex(), arc.e_hi.complex(), min_norm2,
                                speed_bound);
            if (!closed.usable) continue;
            item.closed = true;
            item.value = closed.value;
            item.error = closed.error;
        }
    }
    // The tolerance is shared over the boundary: the closed forms' bounds are accepted in the order of
    // their error per radian for as long as they leave the arcs after them at least as much tolerance per
    // radian as they themselves take; those arcs are integrated by quadrature to the rest, spread in
    // proportion to their length. (Every usable closed form is accepted when their bounds fit together.)
    // The values' error bounds then sum to at most the tolerance, rounding allowances aside, as with a
    // fixed share per arc, and an arc whose closed form carries a bound above that share but below what
    // the other arcs leave unused needs no quadrature.
    const double rounding_floor = 32 * std::numeric_limits<double>::epsilon() * rounding;
    // A twentieth is kept back for the allowances added after this choice (quadrature rounding, the
    // hemisphere's error in the ratio), so that a value asked to a tolerance stays within it.
    const double budget = 0.95 * absolute_tolerance - rounding_floor;
    auto density = [](const PendingArc& item) {
        return item.closed ? item.error / std::max(item.arc.hi - item.arc.lo, 1e-300)
                           : std::numeric_limits<double>::infinity();
    };
    // Insertion sort: a handful of arcs.
    for (std::size_t i = 1; i < pending_count; ++i)
        for (std::size_t j = i; j > 0 && density(pending[j]) < density(pending[j - 1]); --j)
            std::swap(pending[j], pending[j - 1]);
    std::size_t accepted = 0;
    double accepted_error = 0, accepted_length = 0;
    {
        double sum = 0, length = 0;
        for (std::size_t i = 0; i < pending_count && pending[i].closed; ++i) {
            sum += pending[i].error;
            length += pending[i].arc.hi - pending[i].arc.lo;
            const double rest = general_length - length;
            const bool fits = sum <= budget && (i + 1 == pending_count || (rest > 0 && density(pending[i]) * rest <= budget - sum));
            if (fits) accepted = i + 1, accepted_error = sum, accepted_length = length;
        }
    }
    const double rest_length = general_length - accepted_length;
    const double tolerance_per_radian =
        rest_length > 0 ? std::max(0.0, (budget - accepted_error) / rest_length) : 0.0;
    PieceSum sum;
    for (std::size_t i = 0; i < accepted; ++i) {
        sum.value += pending[i].value;
        sum.error += pending[i].error;
    }
    // The arcs left to quadrature: their circle's integrand and poles, found again when the circle changes.
    std::size_t integrand_circle = kMaxCaps;
    ArcIntegrand f;
    PoleList poles;
    for (std::size_t i = accepted; i < pending_count; ++i) {
        const PendingArc& item = pending[i];
        if (item.circle != integrand_circle) {
            const Cap& cap = caps[item.circle];
            Vec3 e1, e2, p, q, r;
            parametrise(cap, item.known, e1, e2);
            stretch_free(cap, item.known, e1, e2, p, q, r);
            f = ArcIntegrand{p, q, r, dot(a, cross(q, r)), dot(a, cross(p, r)), dot(a, cross(p, q))};
            poles = item.known ? item.known->poles : poles_of(circle_quartic(p, q, r));
            integrand_circle = item.circle;
        }
        integrate_piece(f, poles, item.arc.lo, item.arc.hi, rule, tolerance_per_radian, 0, sum);
    }
    result.value += sum.value;
    result.error += sum.error;
    result.quadrature_pieces += sum.pieces;
    result.error += 32 * std::numeric_limits<double>::epsilon() * rounding;
    return result;
}

}  // namespace ms::exact
