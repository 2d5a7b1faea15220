/*
 * cone.cl - the visibility-cone tests, in forms that resolve cones of every size in float.
 *
 * A microfacet normal m passes the cone of half-angle theta around a unit axis a when angle(m, a) <
 * theta. In float, cos_t = 1 for v < ~6e-8 and m.a > cos_t |m| resolves 1 - cos_t only to ~6e-8
 * absolute, so tiny cones come out empty or wrong (0.23 off at v = 1e-7). Both tests below work with
 * the components of m perpendicular to the axis instead, which carry small relative error:
 *
 * 1. Tangent form (per query, any cone): for theta in (0, 90 deg],
 *        angle(m, a) < theta  <=>  m.a > 0  and  cos_t^2 |m x a|^2 < sin_t^2 (m.a)^2,
 *    with |m x a| from m's components perpendicular to a (mx, my for a = z; an orthonormal frame t1, t2
 *    around wo for a = wo), never from |m|^2 - (m.a)^2. Both sides are products of non-negative terms,
 *    so tan^2 is resolved to a few ulps at any cone size (the sine form alone would fail near 90 deg, the
 *    cosine form near 0). With k = cot_t: mz^2 > k^2 (mx^2 + my^2) and (m.wo)^2 > k^2 ((m.t1)^2 + (m.t2)^2).
 *    m need not be normalised (the test is homogeneous in m).
 *
 * 2. Sine key (LUT rows, one pass for every cone): for a unit m with m.z > 0 and m.wo > 0, the larger
 *    of the two angles has sin^2 = max(mx^2 + my^2, |m x wo|^2), again from perpendicular components.
 *    m passes the cone of visibility v exactly when sin^2_t(v) > key, and sin^2_t is v for cosine-
 *    weighted AO (cos_t = sqrt(1 - v)) and v (2 - v) for uniform-weighted AO (cos_t = 1 - v), where the
 *    condition reads v > 1 - t = key / (1 + t) with t = min(mz, m.wo) (that form keeps small keys exact).
 */

/* The frame of the tangent-form test for one light direction: k = cot_t and k t1, k t2. */
typedef struct cone_frame {
    real k2;
    real p1x, p1y;
    real p2x, p2y, p2z;
} cone_frame;

inline cone_frame cone_frame_make(real cos_theta, real sin2_theta, real3 wo)
{
    cone_frame f;
    const real k = cos_theta / sqrt(sin2_theta);
    f.k2 = k * k;
    const real r = sqrt(fma(wo.x, wo.x, wo.y * wo.y));
    /* Below 1e-18 r^2 would be subnormal; wo is then the normal to far below any cone's resolution. */
    const int polar = r < MS_R(1e-18);
    const real cos_po = polar ? MS_R(1.0) : wo.x / r, sin_po = polar ? MS_R(0.0) : wo.y / r;
    /* t1 = (-sin phi_o, cos phi_o, 0), t2 = wo x t1 (phi_o: azimuth of wo), both scaled by k. */
    f.p1x = -k * sin_po;
    f.p1y = k * cos_po;
    f.p2x = -k * wo.z * cos_po;
    f.p2y = -k * wo.z * sin_po;
    f.p2z = k * r;
    return f;
}

/* Lanes whose m lies in both cones (around the normal and around wo); m.wo is passed in. */
inline mask16 cone_test16(const cone_frame f, real16 mx, real16 my, real16 mz, real16 m_dot_l)
{
    const real16 e1 = fma(mx, f.p1x, my * f.p1y);
    const real16 e2 = fma(mx, f.p2x, fma(my, f.p2y, mz * f.p2z));
    return (mz * mz > f.k2 * fma(mx, mx, my * my)) & (m_dot_l * m_dot_l > fma(e1, e1, e2 * e2));
}

/* sin^2 of the larger of angle(m, z) and angle(m, wo) for a unit m (form 2 above). */
inline real16 cone_sine_key16(real16 mx, real16 my, real16 mz, real3 wo)
{
    const real16 cx = fma(my, wo.z, -mz * wo.y), cy = fma(mz, wo.x, -mx * wo.z), cz = fma(mx, wo.y, -my * wo.x);
    return fmax(fma(mx, mx, my * my), fma(cx, cx, fma(cy, cy, cz * cz)));
}
