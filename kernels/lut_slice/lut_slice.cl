/*
 * lut_slice.cl - one (roughness, NdotV) slice of a micro-shadowing LUT from one shared VNDF pass.
 *
 * Estimator (the per-query form is derived in term/generic_term.cl: the Smith weight cancels and the
 * term is P(m in both cones) / P(m.wg > 0 and m.wo > 0) over visible normals m ~ D_wi).
 * For a fixed (alpha, wi, wo) give every unit m with m.z > 0 and m.wo > 0 the sine key of
 * common/cone.cl: u = sin^2 of the larger of angle(m, z) and angle(m, wo). m passes the cone of
 * visibility v exactly when u < sin^2_t(v) (cosine AO: v; uniform AO: the key is mapped to 1 - t), so
 *     numerator(v) = P(u < v)  for every visibility v,   denominator = P(m.z > 0 and m.wo > 0),
 * and the numerator over all visibility texels of a LUT row is a CDF of u: one pass over the samples,
 * each sample binned once, gives every texel of the row.
 * Binning: v_j = vis_min + (j + offset) / scale increases with j, so the texels a sample passes are
 * exactly j >= j0 = floor((u - vis_min) * scale - offset) + 1 (clamped to [0, nv]). Each hemisphere
 * sample adds 1 to bin j0 (bin nv: passes no texel), non-hemisphere samples go to a discarded bin
 * nv + 1; the prefix sum over bins 0..j is then the cone count of texel j and the sum over 0..nv the
 * hemisphere count. The sine key keeps tiny cones (visibility 1e-7) resolved in float, where the
 * former key 1 - t^2 rounded to multiples of 6e-8.
 *
 * Work split: ms_bake_normals turns the slice's points into unit normals once (the sampler costs
 * more than one direction's binning); ms_bake_histogram gives every (direction, replicate) pair its own
 * work-item, which reads the normals in sixteen-lane blocks, bins them with vector arithmetic and
 * scatters into a per-work-item histogram in global scratch memory (private to the work-item, no atomics).
 *
 * Azimuth-stratified bakes (p.cell_points > 0, host/integrands/lut_slice/azimuth_quadrature.hpp): each
 * replicate's points are stored cell-major (cell c: points [c cell_points, (c + 1) cell_points)), a
 * direction is one (row, cell) light at the cell's midpoint azimuth, wo.w holds its cell index, and its
 * work-item bins only that cell's points: every sample is binned once per row instead of once per node.
 *
 * Preamble (prepended by the host, device/runtime.cpp): common/microshadow_shared.h, real.cl,
 * sincos.cl, vndf.cl, cone.cl.
 */

/* One work-item per block of MS_LANES points (all replicates, replicate-major like the point set). */
__kernel void ms_bake_normals(const ms_bake_slice p, __global const float* u1, __global const float* u2,
                              __global real* nx, __global real* ny, __global real* nz)
{
    const uint block = get_global_id(0);
    if (block >= p.points / MS_LANES * p.replicates) return;
    const uint i = block * MS_LANES;
    const real ax = p.alpha_x, ay = p.alpha_y;
    const real3 wi_std = vndf_stretched_view(ax, ay, (real3)(p.wi_x, p.wi_y, p.wi_z));
    real16 mx, my, mz;
    vndf_sample16(wi_std, ax, ay, convert_real16(vload16(0, u1 + i)), convert_real16(vload16(0, u2 + i)), &mx, &my, &mz);
    /* A division by the vector sqrt vectorises; the rsqrt builtin stays scalar on PoCL. */
    const real16 inv = MS_R(1.0) / sqrt(fma(mx, mx, fma(my, my, mz * mz)));
    vstore16(mx * inv, 0, nx + i);
    vstore16(my * inv, 0, ny + i);
    vstore16(mz * inv, 0, nz + i);
}

/*
 * Global id g = direction * replicates + replicate (the direction's points: all of the replicate, or
 * the cell wo[direction].w of it when p.cell_points > 0). Writes counts[g * (nv + 1) + j] = cone count of
 * texel j (j < nv) and counts[g * (nv + 1) + nv] = hemisphere count. scratch holds
 * MS_BAKE_SUBHISTOGRAMS * (nv + 2) uints per work-item.
 */
__kernel void ms_bake_histogram(const ms_bake_slice p, __global const float4* wo,
                                __global const real* nx, __global const real* ny, __global const real* nz,
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

    const float4 lf = wo[direction];
    const real3 l = (real3)(lf.x, lf.y, lf.z);
    const real vis_min = p.vis_min, bin_scale = p.bin_scale, bin_offset = p.bin_offset;
    /* Consecutive lanes go to different sub-histograms (see MS_BAKE_SUBHISTOGRAMS). */
    const int16 lane_copy = (int16)(0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3) * (int)stride;
    const uint count = p.cell_points ? p.cell_points : p.points;
    const uint first = replicate * p.points + (uint)lf.w * count;
    for (uint i = first; i < first + count; i += MS_LANES) {
        const real16 mx = vload16(0, nx + i), my = vload16(0, ny + i), mz = vload16(0, nz + i);
        const real16 m_dot_l = fma(mx, l.x, fma(my, l.y, mz * l.z));
        const real16 t = fmin(mz, m_dot_l);
        const real16 key = cone_sine_key16(mx, my, mz, l);
        const real16 u = p.ao_weighting == MS_AO_COSINE ? key : key / (MS_R(1.0) + t);
        const real16 x = fma(u - vis_min, bin_scale, -bin_offset);
        /* Clamp first so the conversion never overflows; j0 in [0, nv]. After the clamp x + 1 >= 0,
         * where truncation equals floor: convert_int16 vectorises, the floor builtin stays scalar. */
        int16 bin = convert_int16(clamp(x, MS_R(-1.0), (real)nv) + MS_R(1.0));
        bin = min(bin, (int)nv);
        bin = select((int16)(nv + 1), bin, convert_int16(t > MS_R(0.0)) != 0); /* outside the hemisphere: discarded */
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
