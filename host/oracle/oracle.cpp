// The scalar double-precision oracle of the generic VNDF-based micro-shadowing term (part 2).
//
// Estimator. Part 2 defines, for a visibility cone of half-angle theta around wg = (0,0,1),
//
//     GenericM_g = Int GenericM_m(cos_t, wm) D_wi(wm) dwm / Int GenericM_m(0, wm) D_wi(wm) dwm,
//     GenericM_m(c, wm) = H(<wg.wm> - c) H(<wm.wo> - c) G2(wi,wo,wm) / G1(wi,wm),
//
// where D_wi is the distribution of visible normals seen from wi (the seed writes the integrals over
// dwm with the VNDF implied by "wm comes from VNDF sampling"). Drawing wm_k ~ D_wi with the spherical-
// cap sampler turns both integrals into plain averages over the same samples, and their quotient is
// the ratio estimator
//
//     GenericM_g ~= sum_k GenericM_m(cos_t, wm_k) / sum_k GenericM_m(0, wm_k).
//
// It is consistent (not unbiased for finite n, the bias is O(1/n) and far below the error bar). The
// point set holds R independent randomisations (replicates); tally() keeps one (cone, hemisphere)
// pair of sums per replicate and reduce_replicates() pools them into the estimate and derives the
// standard error from the spread of the per-replicate ratios.
//
// This file deliberately keeps everything the kernels simplify away: the weight G2/G1 of the chosen
// Smith form (it cancels in the ratio, which the tests show on this code), both Heavisides of both
// conditions with the clamped dot products, normalised vectors, libm trigonometry and double sums
// (compensated, so that sums of 2^20 terms keep ~1e-16 relative accuracy). It shares no code with
// host/core/cone.hpp or the kernels, so one mistake cannot pass both.
#include "oracle/oracle.hpp"

#include "core/cancel.hpp"

#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>

#include "core/estimate.hpp"

namespace ms::oracle {

namespace {

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
// <a.b> of the seeds: the dot product clamped to [0, 1].
double clamped_dot(const Vec3& a, const Vec3& b) { return std::fmin(std::fmax(dot(a, b), 0.0), 1.0); }
// chi+ of the seeds: 1 when a > 0, 0 when a <= 0 (so a Heaviside of exactly 0 is 0).
double heaviside(double a) { return a > 0 ? 1.0 : 0.0; }
Vec3 normalize(const Vec3& v) {
    const double inv = 1.0 / std::sqrt(dot(v, v));
    return {v.x * inv, v.y * inv, v.z * inv};
}

// (-1 + sqrt(1 + a)) / 2 for a = alpha_w^2 tan^2 theta >= 0, written as a / (2 (1 + sqrt(1 + a))):
// algebraically the same, but without the cancellation that loses every digit when a is tiny
// (directions near the normal or small roughness), so the two Lambda forms can be compared to ulps.
// a = +inf (w.z^2 underflowed to 0 for a grazing but valid direction) is Lambda = +inf, G1 = 0:
// returned explicitly because the quotient would be inf / inf = NaN.
double lambda_from_a(double a) {
    if (std::isinf(a)) return std::numeric_limits<double>::infinity();
    return a / (2.0 * (1.0 + std::sqrt(1.0 + a)));
}

// Neumaier's compensated sum: the replicates' sums are the oracle's output, keep them exact to ~1 ulp.
struct CompensatedSum {
    double sum = 0, c = 0;
    void add(double x) {
        const double t = sum + x;
        c += std::fabs(sum) >= std::fabs(x) ? (sum - t) + x : (x - t) + sum;
        sum = t;
    }
    double value() const { return sum + c; }
};

}  // namespace

double cone_cos_theta(double visibility, AoWeighting weighting) {
    if (!(visibility >= 0 && visibility <= 1))
        throw std::invalid_argument("oracle: visibility must be in [0, 1]");
    // Part 1: a cosine-weighted AO bake measures the cone's projected solid angle, sin^2 theta = v;
    // a uniform-weighted one its solid angle over 2 pi, 1 - cos theta = v.
    return weighting == AoWeighting::cosine ? std::sqrt(1.0 - visibility) : 1.0 - visibility;
}

double projected_alpha(const Vec3& w, double alpha_x, double alpha_y) {
    // The azimuth of w; atan2 gives 0 for w along the normal, where tan theta = 0 makes it irrelevant.
    const double phi = std::atan2(w.y, w.x);
    const double c = std::cos(phi), s = std::sin(phi);
    return std::sqrt(alpha_x * alpha_x * c * c + alpha_y * alpha_y * s * s);
}

double smith_lambda(const Vec3& w, double alpha_x, double alpha_y) {
    // At or below the horizon tan theta is infinite (or meaningless): Lambda = +inf, so G1 = 0.
    if (!(w.z > 0)) return std::numeric_limits<double>::infinity();
    const double alpha_w = projected_alpha(w, alpha_x, alpha_y);
    const double tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
    return lambda_from_a(alpha_w * alpha_w * tan2);
}

double smith_lambda_anisotropic(const Vec3& w, double alpha_x, double alpha_y) {
    if (!(w.z > 0)) return std::numeric_limits<double>::infinity();
    const double a = (alpha_x * alpha_x * w.x * w.x + alpha_y * alpha_y * w.y * w.y) / (w.z * w.z);
    return lambda_from_a(a);
}

double smith_g1(const Vec3& w, const Vec3& wm, double alpha_x, double alpha_y) {
    // docs/method.md: 0 for w at or below the horizon; checked before Lambda so no inf/inf can appear.
    if (!(w.z > 0)) return 0.0;
    return heaviside(dot(w, wm)) / (1.0 + smith_lambda(w, alpha_x, alpha_y));
}

double sample_weight(Form form, const Vec3& wi, const Vec3& wo, const Vec3& wm, double alpha_x, double alpha_y) {
    const double g1o = smith_g1(wo, wm, alpha_x, alpha_y);
    // wo above the horizon and facing wm, but so grazing (wo.z below ~1e-155) that tan^2 theta overflows and
    // G1(wo) = 1 / (1 + Lambda_o) rounds to 0. Every sampled normal's weight then carries that same factor
    // (both forms tend to G1o times a constant: G1o, or G1o / G1i with G1i fixed by wi for the visible
    // normals sampled), and the term is a ratio of two sums of these weights: the factor cancels, so the
    // limit weight is 1. Without this every weight was 0 and the term 0 / 0 = 0 (the limit is ~0.64).
    if (g1o == 0 && wo.z > 0 && dot(wo, wm) > 0 && std::isinf(smith_lambda(wo, alpha_x, alpha_y))) return 1.0;
    // Both forms are proportional to G1o; returning 0 here also keeps the height-correlated quotient
    // away from 0/0 when wm is invisible from both directions.
    if (g1o == 0) return 0.0;
    if (form == Form::uncorrelated) return g1o;
    const double g1i = smith_g1(wi, wm, alpha_x, alpha_y);
    // G2/G1i = G1o / (G1o + G1i - G1o G1i) (part 2's table). Denominator >= G1o > 0 since G1i <= 1.
    return g1o / (g1o + g1i - g1o * g1i);
}

double ggx_ndf(const Vec3& wm, double alpha_x, double alpha_y) {
    // D is supported on the upper hemisphere of normals (chi+(wm.wg) of Heitz 2014).
    if (!(wm.z > 0)) return 0.0;
    const double ex = wm.x / alpha_x, ey = wm.y / alpha_y;
    const double d = ex * ex + ey * ey + wm.z * wm.z;
    return 1.0 / (kPi * alpha_x * alpha_y * d * d);
}

double vndf_pdf(const Vec3& wi, const Vec3& wm, double alpha_x, double alpha_y) {
    // D_wi(wm) = G1(wi,wm) <wi.wm> D(wm) / |wi.wg|; only defined for wi above the horizon.
    if (!(wi.z > 0)) return 0.0;
    return smith_g1(wi, wm, alpha_x, alpha_y) * clamped_dot(wi, wm) * ggx_ndf(wm, alpha_x, alpha_y) / wi.z;
}

Vec3 sample_vndf(const Vec3& wi, double alpha_x, double alpha_y, double u1, double u2) {
    // Dupuy & Benyoub 2023. Stretch wi into the configuration where the microsurface is the isotropic
    // alpha = 1 GGX (a hemisphere of normals); there the visible normals are distributed like
    // wi_std + c, c uniform on the spherical cap z >= -wi_std.z of the unit sphere.
    const Vec3 wi_std = normalize({alpha_x * wi.x, alpha_y * wi.y, wi.z});
    const double phi = 2.0 * kPi * u1;
    const double z = (1.0 - u2) * (1.0 + wi_std.z) - wi_std.z;  // uniform in [-wi_std.z, 1]
    const double s = std::sqrt(std::fmin(std::fmax(1.0 - z * z, 0.0), 1.0));
    const Vec3 h{s * std::cos(phi) + wi_std.x, s * std::sin(phi) + wi_std.y, z + wi_std.z};
    // Normals transform with the inverse transpose of the stretch: unstretch and renormalise.
    return normalize({alpha_x * h.x, alpha_y * h.y, h.z});
}

MicrofacetTerm generic_m_m(double cos_theta, const Vec3& wm, const Vec3& wo, const Vec3& wi, double alpha_x,
                           double alpha_y, Form form) {
    const Vec3 wg{0, 0, 1};
    const double n_dot_m = clamped_dot(wg, wm);
    const double m_dot_l = clamped_dot(wm, wo);
    MicrofacetTerm t;
    t.weight = sample_weight(form, wi, wo, wm, alpha_x, alpha_y);
    t.hemisphere = heaviside(n_dot_m) * heaviside(m_dot_l) * t.weight;
    t.cone = heaviside(n_dot_m - cos_theta) * heaviside(m_dot_l - cos_theta) * t.weight;
    return t;
}

Tally tally(const Query& q, const TermOptions& opt, const PointSet& points) {
    if (!(q.alpha_x > 0 && q.alpha_y > 0)) throw std::invalid_argument("oracle: alpha must be positive");
    // wi exactly on the horizon is accepted: the sampler is well defined there (the cap becomes the
    // upper half sphere) and gives the continuous limit wi.z -> 0 (the height-correlated weight tends
    // to G1o / G1o = 1 as Lambda_i -> inf, which is what smith_g1 = 0 for wi yields). Below: invalid.
    if (!(q.wi.z >= 0)) throw std::invalid_argument("oracle: wi must not be below the horizon");
    const std::size_t n = points.points_per_replicate;
    if (points.u1.size() != points.total() || points.u2.size() != points.total())
        throw std::invalid_argument("oracle: point set arrays do not match replicates * points_per_replicate");
    const double cos_t = cone_cos_theta(q.visibility, opt.ao_weighting);

    Tally result;
    result.cone.assign(points.replicates, 0.0);
    result.hemisphere.assign(points.replicates, 0.0);
    for (std::size_t r = 0; r < points.replicates; ++r) {
        CompensatedSum cone, hemisphere;
        double cone_count = 0, hemisphere_count = 0;
        for (std::size_t i = 0; i < n; ++i) {
            // Long single queries (2^24 samples take seconds) must still stop within ~0.1 s of Ctrl-C.
            if ((i & 0xffff) == 0) throw_if_cancelled();
            const std::size_t k = r * n + i;
            const Vec3 wm = sample_vndf(q.wi, q.alpha_x, q.alpha_y, points.u1[k], points.u2[k]);
            const MicrofacetTerm t = generic_m_m(cos_t, wm, q.wo, q.wi, q.alpha_x, q.alpha_y, opt.form);
            cone.add(t.cone);
            hemisphere.add(t.hemisphere);
            cone_count += t.cone > 0;
            hemisphere_count += t.hemisphere > 0;
        }
        result.cone[r] = cone.value();
        result.hemisphere[r] = hemisphere.value();
        result.cone_count.push_back(cone_count);
        result.hemisphere_count.push_back(hemisphere_count);
    }
    return result;
}

Estimate generic_m_g(const Query& q, const TermOptions& opt, const PointSet& points) {
    const Tally t = tally(q, opt, points);
    return reduce_replicates(t.cone.data(), t.hemisphere.data(), t.cone.size());
}

double reference_step(double visibility, double n_dot_l, AoWeighting weighting) {
    // Part 1's piecewise definition: 1 if cos_theta < NdotL, 0 otherwise (the strict inequality of
    // chi+; the HLSL step(cosTheta, NdotL) would return 1 at equality, a set of measure zero).
    return cone_cos_theta(visibility, weighting) < n_dot_l ? 1.0 : 0.0;
}

}  // namespace ms::oracle
