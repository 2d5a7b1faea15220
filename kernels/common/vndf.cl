/*
 * vndf.cl - the spherical-cap sampler of visible GGX normals (Dupuy & Benyoub 2023), sixteen lanes.
 *
 * Stretch wi into the isotropic configuration (wi_std = normalize(ax wi.x, ay wi.y, wi.z)), sample the
 * spherical cap z in [-wi_std.z, 1] uniformly with phi = 2 pi u1, add wi_std and unstretch. The result
 * m = (ax h.x, ay h.y, h.z) is left unnormalised: callers whose tests are homogeneous in m skip the
 * sqrt and the division; the others normalise it themselves.
 * fma, not mad: PoCL 3.1 lowers mad to a separate multiply and add, ~10 more instructions a block.
 */
inline real3 vndf_stretched_view(real alpha_x, real alpha_y, real3 wi)
{
    real3 wi_std = (real3)(alpha_x * wi.x, alpha_y * wi.y, wi.z);
    return wi_std * rsqrt(dot(wi_std, wi_std));
}

inline void vndf_sample16(real3 wi_std, real alpha_x, real alpha_y, real16 u1, real16 u2,
                          real16* mx, real16* my, real16* mz)
{
    real16 sin_phi, cos_phi;
    sincos_turns16(u1, &sin_phi, &cos_phi);
    const real16 z = fma(MS_R(1.0) - u2, MS_R(1.0) + wi_std.z, -wi_std.z);
    const real16 s = sqrt(max(MS_R(1.0) - z * z, MS_R(0.0)));
    *mx = alpha_x * fma(s, cos_phi, wi_std.x);
    *my = alpha_y * fma(s, sin_phi, wi_std.y);
    *mz = z + wi_std.z;
}
