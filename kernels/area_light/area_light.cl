/*
 * area_light.cl - the micro-shadowing of an area light, sampling light directions and visible normals
 * jointly.
 *
 * Quantity (core/area_light.hpp):
 *     T_area = Int_L W(wo) T(wo) dwo / Int_L W(wo) dwo,   W = f(wi, wo) cos(wo) H(wo.z),
 * T(wo) the generic term, a ratio of two VNDF probabilities (term/generic_term.cl):
 *     T(wo) = P(m.z > cos_t and m.wo > cos_t) / P(m.wo > 0),   m ~ D_wi.
 *
 * Estimator. Each 4D point (u1, u2, u3, u4) gives a light direction wo from (u3, u4) with density p(wo)
 * and a visible normal m from (u1, u2), independently of wo. Then
 *     E[ (W(wo) / p(wo)) * [m passes both cones for wo] / h(wo) ] = Int_L W T dwo,
 *     E[  W(wo) / p(wo) ]                                          = Int_L W dwo,
 * where h(wo) = P(m.wo > 0) is the term's denominator, known in closed form (below), so the joint
 * sample needs no inner ratio. The kernel sums both per replicate; the host forms the pooled ratio and
 * the standard error from the spread of the replicate ratios (core/estimate.hpp).
 *
 * h(wo) in closed form. In the stretched configuration of the spherical-cap sampler (common/vndf.cl) the
 * microsurface is the alpha = 1 GGX, whose visible normals n have density 2 (c.n)+ / (pi (1 + c.z)) on
 * the upper hemisphere, c = wi_s = normalize(ax wi.x, ay wi.y, wi.z). Unstretching maps m.wo > 0 onto
 * n.b > 0 with b = normalize(ax wo.x, ay wo.y, wo.z). So
 *     h(wo) = 2 / (pi (1 + c.z)) Int_P (c.n) dn,   P = {n.z > 0, n.b > 0, n.c > 0},
 * and P, an intersection of three hemispheres with normals a = z, b, c, is a spherical triangle (a lune
 * when they are coplanar). By Stokes, Int_P n dn = 1/2 sum_e theta_e N_e over its edges, N_e the inward
 * normal of edge e (here a, b or c) and theta_e its length; the edge on the great circle of a keeps the
 * part inside the other two hemispheres, of length pi - angle(a x b, a x c) (the dihedral angle between
 * the planes (a, b) and (a, c)), and likewise for b and c:
 *     h(wo) = (theta_a c.z + theta_b (b.c) + theta_c) / (pi (1 + c.z)).
 * Coincident normals: the duplicated edge is shared, so two coincident normals take pi/2 each (b = a:
 * wo along the normal; b = c), and c = a (wi along the normal) gives h = (1 + b.z) / 2. The angles come
 * from atan2(|u x v|, u.v) of cross products that carry small relative error; where b approaches a or
 * c the single angles lose accuracy but their sum (pi) and the nearly equal normals keep h accurate.
 *
 * Light directions. lambert: the light's own sampler, uniform in solid angle on a sphere light's cone,
 * uniform in area on a rectangle (p = p0 + u3 e1 + u4 e2, density |p|^2 / (A |n.wo|) in solid angle).
 * A light of over 1 sr (cosine_technique) adds the cosine lobe as a second technique, as ggx adds its
 * lobe below (p_lobe = wo.z / pi): a rectangle far larger than its distance has an area density that
 * spans many orders over its directions, and area samples alone then miss the few directions that
 * carry the weight; with the cosine lobe every weight is at most 2.
 * ggx: multiple importance sampling with the balance heuristic, one technique per point chosen by
 * u3 < 1/2 (the light's sampler) or u3 >= 1/2 (the GGX lobe: wi reflected about a visible normal drawn
 * from (2 u3 - 1, u4)), so each technique gets half the points on average:
 *     W / p = f cos / (p_light / 2 + p_lobe / 2),   f cos = D G2 / (4 wi.z),  p_lobe = D G1(wi) / (4 wi.z),
 * with D(h) the anisotropic GGX NDF at h = normalize(wi + wo), G2 = 1 / (1 + Lambda_i + Lambda_o), and
 * W = 0 for a lobe sample outside the light or below the horizon. A narrow lobe inside a wide light and
 * a small light inside a wide lobe are then both sampled where their weight is.
 *
 * Sums. Each work-item keeps sixteen float partial sums of each integral (lanes) and counts the
 * samples that passed both cones and those of non-zero weight; the host adds them in double.
 */
/* Preamble (prepended by the host): common/microshadow_shared.h, real.cl, sincos.cl, vndf.cl, cone.cl,
 * work_items.cl. */

#define MS_PI_R MS_R(3.14159265358979323846)

/* Angle between u and v in [0, pi] from the cross and dot products (accurate at every angle). */
inline real16 angle_between16(real16 ux, real16 uy, real16 uz, real16 vx, real16 vy, real16 vz)
{
    const real16 cx = fma(uy, vz, -uz * vy), cy = fma(uz, vx, -ux * vz), cz = fma(ux, vy, -uy * vx);
    return atan2(sqrt(fma(cx, cx, fma(cy, cy, cz * cz))), fma(ux, vx, fma(uy, vy, uz * vz)));
}

/* h(wo) = P(m.wo > 0), m ~ D_wi, for sixteen directions (bx, by, bz) = b, the stretched light, unit. */
inline real16 hemisphere_fraction16(const ms_area_query q, real16 bx, real16 by, real16 bz)
{
    const real cx = q.wis_x, cy = q.wis_y, cz = q.wis_z;
    if (cx == MS_R(0.0) && cy == MS_R(0.0)) return MS_R(0.5) * (MS_R(1.0) + bz);
    /* a x b = (-by, bx, 0), a x c = (-cy, cx, 0): the azimuths of b and c */
    const real16 angle_a = atan2(fabs(fma(bx, (real16)cy, -by * cx)), fma(bx, (real16)cx, by * cy));
    /* b x a = (by, -bx, 0); b x c */
    const real16 bcx = fma(by, (real16)cz, -bz * cy), bcy = fma(bz, (real16)cx, -bx * cz), bcz = fma(bx, (real16)cy, -by * cx);
    const real16 zero = MS_R(0.0);
    const real16 angle_b = angle_between16(by, -bx, zero, bcx, bcy, bcz);
    /* c x a = (cy, -cx, 0); c x b = -(b x c) */
    const real16 angle_c = angle_between16((real16)cy, (real16)(-cx), zero, -bcx, -bcy, -bcz);
    const mask16 b_on_a = fma(bx, bx, by * by) == zero;
    const mask16 b_on_c = fma(bcx, bcx, fma(bcy, bcy, bcz * bcz)) == zero;
    const real16 half_pi = MS_PI_R * MS_R(0.5);
    const real16 ta = MS_PI_R - select(angle_a, half_pi, b_on_a);
    const real16 tb = MS_PI_R - select(angle_b, half_pi, b_on_a | b_on_c);
    const real16 tc = MS_PI_R - select(angle_c, half_pi, b_on_c);
    const real16 b_dot_c = fma(bx, (real16)cx, fma(by, (real16)cy, bz * cz));
    return fma(ta, (real16)cz, fma(tb, b_dot_c, tc)) / (MS_PI_R * (MS_R(1.0) + cz));
}

/* GGX: D(h) for the unnormalised half vector h = wi + wo (lanes), and Lambda(wo). */
inline real16 ggx_ndf16(const ms_area_query q, real16 hx, real16 hy, real16 hz)
{
    const real16 h2 = fma(hx, hx, fma(hy, hy, hz * hz));
    const real16 ex = hx / q.alpha_x, ey = hy / q.alpha_y;
    const real16 s = fma(ex, ex, fma(ey, ey, hz * hz));
    return (h2 * h2) / (MS_PI_R * q.alpha_x * q.alpha_y * s * s);
}

inline real16 smith_lambda16(const ms_area_query q, real16 wx, real16 wy, real16 wz)
{
    const real16 ax = q.alpha_x * wx, ay = q.alpha_y * wy;
    const real16 a = fma(ax, ax, ay * ay) / max(wz * wz, MS_R(1e-30));
    /* (sqrt(1 + a) - 1) / 2 without cancellation for small a */
    return a / (MS_R(2.0) * (MS_R(1.0) + sqrt(MS_R(1.0) + a)));
}

/* Solid-angle density of the light's own sampler at unit directions wo (0 outside the light). */
inline real16 light_pdf16(const ms_area_query q, real16 wx, real16 wy, real16 wz)
{
    if (q.shape == MS_LIGHT_SPHERE) {
        /* inside the cone: wo.c > 0 and |wo x c|^2 < sin^2 gamma (the tangent side of common/cone.cl) */
        const real16 d = fma(wx, (real16)q.a_x, fma(wy, (real16)q.a_y, wz * q.a_z));
        const real16 cx = fma(wy, (real16)q.a_z, -wz * q.a_y), cy = fma(wz, (real16)q.a_x, -wx * q.a_z),
                     cz = fma(wx, (real16)q.a_y, -wy * q.a_x);
        const mask16 inside = (d > MS_R(0.0)) & (fma(cx, cx, fma(cy, cy, cz * cz)) < q.s1);
        return select((real16)MS_R(0.0), (real16)q.inv_measure, inside);
    }
    /* ray from the shaded point along wo meets the plane n.p = s0 at t = s0 / n.wo */
    const real16 facing = fma(wx, (real16)q.n_x, fma(wy, (real16)q.n_y, wz * q.n_z));
    const real16 t = q.s0 / max(facing, MS_R(1e-30));
    const real16 px = fma(t, wx, (real16)(-q.a_x)), py = fma(t, wy, (real16)(-q.a_y)), pz = fma(t, wz, (real16)(-q.a_z));
    const real e1 = q.b_x * q.b_x + q.b_y * q.b_y + q.b_z * q.b_z;
    const real e2 = q.c_x * q.c_x + q.c_y * q.c_y + q.c_z * q.c_z;
    const real16 x = fma(px, (real16)q.b_x, fma(py, (real16)q.b_y, pz * q.b_z)) / e1;
    const real16 y = fma(px, (real16)q.c_x, fma(py, (real16)q.c_y, pz * q.c_z)) / e2;
    const mask16 inside = (facing > MS_R(0.0)) & (x >= MS_R(0.0)) & (x <= MS_R(1.0)) & (y >= MS_R(0.0)) & (y <= MS_R(1.0));
    return select((real16)MS_R(0.0), t * t * q.inv_measure / max(facing, MS_R(1e-30)), inside);
}

/* A direction from the light's own sampler at (u3, u4), and its density. */
inline void sample_light16(const ms_area_query q, real16 u3, real16 u4, real16* wx, real16* wy, real16* wz, real16* pdf)
{
    if (q.shape == MS_LIGHT_SPHERE) {
        /* uniform in the cone: 1 - cos(theta) = u3 (1 - cos gamma), sin(theta) from it without cancellation */
        const real16 one_minus_cos = u3 * q.s0;
        const real16 cos_t = MS_R(1.0) - one_minus_cos;
        const real16 sin_t = sqrt(max(one_minus_cos * (MS_R(2.0) - one_minus_cos), MS_R(0.0)));
        real16 sp, cp;
        sincos_turns16(u4, &sp, &cp);
        const real16 s1 = sin_t * cp, s2 = sin_t * sp;
        *wx = fma(s1, (real16)q.b_x, fma(s2, (real16)q.c_x, cos_t * q.a_x));
        *wy = fma(s1, (real16)q.b_y, fma(s2, (real16)q.c_y, cos_t * q.a_y));
        *wz = fma(s1, (real16)q.b_z, fma(s2, (real16)q.c_z, cos_t * q.a_z));
        *pdf = (real16)q.inv_measure;
        return;
    }
    const real16 px = fma(u3, (real16)q.b_x, fma(u4, (real16)q.c_x, (real16)q.a_x));
    const real16 py = fma(u3, (real16)q.b_y, fma(u4, (real16)q.c_y, (real16)q.a_y));
    const real16 pz = fma(u3, (real16)q.b_z, fma(u4, (real16)q.c_z, (real16)q.a_z));
    const real16 r2 = fma(px, px, fma(py, py, pz * pz));
    const real16 inv_r = rsqrt(r2);
    *wx = px * inv_r;
    *wy = py * inv_r;
    *wz = pz * inv_r;
    /* |n.wo| = s0 / r for every point of the plane (n.p = s0) */
    *pdf = r2 * q.inv_measure * (sqrt(r2) / q.s0);
}

typedef struct area_sums {
    real16 numerator, denominator;
    int16 passed, weighted; /* comparisons yield -1 for true: these count downwards */
} area_sums;

inline void accumulate_block(const ms_area_query q, const real3 wi_std, __global const float* u1, __global const float* u2,
                             __global const float* u3, __global const float* u4, uint i, area_sums* s)
{
    const real16 zero = MS_R(0.0);
    real16 v3 = convert_real16(vload16(0, u3 + i));
    const real16 v4 = convert_real16(vload16(0, u4 + i));
    /* ggx: u3 < 1/2 picks the light's sampler, else the lobe's, each with u3 stretched back onto [0, 1)
     * (one-sample MIS with probability 1/2 each: the balance weight below is the same). The choice must
     * not come from the point's index, which the normals' coordinates (u1 = i / n scrambled) depend on. */
    const int two_techniques = q.lobe == MS_LOBE_GGX || q.cosine_technique;
    const mask16 lobe_technique = two_techniques ? convert_mask16(v3 >= MS_R(0.5)) : (mask16)0;
    if (two_techniques) v3 = select(v3 * MS_R(2.0), fma(v3, MS_R(2.0), MS_R(-1.0)), lobe_technique);
    real16 wx, wy, wz, pdf_light;
    sample_light16(q, v3, v4, &wx, &wy, &wz, &pdf_light);
    if (q.lobe == MS_LOBE_GGX) {
        real16 lx, ly, lz;
        vndf_sample16(wi_std, q.alpha_x, q.alpha_y, v3, v4, &lx, &ly, &lz);
        const real16 inv = rsqrt(fma(lx, lx, fma(ly, ly, lz * lz)));
        lx *= inv, ly *= inv, lz *= inv;
        const real16 two_vm = MS_R(2.0) * fma(lx, (real16)q.wi_x, fma(ly, (real16)q.wi_y, lz * q.wi_z));
        wx = select(wx, fma(two_vm, lx, (real16)(-q.wi_x)), lobe_technique);
        wy = select(wy, fma(two_vm, ly, (real16)(-q.wi_y)), lobe_technique);
        wz = select(wz, fma(two_vm, lz, (real16)(-q.wi_z)), lobe_technique);
        pdf_light = select(pdf_light, light_pdf16(q, wx, wy, wz), lobe_technique);
    } else if (two_techniques) {
        /* the cosine lobe: radius sqrt(u3) on the unit disc, lifted to the hemisphere */
        real16 sp, cp;
        sincos_turns16(v4, &sp, &cp);
        const real16 r = sqrt(v3);
        wx = select(wx, r * cp, lobe_technique);
        wy = select(wy, r * sp, lobe_technique);
        wz = select(wz, sqrt(max(MS_R(1.0) - v3, zero)), lobe_technique);
        pdf_light = select(pdf_light, light_pdf16(q, wx, wy, wz), lobe_technique);
    }
    const mask16 lit = (wz > zero) & (pdf_light > zero);
    real16 weight;
    if (q.lobe == MS_LOBE_LAMBERT && two_techniques) {
        const real16 f_cos = wz / MS_PI_R;
        weight = f_cos / (MS_R(0.5) * (pdf_light + f_cos));
    } else if (q.lobe == MS_LOBE_LAMBERT) {
        weight = wz / (MS_PI_R * max(pdf_light, MS_R(1e-30)));
    } else {
        const real16 d = ggx_ndf16(q, wx + q.wi_x, wy + q.wi_y, wz + q.wi_z);
        const real16 lambda_o = smith_lambda16(q, wx, wy, wz);
        const real scale = MS_R(1.0) / (MS_R(4.0) * q.wi_z);
        const real16 f_cos = d * scale / (MS_R(1.0) + q.lambda_i + lambda_o);
        const real16 p_lobe = d * scale / (MS_R(1.0) + q.lambda_i);
        weight = f_cos / (MS_R(0.5) * (pdf_light + p_lobe));
    }
    weight = select(zero, weight, lit);

    /* the visible normal, its hemisphere and cone tests for this lane's wo (unnormalised m: every test
     * below is homogeneous in m) */
    real16 mx, my, mz;
    vndf_sample16(wi_std, q.alpha_x, q.alpha_y, convert_real16(vload16(0, u1 + i)), convert_real16(vload16(0, u2 + i)), &mx, &my, &mz);
    const real16 m_dot_l = fma(mx, wx, fma(my, wy, mz * wz));
    const real16 cx = fma(my, wz, -mz * wy), cy = fma(mz, wx, -mx * wz), cz = fma(mx, wy, -my * wx);
    const mask16 in_cones = lit & (mz > zero) & (m_dot_l > zero) & (mz * mz > q.cot2_cone * fma(mx, mx, my * my)) &
                            (m_dot_l * m_dot_l > q.cot2_cone * fma(cx, cx, fma(cy, cy, cz * cz)));
    /* the stretched light b for h(wo) */
    const real16 bx = q.alpha_x * wx, by = q.alpha_y * wy;
    const real16 inv_b = rsqrt(fma(bx, bx, fma(by, by, wz * wz)));
    const real16 h = hemisphere_fraction16(q, bx * inv_b, by * inv_b, wz * inv_b);
    s->numerator += select(zero, weight / max(h, MS_R(1e-30)), in_cones);
    s->denominator += weight;
    s->passed += convert_int16(in_cones);
    s->weighted += convert_int16(weight > zero);
}

/*
 * Global id g = (query * replicates + replicate) * chunks + chunk (common/work_items.cl).
 * sums[g * 32 + k]: k < 16 the numerator's lanes, k >= 16 the denominator's; counts[2 g] the samples
 * that passed both cones, counts[2 g + 1] those of non-zero weight.
 */
__kernel void ms_area_light_tally(__global const ms_area_query* queries, uint query_count,
                                  __global const float* u1, __global const float* u2,
                                  __global const float* u3, __global const float* u4,
                                  uint points_per_replicate, uint replicates, uint chunks,
                                  __global float* sums, __global uint* counts)
{
    const uint g = get_global_id(0);
    if (g >= query_count * replicates * chunks) return;
    const ms_work_item w = ms_work_item_of(g, replicates, chunks, points_per_replicate);
    const ms_area_query q = queries[w.item];
    const real3 wi_std = (real3)(q.wis_x, q.wis_y, q.wis_z);
    area_sums s;
    s.numerator = MS_R(0.0);
    s.denominator = MS_R(0.0);
    s.passed = 0;
    s.weighted = 0;
    for (uint i = w.first; i < w.first + w.count; i += MS_LANES) accumulate_block(q, wi_std, u1, u2, u3, u4, i, &s);
    vstore16(convert_float16(s.numerator), 0, sums + g * 32);
    vstore16(convert_float16(s.denominator), 0, sums + g * 32 + 16);
    int8 p8 = s.passed.lo + s.passed.hi, w8 = s.weighted.lo + s.weighted.hi;
    int4 p4 = p8.lo + p8.hi, w4 = w8.lo + w8.hi;
    counts[2 * g] = (uint)(-(p4.x + p4.y + p4.z + p4.w));
    counts[2 * g + 1] = (uint)(-(w4.x + w4.y + w4.z + w4.w));
}
