/*
 * generic_term.cl - the generic VNDF-based micro-shadowing term (part 2) by massive VNDF sampling.
 *
 * Estimator. For a query (cos_t, alpha, wi, wo), part 2 defines
 *     GenericM_g = E[ H(<wg.wm> - cos_t) H(<wm.wo> - cos_t) w ] / E[ H(<wg.wm>) H(<wm.wo>) w ],
 * expectations over visible normals wm ~ D_wi, with w = G2(wi,wo,wm) / G1(wi,wm). Under the Smith
 * profile G1(w,wm) = H(w.wm) / (1 + Lambda(w)), and Lambda depends on the macro direction only, so:
 *   uncorrelated:        w = G1(wo,wm)                            = H(wo.wm) / (1 + Lambda_o)
 *   height-correlated:   w = G1o / (G1o + G1i - G1o G1i)           = H(wo.wm) / (1 + Lambda_o + Lambda_i)
 *                        (G1i = 1 / (1 + Lambda_i) because a visible normal has wi.wm > 0).
 * In both forms w = H(wo.wm) * constant, and H(wo.wm) is already implied by both numerator and
 * denominator (each requires wm.wo > cos_t >= 0). The constant cancels in the ratio, so
 *     GenericM_g = P(wm.wg > cos_t and wm.wo > cos_t) / P(wm.wg > 0 and wm.wo > 0),
 * a ratio of two counts: the kernel tallies integers (which vectorise, unlike float sums under strict
 * math) and the host divides. The scalar oracle keeps the weights; tests compare the two.
 * Conventions: <a.b> clamps to [0,1] and H(x) = [x > 0], so for cos_t in [0,1) the condition
 * H(<a.b> - cos_t) is simply a.b > cos_t. wo at or below the horizon: Lambda_o is infinite, w = 0,
 * term 0.
 *
 * Cone test in tangents, not cosines. In float, cos_t = 1 for v < ~6e-8 and m.a > cos_t |m| resolves
 * 1 - cos_t only to ~6e-8 absolute, so tiny cones come out empty or wrong (0.23 off at v = 1e-7). For a
 * unit axis a and theta in (0, 90 deg]:
 *     angle(m, a) < theta  <=>  m.a > 0  and  cos_t^2 |m x a|^2 < sin_t^2 (m.a)^2,
 * with |m x a| taken from m's components perpendicular to a (mx, my for a = z; an orthonormal frame
 * t1, t2 around wo for a = wo), never from |m|^2 - (m.a)^2. Both sides are products of non-negative
 * terms with small relative error, so tan^2 is resolved to a few ulps at any cone size (the sine form
 * alone would fail near 90 deg, the cosine form near 0). The host passes sin_t^2 (from v in double);
 * k = cot_t scales the perpendicular side, and k = 0 at v = 1 gives the whole hemisphere.
 *
 * Vectorisation. Each work-item handles one (query, replicate, chunk) triple and walks its points in
 * float16 blocks: PoCL keeps sin/cos/normalize scalar, so the sampler uses a polynomial sincos with
 * integer quadrant selection and compares squared quantities instead of normalising.
 */
#include "microshadow_shared.h"

/*
 * Working precision. MS_REAL_IS_DOUBLE=1 (BuildConfig::double_precision, devices with cl_khr_fp64)
 * runs the same algorithm in double, which tells float rounding apart from algorithmic differences
 * when the kernel is compared with the oracle. The points stay float: they are exact in both.
 */
#if MS_REAL_IS_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
typedef double3 real3;
typedef double16 real16;
#define convert_real16 convert_double16
#define MS_R(x) x
#else
typedef float real;
typedef float3 real3;
typedef float16 real16;
#define convert_real16 convert_float16
#define MS_R(x) x##f
#endif

/*
 * cos(2 pi u) and sin(2 pi u) for u in [0, 1). Write 2 pi u = q pi/2 + a with q = round(4u) and
 * a in [-pi/4, pi/4]; Taylor polynomials of degree 7 (sin) and 8 (cos) are accurate to 3e-7 there,
 * below float's resolution of the sampled directions (double mode adds terms up to degree 12, 1e-11).
 * The quadrant rotation is done with selects.
 */
#if MS_REAL_IS_DOUBLE
typedef long16 mask16; /* vector comparisons of double16 yield long16 */
#define convert_mask16 convert_long16
#else
typedef int16 mask16;
#define convert_mask16 convert_int16
#endif
inline void sincos_turns16(real16 u, real16* sin_out, real16* cos_out)
{
    const real16 t = u * MS_R(4.0);
    const int16 q = convert_int16(t + MS_R(0.5)); /* t >= 0, so truncation rounds to nearest */
    const real16 a = (t - convert_real16(q)) * MS_R(1.57079632679489662);
    const real16 a2 = a * a;
#if MS_REAL_IS_DOUBLE
    const real16 sa = a * (1.0 + a2 * (-1.0 / 6 + a2 * (1.0 / 120 + a2 * (-1.0 / 5040 + a2 * (1.0 / 362880 + a2 * (-1.0 / 39916800))))));
    const real16 ca = 1.0 + a2 * (-0.5 + a2 * (1.0 / 24 + a2 * (-1.0 / 720 + a2 * (1.0 / 40320 + a2 * (-1.0 / 3628800 + a2 * (1.0 / 479001600))))));
#else
    const real16 sa = a * (1.0f + a2 * (-1.0f / 6.0f + a2 * (1.0f / 120.0f + a2 * (-1.0f / 5040.0f))));
    const real16 ca = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24.0f + a2 * (-1.0f / 720.0f + a2 * (1.0f / 40320.0f))));
#endif
    const mask16 quadrant = convert_mask16(q & 3);
    /* quadrant 0: (cos, sin) = (ca, sa); 1: (-sa, ca); 2: (-ca, -sa); 3: (sa, -ca) */
    const mask16 odd = (quadrant & 1) != 0;
    const real16 c = select(ca, sa, odd);
    const real16 s = select(sa, ca, odd);
    *cos_out = select(c, -c, (quadrant == 1) | (quadrant == 2));
    *sin_out = select(s, -s, quadrant >= 2);
}

/*
 * Tally one query over `count` points (a multiple of MS_LANES) starting at `first`.
 * Spherical-cap VNDF sampling (Dupuy & Benyoub 2023): stretch wi into the isotropic configuration,
 * sample a spherical cap [-wi_std.z, 1] in z, add wi_std, and unstretch. The unstretched vector
 * m = (ax h.x, ay h.y, h.z) is left unnormalised: the cone tests (see the header) are homogeneous
 * in m, which avoids a sqrt and a division per sample.
 */
inline ms_tally tally_points(const ms_query q, __global const float* u1, __global const float* u2,
                             uint first, uint count)
{
    ms_tally result = {0u, 0u};
    /* Provable zeros (see host/core/cone.hpp): light at or below the horizon, an empty cone (v = 0),
     * or NdotL <= cos(2 theta) = 1 - 2 sin_t^2. The host never sends these; the guard keeps the kernel
     * correct on its own. The 2^-22 margin exceeds the float rounding of wo_z and 1 - 2 sin_t^2, so a
     * query just outside the zero region is never cut. */
    if (q.wo_z <= 0.0f || q.sin2_cone <= 0.0f || q.wo_z < 1.0f - 2.0f * q.sin2_cone - 0x1p-22f)
        return result;

    const real ax = q.alpha_x, ay = q.alpha_y;
    real3 wi_std = (real3)(ax * q.wi_x, ay * q.wi_y, q.wi_z);
    wi_std *= rsqrt(dot(wi_std, wi_std));

    /* k = cot_t; the cone tests read mz^2 > k^2 (mx^2 + my^2) and (m.wo)^2 > e1^2 + e2^2 with
     * e = k (m.t1, m.t2), t1 = (-sin phi_o, cos phi_o, 0), t2 = wo x t1 (phi_o: azimuth of wo). */
    const real wox = q.wo_x, woy = q.wo_y, woz = q.wo_z;
    const real k = (real)q.cos_theta / sqrt((real)q.sin2_cone);
    const real k2 = k * k;
    const real r = sqrt(fma(wox, wox, woy * woy));
    /* Below 1e-18 r^2 would be subnormal; wo is then the normal to far below any cone's resolution. */
    const int polar = r < MS_R(1e-18);
    const real cos_po = polar ? MS_R(1.0) : wox / r, sin_po = polar ? MS_R(0.0) : woy / r;
    const real p1x = -k * sin_po, p1y = k * cos_po;
    const real p2x = -k * woz * cos_po, p2y = -k * woz * sin_po, p2z = k * r;

    int16 cone = 0, hemisphere = 0; /* comparisons yield -1 for true, so these count downwards */
    /* fma, not mad: PoCL 3.1 lowers mad to a separate multiply and add, ~10 more instructions a block. */
    for (uint i = first; i < first + count; i += MS_LANES) {
        const real16 r1 = convert_real16(vload16(0, u1 + i));
        const real16 r2 = convert_real16(vload16(0, u2 + i));
        real16 sin_phi, cos_phi;
        sincos_turns16(r1, &sin_phi, &cos_phi);
        const real16 z = fma(MS_R(1.0) - r2, MS_R(1.0) + wi_std.z, -wi_std.z);
        const real16 s = sqrt(max(MS_R(1.0) - z * z, MS_R(0.0)));
        const real16 mx = ax * fma(s, cos_phi, wi_std.x);
        const real16 my = ay * fma(s, sin_phi, wi_std.y);
        const real16 mz = z + wi_std.z;
        const real16 m_dot_l = fma(mx, wox, fma(my, woy, mz * woz));
        const real16 e1 = fma(mx, p1x, my * p1y);
        const real16 e2 = fma(mx, p2x, fma(my, p2y, mz * p2z));
        const mask16 facing = (mz > MS_R(0.0)) & (m_dot_l > MS_R(0.0));
        const mask16 in_cone = facing & (mz * mz > k2 * fma(mx, mx, my * my)) &
                               (m_dot_l * m_dot_l > fma(e1, e1, e2 * e2));
        hemisphere += convert_int16(facing);
        cone += convert_int16(in_cone);
    }
    /* Lanes hold at most count / 16 each; the horizontal sum cannot overflow for count < 2^31. */
    int8 c8 = cone.lo + cone.hi;
    int8 h8 = hemisphere.lo + hemisphere.hi;
    int4 c4 = c8.lo + c8.hi;
    int4 h4 = h8.lo + h8.hi;
    result.cone = (uint)(-(c4.x + c4.y + c4.z + c4.w));
    result.hemisphere = (uint)(-(h4.x + h4.y + h4.z + h4.w));
    return result;
}

/*
 * Global id g = (query * replicates + replicate) * chunks + chunk. Each replicate's points are split
 * into `chunks` equal chunks so small batches still fill a device; the host sums chunk tallies.
 */
__kernel void ms_tally_queries(__global const ms_query* queries, uint query_count,
                               __global const float* u1, __global const float* u2,
                               uint points_per_replicate, uint replicates, uint chunks,
                               __global ms_tally* tallies)
{
    const uint g = get_global_id(0);
    if (g >= query_count * replicates * chunks) return;
    const uint chunk = g % chunks;
    const uint replicate = (g / chunks) % replicates;
    const uint query = g / (chunks * replicates);
    const uint per_chunk = points_per_replicate / chunks;
    const uint first = replicate * points_per_replicate + chunk * per_chunk;
    tallies[g] = tally_points(queries[query], u1, u2, first, per_chunk);
}
