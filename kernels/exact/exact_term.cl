/*
 * exact_term.cl - the generic micro-shadowing term without sampling, one work-item per query
 * (ms_exact_term) or per LUT texel (ms_exact_azimuth_mean, the mean over the relative azimuth).
 *
 * The same algorithm as the host's deterministic evaluator (host/exact/, whose cap_region.cpp carries
 * the derivation): T = P(cone) / P(hemisphere) under the VNDF of wi, each probability the closed line
 * integral of a.(v x dv) / |v|^2 over the boundary of an intersection of spherical caps, v = S^-1 m.
 * The boundary is arcs of the caps' circles with closed-form ends; great circles and the isotropic
 * circle round e_z integrate in closed form, every other arc by partial fractions over the roots of
 * a quartic (Durand-Kerner; exact_closed_form_arc) where that form's error bound allows, and otherwise
 * by Gauss-Legendre pieces split until the roots' poles of 1 / |v|^2 lie outside each piece's
 * Bernstein ellipse, then while the difference to a lower-order rule (the error estimate) exceeds the
 * piece's share of the tolerance. The azimuth mean integrates T between its non-analytic azimuths in a cosine
 * substitution, by a Gauss-Kronrod pair: the Kronrod sum is the value, its difference to the Gauss sum
 * (the Gauss rule's error, which bounds the Kronrod rule's) the estimate. Its terms hold the light fixed
 * and turn the view, so that they share the light's circle (exact_fixed_cone).
 *
 * OpenCL C has no recursion: the host's recursive bisections are depth-first walks over explicit
 * stacks of piece ends (pieces are finished left to right, so a piece's start is the previous one's
 * end and only ends are stacked). The stacks hold the host's whole depth (60 pole splits, 30 azimuth
 * levels); should one fill, the piece is finished with the rule as it stands, its integral of |f| is
 * added to the error and MS_EXACT_FLAG_STACK_FULL is set. Nothing is written out of bounds.
 *
 * Precision: `real` (common/real.cl). The thresholds that the host states in ulps of double are
 * stated here in ulps of `real`, so the float variant stops refining where float rounding, not the
 * quadrature, dominates, and its error estimate carries float's rounding floor. An arc takes the
 * closed form where its bound is within the arc's share of the tolerance or no larger than what the
 * quadrature reports at that floor (in float, rough surfaces: the quartic's coefficients are rounded
 * relative to the mean of |v|^2, ~1 / alpha^2, while |v|^2 >= 1 near the poles).
 */
/* Preamble (prepended by the host, device/runtime.cpp): common/microshadow_shared.h, real.cl, ... */

#if MS_REAL_IS_DOUBLE
typedef double2 ms_complex;
#define MS_EXACT_EPS DBL_EPSILON
/* Durand-Kerner stops when every squared relative step is below this. */
#define MS_EXACT_ROOT_STOP 1e-30
/* |c4|^2 (or |c3|^2) below this times k0^2: the quartic has lower degree. */
#define MS_EXACT_NEGLIGIBLE 1e-26
/* Caps closer than this (squared axis distance, cosine difference) are one cap. */
#define MS_EXACT_SAME_AXIS 1e-30
#define MS_EXACT_SAME_COS 1e-16
/* Azimuth breakpoints closer than this to each other or to 0 and pi are one. */
#define MS_EXACT_SAME_AZIMUTH 1e-12
#else
typedef float2 ms_complex;
#define MS_EXACT_EPS FLT_EPSILON
#define MS_EXACT_ROOT_STOP 1e-13f
#define MS_EXACT_NEGLIGIBLE 1e-11f
#define MS_EXACT_SAME_AXIS 1e-13f
#define MS_EXACT_SAME_COS 1e-7f
#define MS_EXACT_SAME_AZIMUTH 1e-6f
#endif

#define MS_EXACT_PI MS_R(3.14159265358979323846)
#define MS_EXACT_TWO_PI MS_R(6.28318530717958647692)

/* Stack capacities: the host's depth limits plus one. A build may lower them (-D) to test the guard. */
#ifndef MS_EXACT_ARC_STACK
#define MS_EXACT_ARC_STACK 61
#endif
#ifndef MS_EXACT_AZIMUTH_STACK
#define MS_EXACT_AZIMUTH_STACK 31
#endif
/* Closed-form arcs (1) or Gauss-Legendre on every arc (0, for tests and comparisons). */
#ifndef MS_EXACT_CLOSED_FORM
#define MS_EXACT_CLOSED_FORM 1
#endif
#define MS_EXACT_POLE_DEPTH 60      /* pole-driven splits of an arc piece */
#define MS_EXACT_ERROR_DEPTH 40     /* tolerance-driven splits of an arc piece */
#define MS_EXACT_AZIMUTH_DEPTH 30   /* tolerance-driven splits of an azimuth piece */
#define MS_EXACT_MAX_ARCS 4         /* a circle inside two other caps: at most two arcs */
#define MS_EXACT_MAX_BREAKPOINTS 10 /* 0, pi and up to 2 x 2 + 2 x 2 events */

inline real ms_exact_join(float hi, float lo) { return (real)hi + (real)lo; }

/* The cone's cosine as the caps need it. A narrow cone's circle is fixed by c and s together, and the
 * float pair carrying c (~48 bits) leaves c^2 + s^2 - 1 ~ 2^-48, a relative error 2^-48 / s^2 of the
 * circle (3.5e-9 at v = 1e-6): there c = sqrt(1 - s^2) from the exactly carried s^2 is consistent to
 * an ulp. A wide cone's (s^2 >= 1/2) needs c's own digits, which the pair keeps. */
inline real ms_exact_cone_cos(real carried_cos, real s2)
{
    return s2 < MS_R(0.5) ? sqrt(MS_R(1.0) - s2) : carried_cos;
}

/* ---- complex arithmetic on (re, im) pairs --------------------------------------------------------- */
inline ms_complex cx_mul(ms_complex a, ms_complex b) { return (ms_complex)(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
inline real cx_norm(ms_complex a) { return a.x * a.x + a.y * a.y; }
inline ms_complex cx_conj(ms_complex a) { return (ms_complex)(a.x, -a.y); }
/* a / b through the conjugate (b != 0). */
inline ms_complex cx_div(ms_complex a, ms_complex b) { return cx_mul(a, cx_conj(b)) / cx_norm(b); }
/* The principal square root, without cancellation in either component. */
inline ms_complex cx_sqrt(ms_complex a)
{
    const real r = hypot(a.x, a.y);
    if (r == MS_R(0.0)) return (ms_complex)(MS_R(0.0), MS_R(0.0));
    if (a.x >= MS_R(0.0)) {
        const real t = sqrt(MS_R(0.5) * (r + a.x));
        return (ms_complex)(t, a.y / (MS_R(2.0) * t));
    }
    const real t = sqrt(MS_R(0.5) * (r - a.x));
    return (ms_complex)(fabs(a.y) / (MS_R(2.0) * t), copysign(t, a.y));
}

/* ---- caps and their boundary arcs ----------------------------------------------------------------- */

/* The cap {m : m.n > c}, s = sqrt(1 - c^2) given separately (narrow cones keep its digits). */
typedef struct exact_cap {
    real3 n;
    real c, s;
} exact_cap;

inline exact_cap exact_cap_make(real3 n, real c, real s)
{
    exact_cap cap;
    cap.n = n;
    cap.c = c;
    cap.s = s;
    return cap;
}

/* An orthonormal pair (e1, e2) with e1 x e2 = n (Frisvad / Duff et al.'s branchless basis). */
inline void exact_basis(real3 n, real3* e1, real3* e2)
{
    const real sign = copysign(MS_R(1.0), n.z);
    const real a = MS_R(-1.0) / (sign + n.z);
    const real b = n.x * n.y * a;
    *e1 = (real3)(MS_R(1.0) + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *e2 = (real3)(b, sign + n.y * n.y * a, -n.y);
}

/* The parts of circle k inside every other cap, as psi intervals; returns their number. */
/* Each arc end also gets a first-order bound on its rounding error (end_lo, end_hi, radians): an end is
 * centre +- acos(C / R), and acos amplifies an error d of x = C / R by 1 / sqrt(1 - x^2), or to
 * sqrt(6 d) where 1 - |x| < 2 d (acos(1 - u) ~ sqrt(2 u)). Near tangency (x ~ 1, two circles barely
 * crossing, or a grazing view's great circle passing just inside a narrow cone) that is many ulps of
 * an end, which moves the integral by the integrand there times the shift: the dominant rounding of
 * the float kernel for narrow cones seen at grazing angles. d bounds the rounding of C and R from
 * their inputs (the cosines and sines of the caps, the axis difference and the basis, each correct to
 * a few ulps): 16 ulps of the sizes that enter them, over R. The ends of a whole circle (0, 2 pi) are
 * no ends: the integrand is periodic. */
/* Where circle k (basis e1, e2) meets cap j: wholly inside it, outside it (or touching only), or inside
 * over the arc [lo, hi] whose ends carry the rounding bound `end`. */
#define MS_EXACT_MEETS_WHOLE 0
#define MS_EXACT_MEETS_NONE 1
#define MS_EXACT_MEETS_ARC 2
typedef struct exact_meeting {
    exact_cap circle, cap;
    int kind;
    real lo, hi, end;
} exact_meeting;

inline int exact_same_cap(exact_cap a, exact_cap b)
{
    return a.n.x == b.n.x && a.n.y == b.n.y && a.n.z == b.n.z && a.c == b.c && a.s == b.s;
}

inline exact_meeting exact_meet(exact_cap ck, exact_cap cj, real3 e1, real3 e2)
{
    exact_meeting m;
    m.circle = ck;
    m.cap = cj;
    m.lo = m.hi = m.end = MS_R(0.0);
    const real3 dn = cj.n - ck.n; /* e1.n_j = e1.(n_j - n_k): no cancellation for close axes */
    const real A = ck.s * dot(e1, dn), B = ck.s * dot(e2, dn);
    /* C = c_j - c_k n_k.n_j as (c_j - c_k) + c_k |n_j - n_k|^2 / 2 */
    const real C = (cj.c - ck.c) + ck.c * MS_R(0.5) * dot(dn, dn);
    const real R = sqrt(A * A + B * B);
    if (C < -R) { /* circle k lies inside cap j */
        m.kind = MS_EXACT_MEETS_WHOLE;
        return m;
    }
    if (C >= R) { /* outside, or touching only */
        m.kind = MS_EXACT_MEETS_NONE;
        return m;
    }
    const real centre = atan2(B, A);
    const real x = C / R;
    const real half_angle = acos(x);
    m.kind = MS_EXACT_MEETS_ARC;
    m.lo = centre - half_angle;
    m.hi = centre + half_angle;
    /* The ends' rounding (above): of x, of the centre (atan2: |d(A, B)| / R), and of the sums. */
    const real dn_size = sqrt(dot(dn, dn));
    const real dx = MS_R(4.0) * MS_EXACT_EPS *
                    (fabs(cj.c) + fabs(ck.c) + cj.s + ck.s * dn_size * (MS_R(1.0) + fabs(x)) + fabs(C)) / R;
    const real gap = MS_R(1.0) - fabs(x);
    const real d_half = gap > MS_R(2.0) * dx ? dx / sqrt(gap * (MS_R(1.0) + fabs(x))) : sqrt(MS_R(6.0) * dx);
    const real d_centre = MS_R(4.0) * MS_EXACT_EPS * ck.s * dn_size / R;
    m.end = fmin(MS_EXACT_PI, d_half + d_centre) + MS_R(4.0) * MS_EXACT_EPS * (fabs(centre) + MS_EXACT_TWO_PI);
    return m;
}

/* `known` (known_count of them): meetings computed before for pairs of caps that stay fixed, taken
 * instead of computed where both caps match bit for bit. */
inline int exact_boundary_arcs(const exact_cap* caps, int count, int k, real3 e1, real3 e2, const exact_meeting* known,
                               int known_count, real* arc_lo, real* arc_hi, real* end_lo, real* end_hi)
{
    int arcs = 1;
    arc_lo[0] = MS_R(0.0);
    arc_hi[0] = MS_EXACT_TWO_PI;
    end_lo[0] = end_hi[0] = MS_R(0.0);
    int full = 1;
    for (int j = 0; j < count; ++j) {
        if (j == k) continue;
        int found = -1;
        for (int i = 0; i < known_count; ++i)
            if (found < 0 && exact_same_cap(known[i].circle, caps[k]) && exact_same_cap(known[i].cap, caps[j])) found = i;
        const exact_meeting meeting = found >= 0 ? known[found] : exact_meet(caps[k], caps[j], e1, e2);
        if (meeting.kind == MS_EXACT_MEETS_WHOLE) continue;
        if (meeting.kind == MS_EXACT_MEETS_NONE) return 0;
        const real allowed_lo = meeting.lo, allowed_hi = meeting.hi, d_end = meeting.end;
        if (full) {
            arc_lo[0] = allowed_lo;
            arc_hi[0] = allowed_hi;
            end_lo[0] = end_hi[0] = d_end;
            full = 0;
            continue;
        }
        real next_lo[MS_EXACT_MAX_ARCS], next_hi[MS_EXACT_MAX_ARCS], next_end_lo[MS_EXACT_MAX_ARCS], next_end_hi[MS_EXACT_MAX_ARCS];
        int next = 0;
        for (int i = 0; i < arcs; ++i)
            for (int shift = -1; shift <= 1; ++shift) {
                const real lo = fmax(arc_lo[i], allowed_lo + shift * MS_EXACT_TWO_PI);
                const real hi = fmin(arc_hi[i], allowed_hi + shift * MS_EXACT_TWO_PI);
                if (hi > lo && next < MS_EXACT_MAX_ARCS) {
                    next_lo[next] = lo;
                    next_hi[next] = hi;
                    /* an end is this cap's where this cap's bound it */
                    next_end_lo[next] = arc_lo[i] >= allowed_lo + shift * MS_EXACT_TWO_PI ? end_lo[i] : d_end;
                    next_end_hi[next] = arc_hi[i] <= allowed_hi + shift * MS_EXACT_TWO_PI ? end_hi[i] : d_end;
                    ++next;
                }
            }
        for (int i = 0; i < next; ++i) {
            arc_lo[i] = next_lo[i];
            arc_hi[i] = next_hi[i];
            end_lo[i] = next_end_lo[i];
            end_hi[i] = next_end_hi[i];
        }
        arcs = next;
        if (arcs == 0) return 0;
    }
    return arcs;
}

/* ---- the circle's quartic: poles and closed-form arcs --------------------------------------------- */

/* |v(psi)|^2 = k0 + k1 cos psi + k2 sin psi + k3 cos 2 psi + k4 sin 2 psi; with z = e^{i psi} it is
 * P4(z) / z^2, P4 = sum c[i] z^i, whose roots come in pairs z, 1 / conj(z) (P4 is self-reciprocal) and
 * never lie on |z| = 1 (|v|^2 > 0 there). */
typedef struct exact_quartic {
    ms_complex c[5];
    ms_complex z[4];
    int roots; /* 4; 2 when the z^4 and z^0 terms vanish; 0 when the z^3 and z^1 terms do too */
} exact_quartic;

inline exact_quartic exact_circle_quartic(real3 p, real3 q, real3 r)
{
    exact_quartic out;
    const real k0 = dot(p, p) + MS_R(0.5) * (dot(q, q) + dot(r, r));
    const real k1 = MS_R(2.0) * dot(p, q), k2 = MS_R(2.0) * dot(p, r);
    const real k3 = MS_R(0.5) * (dot(q, q) - dot(r, r)), k4 = dot(q, r);
    const ms_complex c4 = (ms_complex)(MS_R(0.5) * k3, MS_R(-0.5) * k4), c3 = (ms_complex)(MS_R(0.5) * k1, MS_R(-0.5) * k2);
    const ms_complex c2 = (ms_complex)(k0, MS_R(0.0)), c1 = (ms_complex)(MS_R(0.5) * k1, MS_R(0.5) * k2);
    const ms_complex c0 = (ms_complex)(MS_R(0.5) * k3, MS_R(0.5) * k4);
    out.c[0] = c0;
    out.c[1] = c1;
    out.c[2] = c2;
    out.c[3] = c3;
    out.c[4] = c4;
    out.roots = 0;
    const real negligible = MS_EXACT_NEGLIGIBLE * k0 * k0;
    if (cx_norm(c4) > negligible) {
        /* Durand-Kerner on the monic quartic from starts off the real axis. */
        const ms_complex inv4 = cx_conj(c4) / cx_norm(c4);
        const ms_complex a3 = cx_mul(c3, inv4), a2 = cx_mul(c2, inv4), a1 = cx_mul(c1, inv4), a0 = cx_mul(c0, inv4);
        const real radius = pow(hypot(a0.x, a0.y), MS_R(0.25));
        const ms_complex seed = (ms_complex)(MS_R(0.4), MS_R(0.9));
        ms_complex w = (ms_complex)(MS_R(1.0), MS_R(0.0));
        for (int i = 0; i < 4; ++i) {
            out.z[i] = radius * w;
            w = cx_mul(w, seed);
        }
        for (int iter = 0; iter < 200; ++iter) {
            real change = MS_R(0.0);
            for (int i = 0; i < 4; ++i) {
                const ms_complex x = out.z[i];
                const ms_complex value = cx_mul(cx_mul(cx_mul(x + a3, x) + a2, x) + a1, x) + a0;
                ms_complex denom = (ms_complex)(MS_R(1.0), MS_R(0.0));
                for (int j = 0; j < 4; ++j)
                    if (j != i) denom = cx_mul(denom, x - out.z[j]);
                const real dn = cx_norm(denom);
                const ms_complex step = dn > MS_R(0.0) ? cx_mul(value, cx_conj(denom)) / dn : (ms_complex)(MS_R(1e-3), MS_R(1e-3));
                out.z[i] -= step;
                change = fmax(change, cx_norm(step) / (MS_R(1.0) + cx_norm(out.z[i])));
            }
            if (change < MS_EXACT_ROOT_STOP) break;
        }
        out.roots = 4;
    } else if (cx_norm(c3) > negligible) {
        /* z (c3 z^2 + c2 z + c1): two roots (z = 0 and infinity are no poles). */
        const ms_complex disc = cx_sqrt(cx_mul(c2, c2) - MS_R(4.0) * cx_mul(c3, c1));
        const real aligned = c2.x * disc.x + c2.y * disc.y; /* Re(conj(c2) disc) */
        const ms_complex big = MS_R(-0.5) * (c2 + (aligned >= MS_R(0.0) ? disc : -disc));
        out.z[out.roots++] = cx_div(big, c3);
        if (big.x != MS_R(0.0) || big.y != MS_R(0.0)) out.z[out.roots++] = cx_div(c1, big);
    }
    return out;
}

/* The poles of 1 / |v(psi)|^2 in the upper half plane: each root inside the unit disc is one, at
 * psi = arg z + i (-ln |z|); returns their number (<= 4). */
inline int exact_poles(const exact_quartic* quartic, real* pole_re, real* pole_im)
{
    int poles = 0;
    for (int i = 0; i < quartic->roots; ++i) {
        const ms_complex z = quartic->z[i];
        const real m2 = cx_norm(z);
        if (!(m2 < MS_R(1.0)) || m2 == MS_R(0.0)) continue;
        const real im = MS_R(-0.5) * log(m2);
        if (im > MS_R(12.0)) continue; /* farther than any piece's ellipse reaches */
        pole_re[poles] = atan2(z.y, z.x);
        pole_im[poles] = im;
        ++poles;
    }
    return poles;
}

/* The closed form of an arc by partial fractions. With z = e^{i psi} and dpsi = dz / (i z), the arc
 * integrand (n1 + al1 cos psi + al2 sin psi) / |v|^2 dpsi is N(z) / (i P4(z)) dz with
 * N(z) = n2 z^2 + n1 z + n0, n2 = (al1 - i al2) / 2, n0 = (al1 + i al2) / 2 (deg N < deg P4). The
 * computed roots z_j are the exact roots of P~4 = c4 prod (z - z_j), over which partial fractions are
 * exact: N / (i P~4) = sum_j rho_j / (z - z_j), rho_j = N(z_j) / (i P~4'(z_j)). A primitive of
 * dz / (z - z_j) along the unit circle, continuous in psi (1 - w with |w| < 1 keeps the principal
 * Log off its cut), is
 *     i psi + Log(1 - z_j e^{-i psi})   for |z_j| < 1   (log(z - z_j) = log z + log(1 - z_j / z)),
 *     Log(1 - e^{i psi} / z_j)          for |z_j| > 1   (up to the constant log(-z_j)),
 * so the arc's integral is Re sum_j rho_j [L_j(hi) - L_j(lo)]. The outer roots are taken as the
 * reflections of the inner two, whose logarithms are then the conjugates of their partners'.
 *
 * What a circle's arcs share: the residues of the arc integrand (rho_f) and of 1 / |v|^2 (rho_one,
 * N = z), and the distance delta of P~4 from P4 on the unit circle. */
typedef struct exact_residues {
    ms_complex rho_f[4], rho_one[4]; /* at the roots inside the unit disc (0, 1), then at their reflections */
    ms_complex inner[2];
    real delta;
    int usable;
} exact_residues;

/* g bounds |N| / |v|^2 on the circle, |v|^2 lies in [min_norm2, max_norm2]. */
inline exact_residues exact_residues_make(const exact_quartic* quartic, real al0, real al1, real al2, real min_norm2,
                                          real max_norm2, real g, real parameter_size, real tolerance_per_radian)
{
    exact_residues out;
    out.usable = 0;
    out.delta = MS_R(0.0);
    if (quartic->roots != 4) return out; /* vanishing leading coefficients: quadrature instead */
    /* The roots come in pairs z, 1 / conj(z) (P4 is self-reciprocal), two inside the unit disc: the two
     * smallest computed roots are kept and the others taken as their reflections (P~4 below is the
     * polynomial of these values), so that exact_closed_form_arc takes each outer root's logarithms as
     * the conjugates of its partner's. */
    int first = 0, second = 1; /* the smallest and second smallest moduli */
    real norms[4];
    for (int j = 0; j < 4; ++j) norms[j] = cx_norm(quartic->z[j]);
    if (norms[1] < norms[0]) {
        first = 1;
        second = 0;
    }
    for (int j = 2; j < 4; ++j) {
        if (norms[j] < norms[first]) {
            second = first;
            first = j;
        } else if (norms[j] < norms[second]) {
            second = j;
        }
    }
    if (!(norms[second] < MS_R(1.0)) || !(norms[first] > MS_R(0.0))) return out; /* not two roots inside */
    const ms_complex z0 = quartic->z[first], z1 = quartic->z[second];
    const ms_complex z2 = z0 / norms[first], z3 = z1 / norms[second];
    const ms_complex c4 = quartic->c[4];
    /* P~4's coefficients c4 (e4, -e3, e2, -e1, 1) from the elementary symmetric functions. */
    const ms_complex z01 = cx_mul(z0, z1), z23 = cx_mul(z2, z3);
    const ms_complex e1 = z0 + z1 + z2 + z3;
    const ms_complex e2 = z01 + z23 + cx_mul(z0 + z1, z2 + z3);
    const ms_complex e3 = cx_mul(z01, z2 + z3) + cx_mul(z23, z0 + z1);
    const ms_complex e4 = cx_mul(z01, z23);
    real delta = length(cx_mul(c4, e4) - quartic->c[0]) + length(quartic->c[1] + cx_mul(c4, e3)) +
                 length(cx_mul(c4, e2) - quartic->c[2]) + length(quartic->c[3] + cx_mul(c4, e1));
    real coefficient_scale = MS_R(0.0);
    for (int i = 0; i < 5; ++i) coefficient_scale += length(quartic->c[i]);
    const real expansion_scale = length(c4) * (MS_R(1.0) + length(z0)) * (MS_R(1.0) + length(z1)) *
                                 (MS_R(1.0) + length(z2)) * (MS_R(1.0) + length(z3));
    /* The residual above is itself rounded: each e_k c4 to a few ulps of |c4| e_k(|z|) (the sum over k
     * of which is expansion_scale), and the coefficients c_i, dot products of p, q, r, to a few ulps of
     * the products they are made of (at most 2 k0 <= 2 sum |c_i|). */
    delta += MS_R(16.0) * MS_EXACT_EPS * (expansion_scale + coefficient_scale);
    out.delta = delta;
    /* P~4 within a quarter of min |v|^2 keeps |P~4| >= 3/4 min |v|^2 > 0 on the circle: else the roots
     * are too inaccurate (or did not converge) for the bound to say anything. */
    if (!(delta < MS_R(0.25) * min_norm2)) return out;
    /* The bound's root term alone (exact_closed_form_arc), g delta / (1 - delta / m) I with
     * I >= width / max_norm2, against the two levels an arc accepts: its share of the tolerance, and
     * the quadrature's rounding floor (|value| <= g I). Where it exceeds both by 2x on every arc, the
     * residues are not worth computing (float on smooth surfaces, whose quartic float cannot resolve). */
    const real root_term = delta / (MS_R(1.0) - delta / min_norm2) * g;
    if (root_term > MS_R(2.0) * fmax(tolerance_per_radian * max_norm2, (MS_R(1e3) * g + MS_R(8.0) * parameter_size) * MS_EXACT_EPS))
        return out;
    const ms_complex n2 = (ms_complex)(MS_R(0.5) * al1, MS_R(-0.5) * al2), n1 = (ms_complex)(al0, MS_R(0.0));
    const ms_complex n0 = (ms_complex)(MS_R(0.5) * al1, MS_R(0.5) * al2);
    const ms_complex z[4] = {z0, z1, z2, z3};
    int finite = 1;
    for (int j = 0; j < 4; ++j) {
        const ms_complex zj = z[j];
        ms_complex derivative = c4;
        for (int k = 0; k < 4; ++k)
            if (k != j) derivative = cx_mul(derivative, zj - z[k]);
        const real dn = cx_norm(derivative);
        finite &= dn > MS_R(0.0) && isfinite(dn); /* coincident roots have no simple residues */
        /* 1 / (i P~4'(z_j)) = -i conj(P~4') / |P~4'|^2 */
        const ms_complex inv_i_derivative = (ms_complex)(-derivative.y, -derivative.x) / dn;
        out.rho_f[j] = cx_mul(cx_mul(n2, zj) + n1, zj) + n0;
        out.rho_f[j] = cx_mul(out.rho_f[j], inv_i_derivative);
        out.rho_one[j] = cx_mul(zj, inv_i_derivative);
        if (j < 2) out.inner[j] = zj;
    }
    out.usable = finite;
    return out;
}

/* The integral over [lo, hi] of the arc integrand by the closed form, with a bound on its error;
 * returns 0 where the closed form does not apply. The bound, for the value computed from P~4 instead
 * of P4 and in working precision:
 *  - P~4: on |z| = 1, |f - f~| = |N| |P4 - P~4| / (|P4| |P~4|) <= (|N| / |v|^2) delta / (|v|^2 - delta)
 *    with |v|^2 >= min_norm2 = m, so integral |f - f~| <= g delta / (1 - delta / m) I with g a bound
 *    of |N| / |v|^2 (exact_boundary_integral) and I = integral 1 / |v|^2. I itself is the closed
 *    form of 1 / |v~|^2 within I delta / (m - delta) by the same argument, whence
 *    I <= (|I~| + its rounding) / (1 - delta / (m - delta));
 *  - rounding of the sum: each term rho_j L_j carries a few ulps of |rho_j| |L_j|, and Log(1 - w) an
 *    absolute ~ulp |w| / |1 - w| from forming 1 - w; the residues may cancel, so the bound sums moduli;
 *  - the integrand's inputs: |v|^2 from p, q, r to a few ulps, and the numerator's coefficients to a
 *    few ulps of the products they are made of (parameter_size; they cancel at grazing views), which
 *    moves the integral by those relative sizes times max |N| I and parameter_size I.
 * `floor` receives the least error the quadrature may report for the arc where rounding stops it. */
inline int exact_closed_form_arc(const exact_residues* res, real lo, real hi, real min_norm2, real g, real max_numerator,
                                 real parameter_size, real* value, real* error, real* floor)
{
    if (!res->usable) return 0;
    real c_lo, c_hi;
    const real s_lo = sincos(lo, &c_lo), s_hi = sincos(hi, &c_hi);
    ms_complex sum_f = (ms_complex)(MS_R(0.0), MS_R(0.0)), sum_one = sum_f;
    real rounding_f = MS_R(0.0), rounding_one = MS_R(0.0);
    const real width = hi - lo, ends_size = fabs(hi) + fabs(lo);
    /* For the inner root z, w = z e^{-i psi}; for its reflection z' = 1 / conj(z), w' = e^{i psi} / z' =
     * conj(w), so 1 - w' is the conjugate of 1 - w and so are the logarithms' differences (z' is the
     * reflection rounded: conj(w) stands for e^{i psi} / z' to a few ulps, as forming that quotient would,
     * which the 1 / |u| terms of the bound cover). */
    for (int j = 0; j < 2; ++j) {
        const ms_complex u_lo = (ms_complex)(MS_R(1.0), MS_R(0.0)) - cx_mul(res->inner[j], (ms_complex)(c_lo, -s_lo));
        const ms_complex u_hi = (ms_complex)(MS_R(1.0), MS_R(0.0)) - cx_mul(res->inner[j], (ms_complex)(c_hi, -s_hi));
        const real n_lo = cx_norm(u_lo), n_hi = cx_norm(u_hi);
        /* Log(u_hi) - Log(u_lo) as one logarithm and one atan2: Re u > 0 (|w| < 1) puts both arguments in
         * (-pi/2, pi/2), so their difference is the argument of u_hi conj(u_lo), with no branch to choose. */
        const ms_complex turn = cx_mul(u_hi, cx_conj(u_lo));
        const ms_complex log_difference = (ms_complex)(MS_R(0.5) * log(n_hi / n_lo), atan2(turn.y, turn.x));
        const ms_complex dl_inner = log_difference + (ms_complex)(MS_R(0.0), width), dl_outer = cx_conj(log_difference);
        sum_f += cx_mul(res->rho_f[j], dl_inner) + cx_mul(res->rho_f[j + 2], dl_outer);
        sum_one += cx_mul(res->rho_one[j], dl_inner) + cx_mul(res->rho_one[j + 2], dl_outer);
        /* The difference carries a few ulps of its own size, and of 1 from the quotient and the turn's
         * rounding; forming u an ulp of 1 / |u| at either end (the inner root's also the i psi term's). */
        const real log_size = fabs(log_difference.x) + fabs(log_difference.y) + MS_R(2.0) + rsqrt(n_lo) + rsqrt(n_hi);
        rounding_f += length(res->rho_f[j]) * (log_size + ends_size) + length(res->rho_f[j + 2]) * log_size;
        rounding_one += length(res->rho_one[j]) * (log_size + ends_size) + length(res->rho_one[j + 2]) * log_size;
    }
    rounding_f *= MS_R(32.0) * MS_EXACT_EPS;
    rounding_one *= MS_R(32.0) * MS_EXACT_EPS;
    const real delta = res->delta;
    const real ratio = delta / (min_norm2 - delta); /* < 1/3 */
    const real integral_one = (fabs(sum_one.x) + rounding_one) / (MS_R(1.0) - ratio);
    const real inputs = (MS_R(32.0) * max_numerator + MS_R(8.0) * parameter_size) * MS_EXACT_EPS * integral_one;
    *value = sum_f.x;
    *error = delta / (MS_R(1.0) - delta / min_norm2) * g * integral_one + rounding_f + inputs;
    /* The quadrature stops refining where a piece's two rules differ by less than 1e3 ulps of its
     * integral of |f| >= |value|, and adds 8 ulps of parameter_size over |v|^2 (exact_integrate_arc). */
    *floor = (MS_R(1e3) * fabs(sum_f.x) + MS_R(8.0) * parameter_size * integral_one) * MS_EXACT_EPS;
    return isfinite(*value) && isfinite(*error);
}

/* Whether a 2 pi translate of the pole lies inside the Bernstein ellipse E_rho of [lo, hi]
 * (|t - 1| + |t + 1| < rho + 1 / rho for the pole t mapped to [-1, 1]). */
inline int exact_pole_inside_ellipse(real lo, real hi, real re, real im, real rho)
{
    const real mid = MS_R(0.5) * (lo + hi), inv_half = MS_R(2.0) / (hi - lo);
    const real limit = rho + MS_R(1.0) / rho;
    const real shift = round((mid - re) / MS_EXACT_TWO_PI) * MS_EXACT_TWO_PI;
    const real y = im * inv_half, y2 = y * y;
    for (int k = -1; k <= 1; ++k) {
        const real x = (re + shift + k * MS_EXACT_TWO_PI - mid) * inv_half;
        if (sqrt((x - 1) * (x - 1) + y2) + sqrt((x + 1) * (x + 1) + y2) < limit) return 1;
    }
    return 0;
}

/* The real part of the nearest pole translate inside the piece's ellipse, if any. */
inline int exact_pole_near_piece(real lo, real hi, const real* pole_re, const real* pole_im, int poles, real rho,
                                 real* real_part)
{
    int found = 0;
    real best = INFINITY;
    const real mid = MS_R(0.5) * (lo + hi);
    for (int i = 0; i < poles; ++i) {
        if (!exact_pole_inside_ellipse(lo, hi, pole_re[i], pole_im[i], rho)) continue;
        const real x = pole_re[i] + round((mid - pole_re[i]) / MS_EXACT_TWO_PI) * MS_EXACT_TWO_PI;
        const real distance = fabs(x - mid) + pole_im[i];
        if (distance < best) {
            best = distance;
            *real_part = x;
            found = 1;
        }
    }
    return found;
}

/* ---- the arc integrand and its pieces ------------------------------------------------------------- */

/* |v(psi)|^2 for v = p + q cos psi + r sin psi. */
inline real exact_norm2_at(real3 p, real3 q, real3 r, real psi)
{
    real c;
    const real s = sincos(psi, &c);
    const real3 v = p + q * c + r * s;
    return dot(v, v);
}

/* v = p + q cos psi + r sin psi; the integrand (k + bc cos psi - bs sin psi) / |v|^2. */
typedef struct exact_arc {
    real3 p, q, r;
    real k, bc, bs;
    real parameter_size; /* |q||r| + |p||r| + |p||q|: what k, bc, bs are rounded relative to */
} exact_arc;

inline real exact_arc_integrand(const exact_arc* f, real psi)
{
    real c;
    const real s = sincos(psi, &c);
    const real3 v = f->p + f->q * c + f->r * s;
    return (f->k + f->bc * c - f->bs * s) / dot(v, v);
}

typedef struct exact_sum {
    real value, error;
    uint pieces, flags;
} exact_sum;

/* The rule's offsets into the Gauss-Legendre buffer. */
typedef struct exact_rules {
    int arc_high, arc_low, arc_high_at, arc_low_at;
    int azimuth_high, azimuth_low, azimuth_high_at, azimuth_low_at;
    real rho;
} exact_rules;

/* One arc [arc_lo, arc_hi]: pole-aware, then tolerance-driven subdivision, depth first, left first. */
inline void exact_integrate_arc(const exact_arc* f, const real* pole_re, const real* pole_im, int poles, real arc_lo,
                                real arc_hi, const exact_rules* rule, __global const real* gauss,
                                real tolerance_per_radian, exact_sum* out)
{
    real stack_hi[MS_EXACT_ARC_STACK];
    int stack_depth[MS_EXACT_ARC_STACK];
    int top = 1;
    stack_hi[0] = arc_hi;
    stack_depth[0] = 0;
    real lo = arc_lo;
    while (top > 0) {
        const real hi = stack_hi[top - 1];
        const int depth = stack_depth[top - 1];
        const real half_width = MS_R(0.5) * (hi - lo), mid = MS_R(0.5) * (hi + lo);
        int stack_full = 0;
        real pole_x = MS_R(0.0);
        if (depth < MS_EXACT_POLE_DEPTH && exact_pole_near_piece(lo, hi, pole_re, pole_im, poles, rule->rho, &pole_x)) {
            if (top < MS_EXACT_ARC_STACK) {
                /* At the pole's real part when well inside, else graded towards it by 1 : 1.7. */
                real split;
                const real margin = MS_R(0.25) * (hi - lo);
                if (pole_x > lo + margin && pole_x < hi - margin) split = pole_x;
                else if (pole_x <= lo + margin) split = lo + (hi - lo) / MS_R(2.7);
                else split = hi - (hi - lo) / MS_R(2.7);
                stack_depth[top - 1] = depth + 1; /* [split, hi] stays below [lo, split] */
                stack_hi[top] = split;
                stack_depth[top] = depth + 1;
                ++top;
                continue;
            }
            stack_full = 1;
        }
        real qh = MS_R(0.0), ql = MS_R(0.0), magnitude = MS_R(0.0), sensitivity = MS_R(0.0);
        for (int i = 0; i < rule->arc_high; ++i) {
            const real w = gauss[rule->arc_high_at + rule->arc_high + i];
            const real psi = mid + half_width * gauss[rule->arc_high_at + i];
            const real fx = exact_arc_integrand(f, psi);
            qh += w * fx;
            magnitude += w * fabs(fx);
            /* The integrand's rounding from its parameters: k, bc, bs are rounded relative to the
             * products they are made of (parameter_size), not to |k + bc cos - bs sin|, which cancels
             * where the boundary runs nearly along the view's direction (grazing views). */
            const real norm2 = exact_norm2_at(f->p, f->q, f->r, psi);
            sensitivity += w * f->parameter_size / norm2;
        }
        for (int i = 0; i < rule->arc_low; ++i)
            ql += gauss[rule->arc_low_at + rule->arc_low + i] * exact_arc_integrand(f, mid + half_width * gauss[rule->arc_low_at + i]);
        qh *= half_width;
        ql *= half_width;
        /* The difference is the low rule's error: a conservative estimate for the high rule's value. */
        const real difference = fabs(qh - ql);
        /* Below ~1e3 ulps of the piece's magnitude the difference is rounding, not truncation. */
        const real rounding_floor = MS_R(1e3) * MS_EXACT_EPS * half_width * magnitude;
        /* As the C++ evaluator: at most 4096 pieces on one circle. */
        if (!stack_full && difference > tolerance_per_radian * (hi - lo) && difference > rounding_floor &&
            depth < MS_EXACT_ERROR_DEPTH && out->pieces < 4096u) {
            if (top < MS_EXACT_ARC_STACK) {
                stack_depth[top - 1] = depth + 1;
                stack_hi[top] = mid;
                stack_depth[top] = depth + 1;
                ++top;
                continue;
            }
            stack_full = 1;
        }
        out->value += qh;
        out->error += difference + MS_R(64.0) * MS_EXACT_EPS * half_width * magnitude +
                      MS_R(8.0) * MS_EXACT_EPS * half_width * sensitivity;
        out->pieces += 1;
        if (stack_full) {
            out->error += half_width * magnitude;
            out->flags |= MS_EXACT_FLAG_STACK_FULL;
        }
        lo = hi;
        --top;
    }
}

/* The angle v sweeps round `axis` over [lo, hi] on a great circle, through pieces shorter than pi. */
inline real exact_swept_angle(real3 q, real3 r, real3 axis, real lo, real hi)
{
    if (hi - lo >= MS_EXACT_TWO_PI * (MS_R(1.0) - MS_EXACT_EPS * MS_R(4.5))) return MS_EXACT_TWO_PI;
    const int pieces = (int)ceil((hi - lo) / (MS_R(0.75) * MS_EXACT_PI));
    real total = MS_R(0.0);
    real c0;
    real s0 = sincos(lo, &c0);
    real3 v0 = q * c0 + r * s0;
    for (int i = 1; i <= pieces; ++i) {
        const real psi1 = i == pieces ? hi : lo + (hi - lo) * i / pieces;
        real c;
        const real s = sincos(psi1, &c);
        const real3 v1 = q * c + r * s;
        total += atan2(dot(cross(v0, v1), axis), dot(v0, v1));
        v0 = v1;
    }
    return total;
}

/* ---- the boundary integral of a region ------------------------------------------------------------ */

/* v = S^-1 m = p + q cos psi + r sin psi on the circle of `cap` (basis e1, e2): m / (ax, ay, 1)
 * componentwise, as the host divides. */
inline void exact_circle_parametrisation(exact_cap cap, real3 e1, real3 e2, real ax, real ay, real3* p, real3* q, real3* r)
{
    *p = (real3)(cap.n.x / ax, cap.n.y / ay, cap.n.z) * cap.c;
    *q = (real3)(e1.x / ax, e1.y / ay, e1.z) * cap.s;
    *r = (real3)(e2.x / ax, e2.y / ay, e2.z) * cap.s;
}

/* What every term of a texel's azimuth mean shares. The light stays fixed while the view turns (an
 * isotropic surface is invariant under rotation about e_z), so the cone's caps round e_z and round the
 * light are the same for every term: the circle round the light keeps its quartic (only the numerator
 * a.(v x dv) changes with the view, and the residues are formed per term from the shared roots), and the
 * two circles meet each other's caps the same way. exact_boundary_integral takes them for the caps
 * equal to these (bit for bit: the same parametrisation and the same meetings). */
typedef struct exact_fixed_cone {
    exact_cap light_cap;
    exact_quartic light_quartic;
    exact_meeting meetings[2]; /* round e_z in the light's cap, round the light in e_z's */
} exact_fixed_cone;

inline exact_fixed_cone exact_fixed_cone_make(real alpha, exact_cap z_cap, exact_cap light_cap)
{
    exact_fixed_cone fixed;
    fixed.light_cap = light_cap;
    real3 e1, e2, p, q, r;
    exact_basis(light_cap.n, &e1, &e2);
    exact_circle_parametrisation(light_cap, e1, e2, alpha, alpha, &p, &q, &r);
    fixed.light_quartic = exact_circle_quartic(p, q, r);
    fixed.meetings[1] = exact_meet(light_cap, z_cap, e1, e2);
    exact_basis(z_cap.n, &e1, &e2);
    fixed.meetings[0] = exact_meet(z_cap, light_cap, e1, e2);
    return fixed;
}

typedef struct exact_surface {
    real ax, ay;
    real3 a; /* normalize(ax wi.x, ay wi.y, wi.z) */
} exact_surface;

inline exact_surface exact_surface_make(real ax, real ay, real3 wi)
{
    exact_surface m;
    m.ax = ax;
    m.ay = ay;
    const real3 a = (real3)(ax * wi.x, ay * wi.y, wi.z);
    m.a = a * (MS_R(1.0) / sqrt(dot(a, a)));
    return m;
}

/* The closed integral of a.(v x dv) / |v|^2 over the boundary of the intersection of `count` (<= 3)
 * caps; `absolute_tolerance` applies to the value. `fixed` (or 0): what a texel's terms share. */
inline exact_sum exact_boundary_integral(const exact_surface* surface, exact_cap* caps, int count,
                                         const exact_rules* rule, __global const real* gauss, real absolute_tolerance,
                                         const exact_fixed_cone* fixed)
{
    /* Coincident caps (wo = e_z, wo = wi, wi = e_z) would exclude each other's circle: keep one. */
    for (int i = 0; i < count; ++i)
        for (int j = count - 1; j > i; --j) {
            const real3 dn = caps[i].n - caps[j].n;
            if (dot(dn, dn) < MS_EXACT_SAME_AXIS && fabs(caps[i].c - caps[j].c) < MS_EXACT_SAME_COS) {
                for (int m = j; m + 1 < count; ++m) caps[m] = caps[m + 1];
                --count;
            }
        }
    const real ax = surface->ax, ay = surface->ay;
    const real3 a = surface->a;
    exact_sum result = {MS_R(0.0), MS_R(0.0), 0u, 0u};
    real rounding = MS_R(0.0), ends = MS_R(0.0);
    const real tolerance_per_radian = absolute_tolerance / (MS_EXACT_TWO_PI * count);
    /* |v|^2 = |S^-1 m|^2 >= min(1, 1 / ax^2, 1 / ay^2) for unit m; the factor covers m's rounding. */
    const real min_norm2 = (MS_R(1.0) - MS_R(8.0) * MS_EXACT_EPS) * fmin(MS_R(1.0), fmin(MS_R(1.0) / (ax * ax), MS_R(1.0) / (ay * ay)));
    for (int k = 0; k < count; ++k) {
        real3 e1, e2;
        exact_basis(caps[k].n, &e1, &e2);
        real arc_lo[MS_EXACT_MAX_ARCS], arc_hi[MS_EXACT_MAX_ARCS], end_lo[MS_EXACT_MAX_ARCS], end_hi[MS_EXACT_MAX_ARCS];
        const int arcs = exact_boundary_arcs(caps, count, k, e1, e2, fixed ? fixed->meetings : 0, fixed ? 2 : 0, arc_lo, arc_hi,
                                             end_lo, end_hi);
        if (arcs == 0) continue;
        const exact_cap cap = caps[k];
        real3 p, q, r;
        exact_circle_parametrisation(cap, e1, e2, ax, ay, &p, &q, &r);
        if (cap.c == MS_R(0.0)) {
            /* A great circle: v stays in the plane normal to S n, the integral is a.n^ times the angle. */
            const real3 sn = (real3)(ax * cap.n.x, ay * cap.n.y, cap.n.z);
            const real3 axis = sn * (MS_R(1.0) / sqrt(dot(sn, sn)));
            const real weight = dot(a, axis);
            const real sweep_rate = fabs(weight * dot(cross(q, r), axis)); /* over |v|^2: d angle / d psi */
            for (int i = 0; i < arcs; ++i) {
                const real part = weight * exact_swept_angle(q, r, axis, arc_lo[i], arc_hi[i]);
                result.value += part;
                rounding += fabs(part);
                ends += sweep_rate * (end_lo[i] / exact_norm2_at(p, q, r, arc_lo[i]) + end_hi[i] / exact_norm2_at(p, q, r, arc_hi[i]));
            }
            continue;
        }
        const real k_const = dot(a, cross(q, r)), bc = dot(a, cross(p, r)), bs = dot(a, cross(p, q));
        if (ax == ay && cap.n.x == MS_R(0.0) && cap.n.y == MS_R(0.0)) {
            /* Round e_z on an isotropic surface |v|^2 is constant: integrate the numerator. */
            const real norm2 = dot(p, p) + dot(q, q);
            for (int i = 0; i < arcs; ++i) {
                const real part = (k_const * (arc_hi[i] - arc_lo[i]) + bc * (sin(arc_hi[i]) - sin(arc_lo[i])) +
                                   bs * (cos(arc_hi[i]) - cos(arc_lo[i]))) /
                                  norm2;
                result.value += part;
                rounding += fabs(k_const * (arc_hi[i] - arc_lo[i]) / norm2) + (fabs(bc) + fabs(bs)) * MS_R(2.0) / norm2;
                ends += (fabs(k_const) + fabs(bc) + fabs(bs)) * (end_lo[i] + end_hi[i]) / norm2;
            }
            continue;
        }
        exact_arc f;
        f.p = p;
        f.q = q;
        f.r = r;
        f.k = k_const;
        f.bc = bc;
        f.bs = bs;
        {
            const real lp = length(p), lq = length(q), lr = length(r);
            f.parameter_size = lq * lr + lp * lr + lp * lq;
        }
        const exact_quartic quartic =
            fixed && exact_same_cap(fixed->light_cap, cap) ? fixed->light_quartic : exact_circle_quartic(p, q, r);
        exact_sum sum = {MS_R(0.0), MS_R(0.0), 0u, 0u};
#if MS_EXACT_CLOSED_FORM
        /* |N| <= |k| + hypot(bc, bs) = max_numerator; |v'| = |r cos psi - q sin psi| <= sqrt(|q|^2 + |r|^2)
         * = speed_bound, and |v| <= |p| + speed_bound. Two bounds g of |N| / |v|^2 on the circle:
         * max_numerator / m, and |v'| / |v| <= speed_bound / sqrt(m) from N = a.(v x v') with |a| = 1, the
         * far tighter one on smooth surfaces. */
        const real max_numerator = fabs(k_const) + hypot(bc, bs), speed_bound = sqrt(dot(q, q) + dot(r, r));
        const real max_norm = length(p) + speed_bound;
        const real g = fmin(max_numerator / min_norm2, speed_bound / sqrt(min_norm2));
        const exact_residues residues = exact_residues_make(&quartic, k_const, bc, -bs, min_norm2, max_norm * max_norm, g,
                                                            f.parameter_size, tolerance_per_radian);
#endif
        real pole_re[4], pole_im[4];
        int poles = -1; /* found on the first arc that needs quadrature */
        for (int i = 0; i < arcs; ++i) {
            ends += fabs(exact_arc_integrand(&f, arc_lo[i])) * end_lo[i] + fabs(exact_arc_integrand(&f, arc_hi[i])) * end_hi[i];
#if MS_EXACT_CLOSED_FORM
            /* The closed form where its bound meets the arc's share of the tolerance, or where it is no
             * worse than the quadrature's own rounding could be (float, whose rounding, not the
             * tolerance, limits either method); quadrature elsewhere. */
            real closed_value, closed_error, closed_floor;
            if (exact_closed_form_arc(&residues, arc_lo[i], arc_hi[i], min_norm2, g, max_numerator, f.parameter_size,
                                      &closed_value, &closed_error, &closed_floor) &&
                closed_error <= fmax(tolerance_per_radian * (arc_hi[i] - arc_lo[i]), closed_floor)) {
                sum.value += closed_value;
                sum.error += closed_error;
                continue;
            }
#endif
            if (poles < 0) poles = exact_poles(&quartic, pole_re, pole_im);
            exact_integrate_arc(&f, pole_re, pole_im, poles, arc_lo[i], arc_hi[i], rule, gauss, tolerance_per_radian, &sum);
        }
        result.value += sum.value;
        result.error += sum.error;
        result.pieces += sum.pieces;
        result.flags |= sum.flags;
    }
    /* An end moved by its rounding moves the integral by the integrand there times the shift. */
    result.error += MS_R(32.0) * MS_EXACT_EPS * rounding + ends;
    return result;
}

/* The boundary integral of the intersection of three hemispheres {m.n_k > 0} (unit normals), the
 * normalisation of P(cone). In double it comes from the great circles' meeting points, as the host's
 * hemisphere_integral does (no arc angles, three atan2 in all): on great circle k the part inside
 * hemisphere j is the half circle from -u_kj to u_kj counter-clockwise round n_k, u_kj =
 * normalize(n_k x n_j); two such half circles of one circle meet from -u_kl to u_kj when -u_kl lies in
 * the first ((-u_kl).n_j >= 0), else from -u_kj to u_kl; the arc's integral is (a.n^) times the angle
 * v = S^-1 m sweeps round n^ = normalize(S n_k), at most pi. In float, and for nearly coincident or
 * opposite normals, the general boundary integral (its arc ends carry their rounding bounds). */
inline exact_sum exact_hemisphere_integral(const exact_surface* surface, real3 n1, real3 n2, real3 n3, const exact_rules* rule,
                                           __global const real* gauss)
{
#if MS_REAL_IS_DOUBLE
    const real3 n[3] = {n1, n2, n3};
    real3 u[3][3];
    int separated = 1;
    for (int k = 0; k < 3; ++k)
        for (int j = k + 1; j < 3; ++j) {
            const real3 dn = n[j] - n[k];
            const real3 w = cross(n[k], dn); /* n_k x (n_j - n_k): no cancellation when the axes are close */
            const real w2 = dot(w, w);
            separated &= w2 > 1e-60 && dot(dn, dn) >= 1e-28;
            u[k][j] = w * (MS_R(1.0) / sqrt(w2));
            u[j][k] = -u[k][j];
        }
    if (separated) {
        const real ax = surface->ax, ay = surface->ay;
        exact_sum result = {MS_R(0.0), MS_R(0.0), 0u, 0u};
        real magnitude = MS_R(0.0);
        for (int k = 0; k < 3; ++k) {
            const int j = (k + 1) % 3, l = (k + 2) % 3;
            const int later_start = -dot(u[k][l], n[j]) >= MS_R(0.0);
            const real3 start = later_start ? -u[k][l] : -u[k][j];
            const real3 end = later_start ? u[k][j] : u[k][l];
            const real3 sn = (real3)(ax * n[k].x, ay * n[k].y, n[k].z);
            const real3 axis = sn * (MS_R(1.0) / sqrt(dot(sn, sn)));
            const real3 vs = (real3)(start.x / ax, start.y / ay, start.z), ve = (real3)(end.x / ax, end.y / ay, end.z);
            /* In [0, pi] for an arc of at most half a turn: a cross product rounded below 0 is 0. */
            const real swept = atan2(fmax(MS_R(0.0), dot(cross(vs, ve), axis)), dot(vs, ve));
            const real part = dot(surface->a, axis) * swept;
            result.value += part;
            magnitude += fabs(part);
        }
        result.error = MS_R(32.0) * MS_EXACT_EPS * magnitude;
        return result;
    }
#endif
    exact_cap caps[3];
    caps[0] = exact_cap_make(n1, MS_R(0.0), MS_R(1.0));
    caps[1] = exact_cap_make(n2, MS_R(0.0), MS_R(1.0));
    caps[2] = exact_cap_make(n3, MS_R(0.0), MS_R(1.0));
    return exact_boundary_integral(surface, caps, 3, rule, gauss, MS_R(0.0), 0);
}

/* ---- the term ------------------------------------------------------------------------------------- */

/* T for unit wi above the horizon and unit wo, the cone given by its cosine c and squared sine s2. */
inline exact_sum exact_term_of(real ax, real ay, real3 wi, real3 wo, real c, real s2, real tolerance,
                               const exact_rules* rule, __global const real* gauss, const exact_fixed_cone* fixed)
{
    exact_sum out = {MS_R(0.0), MS_R(0.0), 0u, 0u};
    if (!(wo.z > MS_R(0.0))) return out; /* light at or below the horizon: G1(wo) = 0 */
    if (c <= MS_R(0.0)) {                /* visibility 1: the cone is the hemisphere */
        out.value = MS_R(1.0);
        return out;
    }
    /* The provable zero region NdotL <= cos(2 theta) = 1 - 2 sin^2 (host/core/cone.hpp). */
    if (wo.z <= MS_R(1.0) - MS_R(2.0) * s2) return out;
    const exact_surface surface = exact_surface_make(ax, ay, wi);
    const real3 ez = (real3)(MS_R(0.0), MS_R(0.0), MS_R(1.0));
    const exact_sum hemisphere = exact_hemisphere_integral(&surface, ez, wo, wi, rule, gauss);
    if (!(hemisphere.value > MS_R(0.0))) {
        /* wi and wo above the horizon give the hemisphere a positive probability: rounding lost it
         * (float, views within ~1e-6 of the horizon), and nothing is known of the ratio. */
        out.error = MS_R(1.0);
        out.flags = MS_EXACT_FLAG_UNRESOLVED;
        return out;
    }
    const real s = sqrt(s2);
    exact_cap caps[3];
    caps[0] = exact_cap_make(ez, c, s);
    caps[1] = exact_cap_make(wo, c, s);
    caps[2] = exact_cap_make(wi, MS_R(0.0), MS_R(1.0));
    const exact_sum cone = exact_boundary_integral(&surface, caps, 3, rule, gauss, tolerance * hemisphere.value, fixed);
    const real t = cone.value / hemisphere.value;
    out.value = clamp(t, MS_R(0.0), MS_R(1.0));
    out.error = (cone.error + fabs(t) * hemisphere.error) / hemisphere.value;
    out.pieces = cone.pieces + hemisphere.pieces;
    out.flags = cone.flags | hemisphere.flags;
    return out;
}

inline exact_rules exact_rules_of(const ms_exact_rule rule)
{
    exact_rules r;
    r.arc_high = rule.arc_high;
    r.arc_low = rule.arc_low;
    r.arc_high_at = rule.arc_high_at;
    r.arc_low_at = rule.arc_low_at;
    r.azimuth_high = rule.azimuth_high;
    r.azimuth_low = rule.azimuth_low;
    r.azimuth_high_at = rule.azimuth_high_at;
    r.azimuth_low_at = rule.azimuth_low_at;
    r.rho = rule.arc_rho;
    return r;
}

inline void exact_store(__global ms_exact_value* out, exact_sum v)
{
    ms_exact_value o;
    o.term_hi = (float)v.value;
    o.term_lo = (float)(v.value - (real)o.term_hi);
    o.error_hi = (float)v.error;
    o.error_lo = (float)(v.error - (real)o.error_hi);
    o.quadrature_pieces = v.pieces;
    o.flags = v.flags;
    o.pad1 = 0u;
    o.pad2 = 0u;
    *out = o;
}

__kernel void ms_exact_term(__global const ms_exact_query* queries, uint count, const ms_exact_rule rule,
                            __global const real* gauss, __global ms_exact_value* out)
{
    const uint g = get_global_id(0);
    if (g >= count) return;
    const ms_exact_query q = queries[g];
    const exact_rules rules = exact_rules_of(rule);
    const real3 wi = (real3)(ms_exact_join(q.wi_x_hi, q.wi_x_lo), ms_exact_join(q.wi_y_hi, q.wi_y_lo),
                             ms_exact_join(q.wi_z_hi, q.wi_z_lo));
    const real3 wo = (real3)(ms_exact_join(q.wo_x_hi, q.wo_x_lo), ms_exact_join(q.wo_y_hi, q.wo_y_lo),
                             ms_exact_join(q.wo_z_hi, q.wo_z_lo));
    const exact_sum v = exact_term_of(ms_exact_join(q.alpha_x_hi, q.alpha_x_lo), ms_exact_join(q.alpha_y_hi, q.alpha_y_lo),
                                      wi, wo,
                                      ms_exact_cone_cos(ms_exact_join(q.cos_theta_hi, q.cos_theta_lo),
                                                        ms_exact_join(q.sin2_cone_hi, q.sin2_cone_lo)),
                                      ms_exact_join(q.sin2_cone_hi, q.sin2_cone_lo),
                                      ms_exact_join(rule.tolerance_hi, rule.tolerance_lo), &rules, gauss, 0);
    exact_store(out + g, v);
}

/* ---- the azimuth mean ----------------------------------------------------------------------------- */

/* Solutions in (0, pi) of x cos phi + y sin phi = k (the term is even in phi), and the real part of a
 * nearly-real complex pair (|Im phi| < 0.5) that still steers the splitting. */
inline void exact_add_azimuths(real x, real y, real k, real* points, int* count)
{
    const real r = hypot(x, y);
    if (r == MS_R(0.0)) return;
    const real centre = atan2(y, x);
    const real ratio = k / r;
    real found[2];
    int n = 0;
    if (fabs(ratio) <= MS_R(1.0)) {
        const real w = acos(ratio);
        found[n++] = centre - w;
        found[n++] = centre + w;
    } else if (acosh(fabs(ratio)) < MS_R(0.5)) {
        found[n++] = ratio > MS_R(0.0) ? centre : centre + MS_EXACT_PI;
    }
    for (int i = 0; i < n; ++i) {
        const real phi = fabs(remainder(found[i], MS_EXACT_TWO_PI));
        if (phi > MS_EXACT_SAME_AZIMUTH && phi < MS_EXACT_PI - MS_EXACT_SAME_AZIMUTH && *count < MS_EXACT_MAX_BREAKPOINTS)
            points[(*count)++] = phi;
    }
}

/* The azimuths in [0, pi] where the term is not analytic, sorted and deduplicated; returns the count. */
inline int exact_azimuth_breakpoints(real c, real s, real s2, real n_dot_v, real n_dot_l, real* points)
{
    int count = 2;
    points[0] = MS_R(0.0);
    points[1] = MS_EXACT_PI;
    const real sv = sqrt(fmax(MS_R(0.0), MS_R(1.0) - n_dot_v * n_dot_v));
    const real sl = sqrt(fmax(MS_R(0.0), MS_R(1.0) - n_dot_l * n_dot_l));
    if (sv == MS_R(0.0) || sl == MS_R(0.0)) return count;
    /* The cap round wo touches the great circle normal to wi: wi.wo = +-s. */
    exact_add_azimuths(sv * sl, MS_R(0.0), -s - n_dot_v * n_dot_l, points, &count);
    exact_add_azimuths(sv * sl, MS_R(0.0), s - n_dot_v * n_dot_l, points, &count);
    /* The circle round wo passes through a meeting point (x, +-y, c) of the circle round e_z and the
     * great circle normal to wi. */
    const real x = -c * n_dot_v / sv;
    const real y2 = s2 - x * x;
    if (y2 > MS_R(0.0)) {
        const real y = sqrt(y2);
        exact_add_azimuths(x, -y, c * (MS_R(1.0) - n_dot_l) / sl, points, &count);
        exact_add_azimuths(x, y, c * (MS_R(1.0) - n_dot_l) / sl, points, &count);
    }
    for (int i = 1; i < count; ++i) /* insertion sort */
        for (int j = i; j > 0 && points[j - 1] > points[j]; --j) {
            const real t = points[j];
            points[j] = points[j - 1];
            points[j - 1] = t;
        }
    int kept = 1; /* std::unique: each point against the last one kept */
    for (int i = 1; i < count; ++i)
        if (!(points[i] - points[kept - 1] < MS_EXACT_SAME_AZIMUTH)) points[kept++] = points[i];
    return kept;
}

/* The view at relative azimuth phi with the light held at azimuth 0: turned by -phi about e_z. */
inline real3 exact_turned_view(real n_dot_v, real phi)
{
    const real sv = sqrt(fmax(MS_R(0.0), MS_R(1.0) - n_dot_v * n_dot_v));
    real c;
    const real s = sincos(phi, &c);
    return (real3)(sv * c, -sv * s, n_dot_v);
}

/* The azimuth pieces' Gauss-Kronrod pair over [lo, hi] in the substitution phi = mid - half_width cos u,
 * u in [0, pi]: both sums from one evaluation of T at each of the 2n + 1 nodes (the high rule's weights
 * are the Kronrod weights, the low rule's the Gauss weights on the same nodes). */
inline real exact_azimuth_pair(real mid, real half_width, real alpha, real n_dot_v, const exact_fixed_cone* fixed,
                               real c, real s2, real value_tolerance, const exact_rules* rule, __global const real* gauss,
                               real* gauss_sum, real* value_error, uint* flags)
{
    const int n = rule->azimuth_high, kronrod_at = rule->azimuth_high_at, gauss_at = rule->azimuth_low_at;
    real sum = MS_R(0.0), low = MS_R(0.0);
    for (int i = 0; i < n; ++i) {
        const real u = MS_R(0.5) * MS_EXACT_PI * (MS_R(1.0) + gauss[kronrod_at + i]);
        real cu;
        const real su = sincos(u, &cu);
        const real jacobian = half_width * su * MS_R(0.5) * MS_EXACT_PI;
        const exact_sum v =
            exact_term_of(alpha, alpha, exact_turned_view(n_dot_v, mid - half_width * cu), fixed->light_cap.n, c, s2,
                          value_tolerance, rule, gauss, fixed);
        const real wk = gauss[kronrod_at + n + i] * jacobian;
        sum += wk * v.value;
        low += gauss[gauss_at + n + i] * jacobian * v.value;
        *value_error += wk * v.error;
        *flags |= v.flags;
    }
    *gauss_sum = low;
    return sum;
}

__kernel void ms_exact_azimuth_mean(__global const ms_exact_texel* texels, uint count, const ms_exact_rule rule,
                                    __global const real* gauss, __global ms_exact_value* out)
{
    const uint g = get_global_id(0);
    if (g >= count) return;
    const ms_exact_texel t = texels[g];
    const exact_rules rules = exact_rules_of(rule);
    const real s2 = ms_exact_join(t.sin2_cone_hi, t.sin2_cone_lo);
    const real c = ms_exact_cone_cos(ms_exact_join(t.cos_theta_hi, t.cos_theta_lo), s2);
    const real alpha = ms_exact_join(t.alpha_hi, t.alpha_lo);
    const real n_dot_v = ms_exact_join(t.n_dot_v_hi, t.n_dot_v_lo), n_dot_l = ms_exact_join(t.n_dot_l_hi, t.n_dot_l_lo);
    const real tolerance = ms_exact_join(rule.tolerance_hi, rule.tolerance_lo);
    exact_sum result = {MS_R(0.0), MS_R(0.0), 0u, 0u};
    if (!(n_dot_l > MS_R(0.0)) || s2 <= MS_R(0.0)) { /* light below the horizon, or visibility 0 */
        exact_store(out + g, result);
        return;
    }
    if (c <= MS_R(0.0)) { /* visibility 1 */
        result.value = MS_R(1.0);
        exact_store(out + g, result);
        return;
    }
    if (n_dot_l <= MS_R(1.0) - MS_R(2.0) * s2) {
        exact_store(out + g, result);
        return;
    }
    /* Each value's tolerance is a quarter of the mean's; the azimuth quadrature takes half. */
    const real value_tolerance = MS_R(0.25) * tolerance;
    const real sv2 = MS_R(1.0) - n_dot_v * n_dot_v, sl2 = MS_R(1.0) - n_dot_l * n_dot_l;
    /* The light at azimuth 0 for every term; the view turns (exact_turned_view). */
    const real3 light = (real3)(sqrt(fmax(MS_R(0.0), sl2)), MS_R(0.0), n_dot_l);
    if (sv2 <= MS_R(0.0) || sl2 <= MS_R(0.0)) { /* the azimuth does not change the term */
        exact_store(out + g, exact_term_of(alpha, alpha, exact_turned_view(n_dot_v, MS_R(0.0)), light, c, s2, value_tolerance,
                                           &rules, gauss, 0));
        return;
    }
    const real s = sqrt(s2);
    const exact_fixed_cone fixed =
        exact_fixed_cone_make(alpha, exact_cap_make((real3)(MS_R(0.0), MS_R(0.0), MS_R(1.0)), c, s), exact_cap_make(light, c, s));
    real points[MS_EXACT_MAX_BREAKPOINTS];
    const int count_points = exact_azimuth_breakpoints(c, s, s2, n_dot_v, n_dot_l, points);
    real integral = MS_R(0.0);
    for (int piece = 0; piece + 1 < count_points; ++piece) {
        real stack_hi[MS_EXACT_AZIMUTH_STACK];
        int stack_depth[MS_EXACT_AZIMUTH_STACK];
        int top = 1;
        stack_hi[0] = points[piece + 1];
        stack_depth[0] = 0;
        real lo = points[piece];
        while (top > 0) {
            const real hi = stack_hi[top - 1];
            const int depth = stack_depth[top - 1];
            const real mid = MS_R(0.5) * (lo + hi), half_width = MS_R(0.5) * (hi - lo);
            real error_high = MS_R(0.0), low = MS_R(0.0);
            const real high = exact_azimuth_pair(mid, half_width, alpha, n_dot_v, &fixed, c, s2, value_tolerance, &rules,
                                                 gauss, &low, &error_high, &result.flags);
            const real estimate = fabs(high - low);
            /* A difference at the level of the values' own errors or of rounding cannot be split away (both
             * sums' value errors: the Gauss weights are at most 2.05x the Kronrod weights at their nodes). */
            const real floor_level = MS_R(3.0) * error_high + MS_R(1e3) * MS_EXACT_EPS * (hi - lo);
            /* As the C++ evaluator: pieces of at least 1e-7 rad, at most 512 pieces per mean. */
            if (estimate > MS_R(0.5) * tolerance * (hi - lo) && estimate > floor_level && depth < MS_EXACT_AZIMUTH_DEPTH &&
                hi - lo > (real)1e-7 && (int)result.pieces + depth < 512) {
                if (top < MS_EXACT_AZIMUTH_STACK) {
                    stack_depth[top - 1] = depth + 1;
                    stack_hi[top] = mid;
                    stack_depth[top] = depth + 1;
                    ++top;
                    continue;
                }
                /* Stack full: keep the piece, and its whole magnitude as error. */
                result.error += fabs(high);
                result.flags |= MS_EXACT_FLAG_STACK_FULL;
            }
            integral += high;
            result.error += estimate + error_high;
            result.pieces += 1;
            lo = hi;
            --top;
        }
    }
    result.value = clamp(integral / MS_EXACT_PI, MS_R(0.0), MS_R(1.0));
    result.error = result.error / MS_EXACT_PI;
    exact_store(out + g, result);
}
