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
 * The cone test is the tangent form of common/cone.cl, exact for cones of every size.
 *
 * Vectorisation. Each work-item handles one (query, replicate, chunk) triple and walks its points in
 * float16 blocks: PoCL keeps sin/cos/normalize scalar, so the sampler uses a polynomial sincos with
 * integer quadrant selection and compares squared quantities instead of normalising.
 */
/* Preamble (prepended by the host, device/runtime.cpp): common/microshadow_shared.h, real.cl, sincos.cl,
 * vndf.cl, cone.cl, work_items.cl. */

/*
 * Tally one query over `count` points (a multiple of MS_LANES) starting at `first`.
 * Visible normals come unnormalised from common/vndf.cl: the tangent-form cone test is homogeneous in m.
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
    const real3 wi_std = vndf_stretched_view(ax, ay, (real3)(q.wi_x, q.wi_y, q.wi_z));
    const real3 wo = (real3)(q.wo_x, q.wo_y, q.wo_z);
    const cone_frame frame = cone_frame_make((real)q.cos_theta, (real)q.sin2_cone, wo);

    int16 cone = 0, hemisphere = 0; /* comparisons yield -1 for true, so these count downwards */
    for (uint i = first; i < first + count; i += MS_LANES) {
        real16 mx, my, mz;
        vndf_sample16(wi_std, ax, ay, convert_real16(vload16(0, u1 + i)), convert_real16(vload16(0, u2 + i)), &mx, &my, &mz);
        const real16 m_dot_l = fma(mx, wo.x, fma(my, wo.y, mz * wo.z));
        const mask16 facing = (mz > MS_R(0.0)) & (m_dot_l > MS_R(0.0));
        hemisphere += convert_int16(facing);
        cone += convert_int16(facing & cone_test16(frame, mx, my, mz, m_dot_l));
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

/* Global id g = (query * replicates + replicate) * chunks + chunk (common/work_items.cl). */
__kernel void ms_tally_queries(__global const ms_query* queries, uint query_count,
                               __global const float* u1, __global const float* u2,
                               uint points_per_replicate, uint replicates, uint chunks,
                               __global ms_tally* tallies)
{
    const uint g = get_global_id(0);
    if (g >= query_count * replicates * chunks) return;
    const ms_work_item w = ms_work_item_of(g, replicates, chunks, points_per_replicate);
    tallies[g] = tally_points(queries[w.item], u1, u2, w.first, w.count);
}
