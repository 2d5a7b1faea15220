/*
 * dfg.cl - the split-sum DFG integrals of GGX (scale, bias) by VNDF sampling.
 *
 * Integrals. For an isotropic GGX surface (alpha = roughness^2) seen from V = (sqrt(1 - v^2), 0, v),
 * v = NdotV, the split-sum approximation (Karis 2013) factors the specular BRDF f = D G2 / (4 NdotL NdotV)
 * with Schlick's Fresnel F = F0 + (1 - F0) Fc, Fc = (1 - VdotH)^5, into
 *     integral f F NdotL dL = F0 * scale + bias,
 *     scale = integral f (1 - Fc) NdotL dL,     bias = integral f Fc NdotL dL.
 * Their sum E = scale + bias is the single-scattering directional albedo with F = 1, which the
 * multiple-scattering energy compensation (Kulla-Conty; Filament: 1 + F0 (1/E - 1)) needs.
 *
 * Estimator. Sample visible normals m ~ D_V(m) = G1(V) <V.m> D(m) / NdotV (common/vndf.cl) and reflect:
 * L = 2 (V.m) m - V, with pdf(L) = D_V(m) / (4 V.m). Then
 *     f NdotL / pdf(L) = D G2 / (4 NdotL NdotV) * NdotL * 4 (V.m) NdotV / (G1(V) (V.m) D) = G2(V, L) / G1(V),
 * and with the height-correlated Smith form G2 = 1 / (1 + Lambda_V + Lambda_L), G1(V) = 1 / (1 + Lambda_V):
 *     w = (1 + Lambda_V) / (1 + Lambda_V + Lambda_L)   for L above the horizon, 0 below,
 *     Lambda(L) = (sqrt(1 + alpha^2 (1 - Lz^2) / Lz^2) - 1) / 2.
 * scale = E[w (1 - Fc)], bias = E[w Fc]: plain means, every weight in [0, 1].
 *
 * Rare events. For small alpha the visible normals that send L towards or below the horizon come from
 * a sliver of the unit square near u2 = 1 (the cap's rim: z -> -wi_std.z), of width ~alpha^2, narrower
 * than one stratum of a replicate (1/n); a net then sees it in no replicate, the estimate misses its
 * share (1e-5 at roughness 0.05) and the replicate spread does not show it. The points are therefore
 * warped towards u2 = 1: u2 = 1 - (1 - s)^K with weight K (1 - s)^(K - 1) (K = MS_DFG_WARP, default
 * 3), which maps a sliver of width eps onto eps^(1/K) and keeps the integrand smooth in s.
 *
 * Sums. Under strict math PoCL does not vectorise a scalar float reduction (it may not reassociate), so
 * each work-item keeps sixteen partial sums per integral in float16 and writes them out; the host adds
 * them in double per replicate. A work-item sums at most a few thousand points (a few hundred per lane),
 * so the float rounding of a lane sum stays near 1e-6 relative, far below the sampling error.
 */
/* Preamble (prepended by the host): common/microshadow_shared.h, real.cl, sincos.cl, vndf.cl, cone.cl. */
#ifndef MS_DFG_WARP
#define MS_DFG_WARP 3
#endif

/*
 * texels[t] = (alpha, NdotV, sqrt(1 - NdotV^2), unused), NdotV in (0, 1].
 * Global id g = (texel * replicates + replicate) * chunks + chunk (common/work_items.cl); sums[g * 32 + k]: k < 16 the lanes of
 * scale, k >= 16 the lanes of bias.
 */
__kernel void ms_dfg_tally(__global const float4* texels, uint texel_count,
                           __global const float* u1, __global const float* u2,
                           uint points_per_replicate, uint replicates, uint chunks,
                           __global float* sums)
{
    const uint g = get_global_id(0);
    if (g >= texel_count * replicates * chunks) return;
    const ms_work_item w = ms_work_item_of(g, replicates, chunks, points_per_replicate);
    const float4 p = texels[w.item];
    const real alpha = p.x, cv = p.y, sv = p.z;
    const real a2 = alpha * alpha;
    const real3 view = (real3)(sv, MS_R(0.0), cv);
    const real3 wi_std = vndf_stretched_view(alpha, alpha, view);
    /* Lambda of the view, once per work-item: tan^2 = sv^2 / cv^2. */
    const real lambda_v = MS_R(0.5) * (sqrt(MS_R(1.0) + a2 * sv * sv / (cv * cv)) - MS_R(1.0));
    const real one_lv = MS_R(1.0) + lambda_v;

    real16 scale = MS_R(0.0), bias = MS_R(0.0);
    for (uint i = w.first; i < w.first + w.count; i += MS_LANES) {
        const real16 rim = MS_R(1.0) - convert_real16(vload16(0, u2 + i)); /* 1 - s, in (0, 1] */
#if MS_DFG_WARP == 1
        const real16 warped = rim, jacobian = MS_R(1.0);
#elif MS_DFG_WARP == 2
        const real16 warped = rim * rim, jacobian = MS_R(2.0) * rim;
#else
        const real16 warped = rim * rim * rim, jacobian = MS_R(3.0) * rim * rim;
#endif
        real16 mx, my, mz;
        vndf_sample16(wi_std, alpha, alpha, convert_real16(vload16(0, u1 + i)), MS_R(1.0) - warped, &mx, &my, &mz);
        const real16 inv = rsqrt(fma(mx, mx, fma(my, my, mz * mz)));
        mx *= inv;
        mz *= inv;
        const real16 vh = clamp(fma(mx, sv, mz * cv), MS_R(0.0), MS_R(1.0));
        const real16 lz = fma(MS_R(2.0) * vh, mz, -cv);
        const mask16 above = lz > MS_R(0.0);
        const real16 lz2 = max(lz * lz, MS_R(1e-30));
        const real16 lambda_l = MS_R(0.5) * (sqrt(MS_R(1.0) + a2 * (MS_R(1.0) - lz2) / lz2) - MS_R(1.0));
        const real16 w = select((real16)MS_R(0.0), jacobian * one_lv / (one_lv + lambda_l), above);
        const real16 c = MS_R(1.0) - vh;
        const real16 c2 = c * c;
        const real16 fc = c2 * c2 * c;
        const real16 wf = w * fc;
        bias += wf;
        scale += w - wf;
    }
    __global float* out = sums + (size_t)g * 32;
    vstore16(convert_float16(scale), 0, out);
    vstore16(convert_float16(bias), 0, out + 16);
}
