/*
 * irradiance.cl - the irradiance of a cubemap by direct convolution with the clamped cosine:
 *     E(n) = integral L(l) max(0, n.l) dl = sum over texels T of L_T * integral_T max(0, n.l) dl,
 * exact for the (reduced) source read as piecewise constant per texel.
 *
 * The texel integral. For a spherical polygon P with great-circle edges (a cube texel's edges are straight
 * lines on its face plane, so great circles on the sphere), Lambert's formula gives the vector solid angle
 *     W_P = integral_P l dl = 1/2 sum_edges theta_e u_e,   u_e = normalize(a x b), theta_e = angle(a, b),
 * for vertices a -> b counter-clockwise seen from outside. A texel wholly above the horizon (inside the cap
 * of radius rho_T around W_T, n.W_T / |W_T| >= sin rho_T) contributes n.W_T, with W_T computed once on the
 * host in double; one wholly below contributes 0; one the horizon crosses is clipped to n.l >= 0 (its
 * corners above, plus normalize(d_a b - d_b a) / (d_a - d_b) where an edge crosses, d = n.corner, a point
 * of the edge's arc on the horizon) and integrated by the same formula with n: 1/2 sum theta_e n.u_e.
 *
 * Error. The host reduced the source by solid-angle means; spread_T = diameter_T * deviation_T bounds what
 * that costs for every texel that reaches above the horizon (host/env/irradiance.hpp derives it), so the
 * work-item also sums the bound. Rounding: the sums are compensated (Kahan); the rounding scale (L_T n.W_T
 * for whole texels, L_T diameter_T for clipped ones, whose Lambert terms cancel) goes to the host, which
 * turns it into an allowance (irradiance_integrand.hpp, kRoundingUnits).
 *
 * One work-item per output direction. Written on its own: the oracle (host/env/irradiance.cpp) integrates
 * in the face plane by antiderivatives and Green's theorem, not by Lambert's formula.
 */
/* Preamble (prepended by the host): common/microshadow_shared.h, real.cl, sincos.cl, vndf.cl, cone.cl,
 * work_items.cl, cubemap.cl (ms_cube_direction). */

inline float ir_clipped_texel(float3 n, int face, uint x, uint y, uint size)
{
    const float step = 2.0f / (float)size;
    const float s0 = (float)x * step - 1.0f, s1 = (float)(x + 1u) * step - 1.0f;
    const float t0 = (float)y * step - 1.0f, t1 = (float)(y + 1u) * step - 1.0f;
    float3 c[4];
    c[0] = ms_cube_direction(face, s0, t0);
    c[1] = ms_cube_direction(face, s1, t0);
    c[2] = ms_cube_direction(face, s1, t1);
    c[3] = ms_cube_direction(face, s0, t1);
    /* The corners run +s then +t; whether that is counter-clockwise seen from outside depends on the face. */
    const float orient = dot(cross(c[1] - c[0], c[3] - c[0]), c[0]) > 0.0f ? 1.0f : -1.0f;
    float3 p[5];
    int m = 0;
    for (int i = 0; i < 4; ++i) {
        const int j = (i + 1) & 3;
        const float da = dot(n, c[i]), db = dot(n, c[j]);
        if (da >= 0.0f) p[m++] = c[i];
        if ((da >= 0.0f) != (db >= 0.0f)) p[m++] = normalize((da * c[j] - db * c[i]) / (da - db));
    }
    if (m < 3) return 0.0f;
    float sum = 0.0f;
    for (int i = 0; i < m; ++i) {
        const float3 a = p[i], b = p[i + 1 < m ? i + 1 : 0];
        const float3 ab = cross(a, b);
        const float len = length(ab);
        if (len > 0.0f) sum += atan2(len, dot(a, b)) * dot(n, ab) / len;
    }
    return 0.5f * orient * sum;
}

/* Compensated (Kahan) accumulation of three channels. */
inline void ir_add(float3* sum, float3* carry, float3 term)
{
    const float3 y = term - *carry;
    const float3 t = *sum + y;
    *carry = (t - *sum) - y;
    *sum = t;
}

/*
 * vector[T] = (W_T, |W_T| sin rho_T), radiance[T] = (L_T, 0), spread[T] = (diameter_T * deviation_T, diameter_T),
 * T = (face * size + y) * size + x. targets[k].xyz = n (unit). out[k * 12 + ...]: 0-2 E, 4-6 the reduction's
 * bound, 8-10 the rounding scale.
 */
__kernel void ms_irradiance(__global const float4* vector, __global const float4* radiance, __global const float4* spread, uint size,
                            __global const float4* targets, uint target_count, __global float* out)
{
    const uint g = get_global_id(0);
    if (g >= target_count) return;
    const float3 n = targets[g].xyz;
    const uint per_face = size * size, texels = 6u * per_face;
    float3 e = (float3)(0.0f), e_carry = (float3)(0.0f);
    float3 bound = (float3)(0.0f), bound_carry = (float3)(0.0f);
    float3 scale = (float3)(0.0f), scale_carry = (float3)(0.0f);
    for (uint i = 0; i < texels; ++i) {
        const float4 w = vector[i];
        const float nw = dot(n, w.xyz);
        if (nw <= -w.w) continue; /* wholly below the horizon: max(0, n.l) = 0 on it */
        const float3 l = radiance[i].xyz;
        const float4 sp = spread[i];
        float k;
        float3 sc;
        if (nw >= w.w) {
            k = nw;
            sc = l * nw;
        } else {
            const uint face = i / per_face, r = i - face * per_face, y = r / size;
            k = ir_clipped_texel(n, (int)face, r - y * size, y, size);
            sc = l * sp.w;
        }
        ir_add(&e, &e_carry, l * k);
        ir_add(&bound, &bound_carry, sp.xyz);
        ir_add(&scale, &scale_carry, sc);
    }
    __global float* o = out + (size_t)g * 12;
    o[0] = e.x;
    o[1] = e.y;
    o[2] = e.z;
    o[3] = 0.0f;
    o[4] = bound.x;
    o[5] = bound.y;
    o[6] = bound.z;
    o[7] = 0.0f;
    o[8] = scale.x;
    o[9] = scale.y;
    o[10] = scale.z;
    o[11] = 0.0f;
}
