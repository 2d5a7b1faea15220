/*
 * prefilter.cl - GGX prefiltering of a cubemap for the split-sum approximation (N = V = R):
 *     P(n) = integral L(l) (n.l) D(h) dl / integral (n.l) D(h) dl,   h = normalize(n + l).
 *
 * Estimator. h is sampled from D(h) (n.h): cos^2 t = (1 - u2) / (1 + (alpha^2 - 1) u2), phi = 2 pi u1, and
 * l = 2 (n.h) h - n, so pdf(l) = D(h) / 4 and the ratio sum L(l) (n.l) / sum (n.l) estimates P(n). With
 * filtered importance sampling (Krivanek & Colbert 2008) a sample is read at
 *     lod = 1/2 log2(Omega_s / Omega_p) + bias,   Omega_s = 1 / (N pdf),
 * Omega_p the solid angle of a full-resolution texel where l lands, (2/n0)^2 / (1 + s^2 + t^2)^(3/2), from the
 * source's box-filtered mip chain (trilinear); unfiltered, every sample is a bilinear read of level 0.
 * Seams: a bilinear footprint that leaves a face reads the neighbouring face's texel through the direction
 * of the missing texel's centre, so no filter sees a seam.
 *
 * One work-item per (output texel, replicate): it writes the replicate's sums (R, G, B numerators and the
 * denominator) and the host forms the ratio and its error bar (ms::reduce_replicates). Written on its own
 * (the host's C++ estimator, host/env/prefilter.cpp, and the brute-force oracle are separate code).
 */
/* Preamble (prepended by the host): common/microshadow_shared.h, real.cl, sincos.cl, vndf.cl, cone.cl,
 * work_items.cl, cubemap.cl (ms_cube_direction, ms_cube_face_st). */

inline float3 pf_texel(__global const float* chain, uint offset, uint n, int face, int x, int y)
{
    return vload3(offset + ((uint)face * n + (uint)y) * n + (uint)x, chain);
}

inline float3 pf_bilinear(__global const float* chain, uint offset, uint n, float3 d)
{
    float s, t;
    const int face = ms_cube_face_st(d, &s, &t);
    const float x = (s + 1.0f) * 0.5f * (float)n - 0.5f, y = (t + 1.0f) * 0.5f * (float)n - 0.5f;
    const float fx = floor(x), fy = floor(y);
    const float ax = x - fx, ay = y - fy;
    const int x0 = (int)fx, y0 = (int)fy;
    float3 acc = (float3)(0.0f);
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
            const float w = (i ? ax : 1.0f - ax) * (j ? ay : 1.0f - ay);
            if (w == 0.0f) continue;
            const int xi = x0 + i, yi = y0 + j;
            float3 v;
            if (xi >= 0 && yi >= 0 && xi < (int)n && yi < (int)n) {
                v = pf_texel(chain, offset, n, face, xi, yi);
            } else {
                const float3 e = ms_cube_direction(face, 2.0f * ((float)xi + 0.5f) / (float)n - 1.0f,
                                              2.0f * ((float)yi + 0.5f) / (float)n - 1.0f);
                float es, et;
                const int ef = ms_cube_face_st(e, &es, &et);
                const int ex = clamp((int)floor((es + 1.0f) * 0.5f * (float)n), 0, (int)n - 1);
                const int ey = clamp((int)floor((et + 1.0f) * 0.5f * (float)n), 0, (int)n - 1);
                v = pf_texel(chain, offset, n, ef, ex, ey);
            }
            acc += w * v;
        }
    return acc;
}

/*
 * chain: the source's mip chain, RGB floats, level l at texel offset level_offset[l] (in texels), face size
 * size0 >> l. targets[k] = (n.x, n.y, n.z, roughness > 0). out[(k * replicates + r) * 4 + c]: c < 3 the
 * numerators, c = 3 the denominator of replicate r.
 */
__kernel void ms_prefilter(__global const float* chain, __global const uint* level_offset, uint levels, uint size0,
                           __global const float4* targets, uint target_count,
                           __global const float* u1, __global const float* u2, uint points_per_replicate, uint replicates,
                           float total_samples, float lod_bias, int filtered, __global float* out)
{
    const uint g = get_global_id(0);
    if (g >= target_count * replicates) return;
    const uint k = g / replicates, r = g % replicates;
    const float4 tg = targets[k];
    const float3 n = (float3)(tg.x, tg.y, tg.z);
    const float alpha = tg.w * tg.w, a2 = alpha * alpha;
    /* Orthonormal basis around n (Duff et al. 2017). */
    const float sign = copysign(1.0f, n.z);
    const float fa = -1.0f / (sign + n.z), fb = n.x * n.y * fa;
    const float3 tx = (float3)(1.0f + sign * n.x * n.x * fa, sign * fb, -sign * n.x);
    const float3 ty = (float3)(fb, sign + n.y * n.y * fa, -n.y);
    const float omega_p = 4.0f / ((float)size0 * (float)size0);
    float3 num = (float3)(0.0f);
    float den = 0.0f;
    const uint first = r * points_per_replicate;
    for (uint i = first; i < first + points_per_replicate; ++i) {
        const float v1 = u1[i], v2 = u2[i];
        const float c2 = (1.0f - v2) / (1.0f + (a2 - 1.0f) * v2);
        const float nl = 2.0f * c2 - 1.0f;
        if (nl <= 0.0f) continue;
        const float c = sqrt(c2), s = sqrt(max(0.0f, 1.0f - c2));
        float sp, cp;
        sp = sincos(6.28318530717958648f * v1, &cp);
        const float3 l = (2.0f * c * s * cp) * tx + (2.0f * c * s * sp) * ty + nl * n;
        float3 v;
        if (filtered) {
            float fs, ft;
            (void)ms_cube_face_st(l, &fs, &ft);
            const float q = 1.0f + fs * fs + ft * ft;
            const float omega_l = omega_p / (q * sqrt(q));
            const float dd = (a2 - 1.0f) * c2 + 1.0f;
            const float pdf = a2 / (3.14159265358979324f * dd * dd) * 0.25f;
            const float lod = clamp(0.5f * log2(1.0f / (total_samples * pdf) / omega_l) + lod_bias, 0.0f, (float)(levels - 1));
            const uint l0 = (uint)floor(lod);
            const float f = lod - (float)l0;
            v = pf_bilinear(chain, level_offset[l0], size0 >> l0, l);
            if (f > 0.0f && l0 + 1 < levels)
                v = (1.0f - f) * v + f * pf_bilinear(chain, level_offset[l0 + 1], size0 >> (l0 + 1), l);
        } else {
            v = pf_bilinear(chain, level_offset[0], size0, l);
        }
        num += nl * v;
        den += nl;
    }
    __global float* o = out + (size_t)g * 4;
    o[0] = num.x;
    o[1] = num.y;
    o[2] = num.z;
    o[3] = den;
}
