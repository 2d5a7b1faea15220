/*
 * bake_lut.cl - one (roughness, NdotV) slice of a micro-shadowing LUT from one shared VNDF pass.
 *
 * Estimator (the per-query form is derived in generic_term.cl: the Smith weight cancels and the term
 * is P(wm.wg > c and wm.wo > c) / P(wm.wg > 0 and wm.wo > 0) over visible normals wm ~ D_wi).
 * For a fixed (alpha, wi, wo) write t = min(wm.wg, wm.wo) for a unit wm. Then
 *     numerator(c) = P(t > c)  for every cone cosine c in [0, 1),   denominator = P(t > 0),
 * so the numerator over all visibility texels of a LUT row is the complementary CDF of t: one pass
 * over the samples, each sample binned once, gives every texel of the row.
 * Binning: texel j (visibility v_j) is passed when t > cos_t(v_j). With cosine-weighted AO,
 * cos_t = sqrt(1 - v) and, for t > 0, t > sqrt(1 - v_j) <=> v_j > 1 - t^2; with uniform-weighted AO,
 * cos_t = 1 - v and t > 1 - v_j <=> v_j > 1 - t. Both read v_j > u with u = 1 - t^2 or 1 - t, and
 * v_j = vis_min + (j + offset) / scale increases with j, so the passed texels are exactly
 * j >= j0 = floor((u - vis_min) * scale - offset) + 1 (clamped to [0, nv]). Each hemisphere sample adds
 * 1 to bin j0 (bin nv: passes no texel), non-hemisphere samples go to a discarded bin nv + 1; the
 * prefix sum over bins 0..j is then the cone count of texel j and the sum over 0..nv the hemisphere count.
 *
 * Work split: ms_bake_normals turns the slice's points into unit normals once (the sampler costs
 * more than one direction's binning); ms_bake_histogram gives every (direction, replicate) pair its own
 * work-item, which reads the normals in float16 blocks, bins them with vector arithmetic and scatters
 * into a per-work-item histogram in global scratch memory (private to the work-item, so no atomics).
 */
#include "microshadow_shared.h"

/* cos(2 pi u) and sin(2 pi u), u in [0, 1): as generic_term.cl (quadrant + degree 7/8 Taylor, 3e-7). */
inline void sincos_turns16(float16 u, float16* sin_out, float16* cos_out)
{
    const float16 t = u * 4.0f;
    const int16 q = convert_int16(t + 0.5f);
    const float16 a = (t - convert_float16(q)) * 1.57079632679489662f;
    const float16 a2 = a * a;
    const float16 sa = a * (1.0f + a2 * (-1.0f / 6.0f + a2 * (1.0f / 120.0f + a2 * (-1.0f / 5040.0f))));
    const float16 ca = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24.0f + a2 * (-1.0f / 720.0f + a2 * (1.0f / 40320.0f))));
    const int16 quadrant = q & 3;
    const int16 odd = (quadrant & 1) != 0;
    const float16 c = select(ca, sa, odd);
    const float16 s = select(sa, ca, odd);
    *cos_out = select(c, -c, (quadrant == 1) | (quadrant == 2));
    *sin_out = select(s, -s, quadrant >= 2);
}

/*
 * One work-item per block of MS_LANES points (all replicates, replicate-major like the point set):
 * spherical-cap VNDF sample (Dupuy & Benyoub 2023) normalised to a unit normal.
 */
__kernel void ms_bake_normals(const ms_bake_slice p, __global const float* u1, __global const float* u2,
                              __global float* nx, __global float* ny, __global float* nz)
{
    const uint block = get_global_id(0);
    if (block >= p.points / MS_LANES * p.replicates) return;
    const uint i = block * MS_LANES;
    float3 wi_std = (float3)(p.alpha_x * p.wi_x, p.alpha_y * p.wi_y, p.wi_z);
    wi_std *= rsqrt(dot(wi_std, wi_std));

    const float16 r1 = vload16(0, u1 + i);
    const float16 r2 = vload16(0, u2 + i);
    float16 sin_phi, cos_phi;
    sincos_turns16(r1, &sin_phi, &cos_phi);
    const float16 z = mad(1.0f - r2, 1.0f + wi_std.z, -wi_std.z);
    const float16 s = sqrt(max(1.0f - z * z, 0.0f));
    const float16 mx = p.alpha_x * mad(s, cos_phi, wi_std.x);
    const float16 my = p.alpha_y * mad(s, sin_phi, wi_std.y);
    const float16 mz = z + wi_std.z;
    /* A division by the vector sqrt vectorises; the rsqrt builtin stays scalar on PoCL. */
    const float16 inv = 1.0f / sqrt(mad(mx, mx, mad(my, my, mz * mz)));
    vstore16(mx * inv, 0, nx + i);
    vstore16(my * inv, 0, ny + i);
    vstore16(mz * inv, 0, nz + i);
}

/*
 * Global id g = direction * replicates + replicate. Writes counts[g * (nv + 1) + j] = cone count of
 * texel j (j < nv) and counts[g * (nv + 1) + nv] = hemisphere count. scratch holds
 * MS_BAKE_SUBHISTOGRAMS * (nv + 2) uints per work-item.
 */
__kernel void ms_bake_histogram(const ms_bake_slice p, __global const float4* wo,
                                __global const float* nx, __global const float* ny, __global const float* nz,
                                __global uint* scratch, __global uint* counts)
{
    const uint g = get_global_id(0);
    if (g >= p.directions * p.replicates) return;
    const uint direction = g / p.replicates;
    const uint replicate = g % p.replicates;
    const uint nv = p.texels;
    const uint stride = nv + 2;
    __global uint* hist = scratch + (size_t)g * (MS_BAKE_SUBHISTOGRAMS * stride);
    for (uint k = 0; k < MS_BAKE_SUBHISTOGRAMS * stride; ++k) hist[k] = 0u;

    const float4 l = wo[direction];
    const int16 lane_copy = (int16)(0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3) * (int)stride;
    const uint first = replicate * p.points;
    for (uint i = first; i < first + p.points; i += MS_LANES) {
        const float16 mz = vload16(0, nz + i);
        const float16 m_dot_l = mad(vload16(0, nx + i), l.x, mad(vload16(0, ny + i), l.y, mz * l.z));
        const float16 t = fmin(mz, m_dot_l);
        const float16 u = p.ao_weighting == MS_AO_COSINE ? 1.0f - t * t : 1.0f - t;
        const float16 x = mad(u - p.vis_min, p.bin_scale, -p.bin_offset);
        /* Clamp in float first so the conversion never overflows; j0 in [0, nv]. After the clamp
         * x + 1 >= 0, where truncation equals floor: convert_int16 vectorises, the floor builtin
         * stays scalar on PoCL. */
        int16 bin = convert_int16(clamp(x, -1.0f, (float)nv) + 1.0f);
        bin = min(bin, (int)nv);
        bin = select((int16)(nv + 1), bin, t > 0.0f); /* outside the hemisphere: discarded bin */
        int lanes[MS_LANES];
        vstore16(bin + lane_copy, 0, lanes);
        for (int k = 0; k < MS_LANES; ++k) hist[lanes[k]] += 1u;
    }

    __global uint* out = counts + (size_t)g * (nv + 1);
    uint running = 0;
    for (uint j = 0; j <= nv; ++j) {
        for (uint c = 0; c < MS_BAKE_SUBHISTOGRAMS; ++c) running += hist[c * stride + j];
        out[j] = running; /* j == nv: every hemisphere sample */
    }
}
