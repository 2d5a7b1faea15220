// The scalar double-precision oracle of the generic VNDF-based micro-shadowing term (part 2).
//
// Written plainly and independently of the OpenCL kernels: it keeps every factor of GenericM_m
// (both Heavisides of both conditions and the Smith weight G2/G1 of the chosen form), evaluates the
// spherical-cap VNDF sampler with libm's trigonometry, and sums in double. The kernels drop the weight
// (it cancels in the ratio, see kernels/generic_term.cl), so agreement between the two checks that
// derivation as well as the code. Nothing here includes OpenCL.
#pragma once

#include <vector>

#include "core/types.hpp"
#include "sampling/point_set.hpp"

namespace ms::oracle {

// Cosine of the visibility cone half-angle: sqrt(1 - v) (cosine-weighted AO) or 1 - v (uniform).
double cone_cos_theta(double visibility, AoWeighting weighting);

// Roughness projected onto direction w (anisotropic GGX is a stretched isotropic one):
// alpha_w = sqrt(ax^2 cos^2 phi + ay^2 sin^2 phi), phi the azimuth of w.
double projected_alpha(const Vec3& w, double alpha_x, double alpha_y);
// Smith Lambda of GGX through the projected roughness: (-1 + sqrt(1 + alpha_w^2 tan^2 theta)) / 2.
double smith_lambda(const Vec3& w, double alpha_x, double alpha_y);
// Smith Lambda of anisotropic GGX written directly, (-1 + sqrt(1 + (ax^2 x^2 + ay^2 y^2) / z^2)) / 2,
// kept apart so a test can show the projection equals it.
double smith_lambda_anisotropic(const Vec3& w, double alpha_x, double alpha_y);
// Masking G1(w, wm) = H(w.wm) / (1 + Lambda(w)); 0 for w at or below the horizon.
double smith_g1(const Vec3& w, const Vec3& wm, double alpha_x, double alpha_y);
// G2(wi,wo,wm) / G1(wi,wm) in the chosen Smith form.
double sample_weight(Form form, const Vec3& wi, const Vec3& wo, const Vec3& wm, double alpha_x, double alpha_y);

// Anisotropic GGX NDF D(wm), and the VNDF D_wi(wm) = G1(wi,wm) <wi.wm> D(wm) / (wi.wg).
double ggx_ndf(const Vec3& wm, double alpha_x, double alpha_y);
double vndf_pdf(const Vec3& wi, const Vec3& wm, double alpha_x, double alpha_y);
// Dupuy & Benyoub 2023 spherical-cap VNDF sampler; u1, u2 in [0, 1).
Vec3 sample_vndf(const Vec3& wi, double alpha_x, double alpha_y, double u1, double u2);

// GenericM_m for one microfacet wm: the cone term, the hemisphere term (cos_theta = 0) and the weight.
struct MicrofacetTerm {
    double cone = 0;
    double hemisphere = 0;
    double weight = 0;
};
MicrofacetTerm generic_m_m(double cos_theta, const Vec3& wm, const Vec3& wo, const Vec3& wi, double alpha_x,
                           double alpha_y, Form form);

// Per-replicate sums of the cone and hemisphere terms of one query over a point set.
struct Tally {
    std::vector<double> cone, hemisphere;  // one entry per replicate
    // How many samples had a non-zero cone / hemisphere term (the weights are positive there): with
    // these a caller can bound the term when no sample (or every sample) passed the cone.
    std::vector<double> cone_count, hemisphere_count;
};
Tally tally(const Query& q, const TermOptions& opt, const PointSet& points);

// GenericM_g = sum(cone) / sum(hemisphere) with its standard error (reduce_replicates), 0 where the
// hemisphere sum is 0. Never NaN for valid input (unit wi with wi.z > 0, unit wo, alpha > 0).
Estimate generic_m_g(const Query& q, const TermOptions& opt, const PointSet& points);

// Part 1's reference: step(cos_theta, NdotL), the alpha -> 0 limit of GenericM_g.
double reference_step(double visibility, double n_dot_l, AoWeighting weighting);

}  // namespace ms::oracle
