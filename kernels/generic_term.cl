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
 * Vectorisation. Each work-item handles one (query, replicate, chunk) triple and walks its points in
 * float16 blocks: PoCL keeps sin/cos/normalize scalar, so the sampler uses a polynomial sincos with
 * integer quadrant selection and compares squared quantities instead of normalising.
 */
#include "microshadow_shared.h"

/*
 * cos(2 pi u) and sin(2 pi u) for u in [0, 1). Write 2 pi u = q pi/2 + a with q = round(4u) and
 * a in [-pi/4, pi/4]; Taylor polynomials of degree 7 (sin) and 8 (cos) are accurate to 3e-7 there,
 * below float's resolution of the sampled directions. The quadrant rotation is done with selects.
 */
inline void sincos_turns16(float16 u, float16* sin_out, float16* cos_out)
{
    const float16 t = u * 4.0f;
    const int16 q = convert_int16(t + 0.5f); /* t >= 0, so truncation rounds to nearest */
    const float16 a = (t - convert_float16(q)) * 1.57079632679489662f;
    const float16 a2 = a * a;
    const float16 sa = a * (1.0f + a2 * (-1.0f / 6.0f + a2 * (1.0f / 120.0f + a2 * (-1.0f / 5040.0f))));
    const float16 ca = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24.0f + a2 * (-1.0f / 720.0f + a2 * (1.0f / 40320.0f))));
    const int16 quadrant = q & 3;
    /* quadrant 0: (cos, sin) = (ca, sa); 1: (-sa, ca); 2: (-ca, -sa); 3: (sa, -ca) */
    const int16 odd = (quadrant & 1) != 0;
    const float16 c = select(ca, sa, odd);
    const float16 s = select(sa, ca, odd);
    *cos_out = select(c, -c, (quadrant == 1) | (quadrant == 2));
    *sin_out = select(s, -s, quadrant >= 2);
}

/*
 * Tally one query over `count` points (a multiple of MS_LANES) starting at `first`.
 * Spherical-cap VNDF sampling (Dupuy & Benyoub 2023): stretch wi into the isotropic configuration,
 * sample a spherical cap [-wi_std.z, 1] in z, add wi_std, and unstretch. The unstretched vector
 * m = (ax h.x, ay h.y, h.z) is left unnormalised: with len = |m|,
 *     wm.wg > c  <=>  m.z > c len,      wm.wo > c  <=>  m.wo > c len,
 * and for c >= 0 and positive left sides these are compared squared, which avoids a sqrt and a division.
 */
inline ms_tally tally_points(const ms_query q, __global const float* u1, __global const float* u2,
                             uint first, uint count)
{
    ms_tally result = {0u, 0u};
    /* Provable zeros (see host/core/cone.hpp): light at or below the horizon, or outside twice the
     * cone. The host never sends these; the guard keeps the kernel correct on its own. */
    if (q.wo_z <= 0.0f || q.wo_z <= 2.0f * q.cos_theta * q.cos_theta - 1.0f || q.cos_theta >= 1.0f)
        return result;

    float3 wi_std = (float3)(q.alpha_x * q.wi_x, q.alpha_y * q.wi_y, q.wi_z);
    wi_std *= rsqrt(dot(wi_std, wi_std));
    const float c2 = q.cos_theta * q.cos_theta;

    int16 cone = 0, hemisphere = 0; /* comparisons yield -1 for true, so these count downwards */
    for (uint i = first; i < first + count; i += MS_LANES) {
        const float16 r1 = vload16(0, u1 + i);
        const float16 r2 = vload16(0, u2 + i);
        float16 sin_phi, cos_phi;
        sincos_turns16(r1, &sin_phi, &cos_phi);
        const float16 z = mad(1.0f - r2, 1.0f + wi_std.z, -wi_std.z);
        const float16 s = sqrt(max(1.0f - z * z, 0.0f));
        const float16 mx = q.alpha_x * mad(s, cos_phi, wi_std.x);
        const float16 my = q.alpha_y * mad(s, sin_phi, wi_std.y);
        const float16 mz = z + wi_std.z;
        const float16 len2 = mad(mx, mx, mad(my, my, mz * mz));
        const float16 m_dot_l = mad(mx, q.wo_x, mad(my, q.wo_y, mz * q.wo_z));
        const int16 facing_up = mz > 0.0f;
        const int16 facing_light = m_dot_l > 0.0f;
        const float16 threshold2 = c2 * len2;
        hemisphere += facing_up & facing_light;
        cone += facing_up & facing_light & (mz * mz > threshold2) & (m_dot_l * m_dot_l > threshold2);
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
