/*
 * naive_term.cl - a deliberately plain version of kernels/generic_term.cl, for the benchmarks only.
 *
 * Same estimator (ratio of cone to hemisphere counts over spherical-cap VNDF samples, see the derivation
 * in kernels/generic_term.cl) written the obvious way: one point at a time, builtin sin/cos, normalize
 * and clamped dot products, float sums. It shows what the vectorised kernel gains on PoCL's CPU device,
 * where the builtins stay scalar calls. Loaded from source by bench/throughput.cpp, never shipped.
 */
#include "microshadow_shared.h"

__kernel void ms_naive_tally(__global const ms_query* queries, uint query_count, __global const float* u1,
                             __global const float* u2, uint points_per_replicate, uint replicates, uint chunks,
                             __global float2* sums)
{
    const uint g = get_global_id(0);
    if (g >= query_count * replicates * chunks) return;
    const uint chunk = g % chunks;
    const uint replicate = (g / chunks) % replicates;
    const ms_query q = queries[g / (chunks * replicates)];
    const uint per_chunk = points_per_replicate / chunks;
    const uint first = replicate * points_per_replicate + chunk * per_chunk;

    const float3 wi_std = normalize((float3)(q.alpha_x * q.wi_x, q.alpha_y * q.wi_y, q.wi_z));
    const float3 wo = (float3)(q.wo_x, q.wo_y, q.wo_z);
    float cone = 0.0f, hemisphere = 0.0f;
    for (uint i = first; i < first + per_chunk; ++i) {
        const float phi = 2.0f * M_PI_F * u1[i];
        const float z = (1.0f - u2[i]) * (1.0f + wi_std.z) - wi_std.z;
        const float s = sqrt(clamp(1.0f - z * z, 0.0f, 1.0f));
        const float3 h = (float3)(s * cos(phi), s * sin(phi), z) + wi_std;
        const float3 wm = normalize((float3)(q.alpha_x * h.x, q.alpha_y * h.y, h.z));
        const float n_dot_m = clamp(wm.z, 0.0f, 1.0f);
        const float m_dot_l = clamp(dot(wm, wo), 0.0f, 1.0f);
        const float up = (n_dot_m > 0.0f && m_dot_l > 0.0f) ? 1.0f : 0.0f;
        hemisphere += up;
        cone += (n_dot_m > q.cos_theta && m_dot_l > q.cos_theta) ? up : 0.0f;
    }
    sums[g] = (float2)(cone, hemisphere);
}
