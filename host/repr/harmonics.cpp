// "azimuth-harmonics": per texel a cosine series in the relative azimuth.
//
// Derivation. The term is an even, 2 pi-periodic, smooth function of phi, so it has a cosine series
// f(phi) = sum_m a_m cos(m phi). From the K bake nodes phi_k = pi k / N (N = K - 1 intervals) the
// trapezoid-weighted sums are discretely orthogonal (the DCT-I): with w_k = 1/2 at k = 0 and N, else 1,
//   sum_k w_k cos(m phi_k) cos(m' phi_k) = N (m = m' = 0), N / 2 (m = m' in 1..N-1), 0 (m != m'),
// so the projection a_0 = (1/N) sum_k w_k f_k, a_m = (2/N) sum_k w_k f_k cos(m phi_k) is the series
// truncated to m <= 3 (exact when the term has no higher harmonics; the residual at the nodes is
// recorded as "node_residual_max"). The lookup evaluates a0 + a1 c + a2 (2c^2 - 1) + a3 (4c^3 - 3c)
// with c = cos phi (no trigonometry in the shader) and clamps the result to [0, 1].
// Under the far-side warp (ReprGrid::azimuth_warp) c is replaced by the warped coordinate y(cos phi)
// and each texel's node k sits where y = cos(pi k / N): the same sums are then the Chebyshev
// coefficients of the interpolant in y, and the lookup evaluates them at the query's own y.
//
// Layout: a 3D texture of width nv (visibility), height nl (NdotL), depth nvv * R: roughness node j
// occupies depth slices [j nvv, (j + 1) nvv); RGBA = (a0, a1, a2, a3). The NdotV coordinate is clamped
// inside its slab, so the filter never reads the next roughness. Two fetches per light: the slabs of the
// two roughness nodes that bracket the roughness, each trilinearly filtered, blended by hand.
//
// "anisotropic-mapped-harmonics" (the anisotropic preset): the same texture, looked up for an
// anisotropic surface (alpha_x, alpha_y, V and L in the tangent frame) at an isotropic equivalent
// (roughness, cos phi, NdotV, NdotL) that reduces to the identity on an isotropic surface.
//
// Derivation of the mapping. In slope space GGX is an elliptic law with covariance
// Sigma = diag(alpha_x^2, alpha_y^2). The VNDF weight of a slope s is linear in its component s_v along
// V's horizontal direction u_v (wi.m / m.z = wi.z - s.wi_xy), the hemisphere's bound m.wo > 0 is a half
// plane in the component s_l along L's u_l, and the cone's bounds m.z > c, m.wo > c add |s|. So the
// term depends on the surface through the projected roughnesses alpha_v = sqrt(u_v.Sigma u_v),
// alpha_l = sqrt(u_l.Sigma u_l), the slopes' correlation rho = u_v.Sigma u_l / (alpha_v alpha_l) (an
// isotropic surface: alpha_v = alpha_l = alpha, rho = cos dphi) and, through |s|, the whole Sigma. The
// isotropic equivalent matches these to first order:
//   - cos phi = rho + k_beta (beta - rho), beta = rho alpha_v / alpha_l the regression of s_v on s_l
//     (what the weight sees of the light's side);
//   - the roughness from log alpha = sum_X (w_X + u_X sin theta_l) log X over X = alpha_l, alpha_v,
//     alpha_rms = sqrt((alpha_x^2 + alpha_y^2) / 2) and alpha_g = sqrt(alpha_x alpha_y) (weights summing
//     to 1: a light along the normal sees |s| (alpha_rms), a grazing one its own direction (alpha_l));
//   - the view's and light's tangents scaled by (alpha_v / alpha)^k_v and (alpha_l / alpha)^k_l, as the
//     Smith masking of a direction reads tan theta times its projected roughness.
// Each piece is 1 (or exact) on an isotropic surface. The nine constants were fitted by coordinate
// search to the exact term on 4,000 random anisotropic queries (ratio 1-25) and measured on 10,000 others
// (docs/representations.md, "Anisotropic surfaces"): the mapping alone, exact isotropic term at the
// mapped inputs, misses the anisotropic term by N.L-weighted RMS 0.044 (the isotropic-equivalent
// roughness with the true azimuth: 0.125).
//
// "anisotropic-corrected-harmonics" (the anisotropic preset): the mapped lookup above plus a correction
// that reads what the mapping loses. Why: the mapping alone misses the anisotropic term by RMS 0.044,
// growing with the ratio, because a strongly anisotropic surface's slopes follow a nearly 1-D law that no
// isotropic roughness reproduces; more mapping constants or a second mapped lookup gained 0.001. The
// correction is linear in four features of the surface and directions that vanish on an isotropic one,
//   g = (log(alpha_l / alpha_g), log(alpha_v / alpha_g), rho - cos(dphi), log(alpha_rms / alpha_g)),
// alpha_g = sqrt(alpha_x alpha_y), alpha_rms = sqrt((alpha_x^2 + alpha_y^2) / 2) (the projected
// roughnesses, their slopes' correlation and the anisotropy's strength, as above), with coefficients
// c(visibility, NdotL, NdotV, roughness) stored per texel of the same grid in a second block of R slabs:
//   lookup = clamp(sum_j w_j (series_j + c_j . g), 0, 1),
// c_j read at slab j's own texel coordinates (the mapped NdotL and NdotV) R slabs further down, so the
// four fetches share one set of coordinates and one roughness blend. On an isotropic surface g = 0 and
// the lookup is azimuth-harmonics' exactly, whatever c. The lookup is linear in c, so c is fitted by
// least squares to the exact term on random anisotropic queries (jobs/repr_bake.cpp). Chosen by
// measurement (docs/representations.md, "Anisotropic surfaces"): with c multilinear on 8^4 nodes, these features
// scored RMS 0.024-0.025 where the mapping's own residual features (log(alpha_v / alpha_l) and its
// square, rho - cos(dphi), log(alpha_rms / alpha_g)) scored 0.032-0.033 and cos 2 psi terms of the azimuths
// from the rougher axis 0.033.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "repr/texture_repr.hpp"

namespace ms::repr {

namespace {

// The mapping's constants (derivation above): weights of log alpha_l, alpha_v, alpha_rms (alpha_g takes
// the rest), their slopes in sin theta_l, the pull toward beta, and the view's and light's tangent exponents.
struct MappingConstants {
    double w_l, w_v, w_rms, u_l, u_v, u_rms, k_beta, k_v, k_l;
};
constexpr MappingConstants kMapping{-0.1406, 0.2028, 0.8746, 0.8438, -0.3121, -0.5466, -0.1566, 1.1096, -0.0310};

}  // namespace

IsotropicEquivalent isotropic_equivalent(double alpha_x, double alpha_y, double pv, double pl, double n_dot_v, double n_dot_l) {
    const MappingConstants& k = kMapping;
    const double cv = std::cos(pv), sv = std::sin(pv), cl = std::cos(pl), sl = std::sin(pl);
    const double ax2 = alpha_x * alpha_x, ay2 = alpha_y * alpha_y;
    const double av2 = ax2 * cv * cv + ay2 * sv * sv, al2 = ax2 * cl * cl + ay2 * sl * sl;
    const double rho = (ax2 * cv * cl + ay2 * sv * sl) / std::sqrt(av2 * al2);
    const double beta = rho * std::sqrt(av2 / al2);
    const double sin_l = std::sqrt(std::max(0.0, 1 - n_dot_l * n_dot_l));
    const double w_l = k.w_l + k.u_l * sin_l, w_v = k.w_v + k.u_v * sin_l, w_rms = k.w_rms + k.u_rms * sin_l;
    // Logarithms of squared alphas: log alpha = half of them.
    const double log_g2 = std::log(alpha_x * alpha_y), log_rms2 = std::log(0.5 * (ax2 + ay2));
    const double log_a2 = w_l * std::log(al2) + w_v * std::log(av2) + w_rms * log_rms2 + (1 - w_l - w_v - w_rms) * log_g2;
    const double alpha2 = std::exp(log_a2);
    // Scaled tangents: tan' = tan (alpha_d / alpha)^k, as cos' = cos / sqrt(cos^2 + sin^2 s^2).
    const double s_v = std::pow(av2 / alpha2, 0.5 * k.k_v), s_l = std::pow(al2 / alpha2, 0.5 * k.k_l);
    const double sin_v2 = std::max(0.0, 1 - n_dot_v * n_dot_v);
    IsotropicEquivalent out;
    out.roughness = std::sqrt(std::sqrt(alpha2));
    out.cos_phi = std::clamp(rho + k.k_beta * (beta - rho), -1.0, 1.0);
    out.n_dot_v = n_dot_v / std::sqrt(n_dot_v * n_dot_v + sin_v2 * s_v * s_v);
    out.n_dot_l = n_dot_l / std::sqrt(n_dot_l * n_dot_l + sin_l * sin_l * s_l * s_l);
    return out;
}

namespace {

constexpr int kHarmonics = 4;

class AzimuthHarmonics final : public TextureRepresentation {
public:
    AzimuthHarmonics(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture, nlohmann::json metadata, HarmonicsLookup lookup)
        : TextureRepresentation(std::move(grid), azimuth_nodes, std::move(texture), std::move(metadata)),
          mapped_(lookup != HarmonicsLookup::isotropic), corrected_(lookup == HarmonicsLookup::corrected) {
        correction_bound_ = metadata_.value("correction_bound", 0.0);
    }
    std::string kind() const override {
        return corrected_ ? "anisotropic-corrected-harmonics" : mapped_ ? "anisotropic-mapped-harmonics" : "azimuth-harmonics";
    }
    std::string name() const override {
        std::ostringstream o;
        o << (corrected_ ? "azimuth harmonics a0..a3 at the isotropic equivalent of an anisotropic surface, plus its anisotropy correction per texel: "
              : mapped_ ? "azimuth harmonics a0..a3 at the isotropic equivalent of an anisotropic surface: " : "azimuth harmonics a0..a3: ") << grid_.visibility << " visibility (" << to_string(grid_.warps.visibility) << ") x " << grid_.n_dot_l << " NdotL ("
          << to_string(grid_.warps.n_dot_l) << ") x " << grid_.n_dot_v << " NdotV (" << to_string(grid_.warps.n_dot_v)
          << ") x " << grid_.roughness.size() << " roughness slabs:";
        for (double r : grid_.roughness) o << " " << r;
        return o.str();
    }
    // The corrected kind's correction slabs reuse the four channels for their coefficients c_0..c_3.
    std::vector<std::string> channel_names() const override { return {"cos0phi", "cos1phi", "cos2phi", "cos3phi"}; }
    // With f_k in [0, 1] and sum_k w_k = N: a_0 = (1/N) sum w_k f_k is in [0, 1] and
    // |a_m| <= (2/N) sum w_k |f_k cos(m phi_k)| <= 2. The correction's coefficients lie within the
    // bound its fit recorded (the largest |c| it produced).
    std::array<double, 2> channel_range(std::size_t c) const override {
        std::array<double, 2> range = c == 0 ? std::array<double, 2>{0.0, 1.0} : std::array<double, 2>{-2.0, 2.0};
        if (corrected_) range = {std::min(range[0], -correction_bound_), std::max(range[1], correction_bound_)};
        return range;
    }

    double operator()(const approx::Inputs& in) const override { return evaluate(in, nullptr); }

    // The lookup, and with `stencil` the same lookup written as base + sum_k weight_k dot(texel_k, g)
    // over the correction texels it reads (what the correction's fit solves for).
    double evaluate(const approx::Inputs& in, CorrectionStencil* stencil) const {
        if (stencil) *stencil = CorrectionStencil{};
        if (zero_region(in.visibility, in.n_dot_l)) return 0;
        // Full visibility: the cone is the whole hemisphere and the term is exactly 1 above the horizon.
        // Just below v = 1 a light under the cone's edge sqrt(1 - v) is still shadowed, so no texel
        // holds both sides of that limit.
        // Decided on the binary32 visibility, as the shader decides it.
        if (float(in.visibility) >= 1.0f) return 1;
        // The anisotropic kind reads the surface's alphas and tangent-relative azimuths when given (an
        // isotropic caller's roughness and relative azimuth otherwise: the mapping's identity).
        double n_dot_l = in.n_dot_l, n_dot_v = in.n_dot_v, roughness = in.roughness, cos_phi = std::cos(in.relative_azimuth);
        // The anisotropy features the correction's coefficients multiply: zero on an isotropic surface.
        std::array<double, 4> g{0, 0, 0, 0};
        if (mapped_ && in.alpha_x > 0 && in.alpha_y > 0) {
            const auto e = isotropic_equivalent(in.alpha_x, in.alpha_y, in.view_azimuth, in.light_azimuth, in.n_dot_v, in.n_dot_l);
            n_dot_l = e.n_dot_l, n_dot_v = e.n_dot_v, roughness = e.roughness, cos_phi = e.cos_phi;
            if (corrected_) g = anisotropy_features(in.alpha_x, in.alpha_y, in.view_azimuth, in.light_azimuth);
        }
        const std::size_t slab_texels = std::size_t(texture_.width) * texture_.height * grid_.n_dot_v;
        const double correction_z = double(grid_.roughness.size()) * grid_.n_dot_v;
        const double tz = n_dot_v_texel(n_dot_v);
        const double c = grid_.azimuth_coordinate(cos_phi, n_dot_v, n_dot_l);
        const double basis[kHarmonics] = {1, c, 2 * c * c - 1, (4 * c * c - 3) * c};
        // The NdotL and visibility texels of a slab: its own under the edge-roughness warps, else one for all.
        // The corrected kind adds, per slab, the correction slab's coefficients dot g (at the same texel
        // coordinates, R slabs further down the texture); `weight` is the slab's share of the blend.
        auto series = [&](std::uint32_t slab, double weight) {
            const double tl = n_dot_l_texel(in.visibility, n_dot_l, slab, n_dot_v), tv = visibility_texel(in.visibility, slab, n_dot_v);
            const auto a = texture_.sample(tv, tl, double(slab) * grid_.n_dot_v + tz);
            double s = 0;
            for (int m = 0; m < kHarmonics; ++m) s += a[m] * basis[m];
            if (stencil) {
                stencil->base += weight * s;
                const auto corners = texture_.corners(tv, tl, correction_z + double(slab) * grid_.n_dot_v + tz);
                for (int k = 0; k < 8; ++k) {
                    const std::size_t n = stencil->texels++;
                    stencil->texel[n] = std::uint32_t(corners[k].first - slab_texels * grid_.roughness.size());
                    stencil->weight[n] = weight * corners[k].second;
                }
            }
            if (corrected_ && (g[0] != 0 || g[1] != 0 || g[2] != 0 || g[3] != 0)) {
                const auto b = texture_.sample(tv, tl, correction_z + double(slab) * grid_.n_dot_v + tz);
                for (int m = 0; m < 4; ++m) s += b[m] * g[m];
            }
            return s;
        };
        if (stencil) stencil->features = g, stencil->active = true;
        const auto& r = grid_.roughness;
        if (r.size() == 1) return std::clamp(series(0, 1), 0.0, 1.0);
        const double x = std::clamp(roughness, r.front(), r.back());
        std::size_t j = 0;
        while (j + 2 < r.size() && x > r[j + 1]) ++j;
        const double f = (x - r[j]) * (1 / (r[j + 1] - r[j]));
        const double a = series(std::uint32_t(j), 1 - f), b = series(std::uint32_t(j + 1), f);
        return std::clamp(a + (b - a) * f, 0.0, 1.0);
    }

    // The far-side warp written out (ReprGrid::azimuth_coordinate): c becomes the series coordinate y.
    std::string azimuth_warp_text() const {
        if (!(grid_.azimuth_warp > 0)) return "";
        const auto L = shader_literal;
        return "    // The series is in y = 2 asinh((1 + c) / tau) / asinh(2 / tau) - 1, tau = kappa (NdotV + NdotL)^2 / 2:\n"
               "    // its range spent near the far side, where a light at the horizon falls into shadow.\n"
               "    float d_w = max(n_dot_v, 0.0) + max(n_dot_l, 0.0);\n"
               "    float tau = max(" + L(grid_.azimuth_warp / 2) + " * d_w * d_w, " + L(1e-6) + ");\n"
               "    c = 2.0 * ms_asinh((1.0 + c) / tau) / ms_asinh(2.0 / tau) - 1.0;\n";
    }

    std::string shader(ShaderLanguage language, const std::string& source_name) const override {
        const auto L = shader_literal;
        const auto& r = grid_.roughness;
        std::ostringstream o;
        o << shader_common(source_name);
        o << "// RGBA = a0..a3 of a0 + a1 cos(phi) + a2 cos(2 phi) + a3 cos(3 phi); depth = roughness slab j * "
          << grid_.n_dot_v << " + NdotV texel, slabs at roughness";
        for (double x : r) o << " " << x;
        o << ".\n";
        if (mapped_) o << mapping_prologue();
        else
            o << "ENTRY(float visibility, float n_dot_l, float n_dot_v, float roughness, float cos_phi)\n{\n"
              << "    if (ms_zero_region(visibility, n_dot_l)) return 0.0;  // early-out: no fetch\n"
              << "    if (visibility >= 1.0) return 1.0;  // the cone is the hemisphere: lit wherever above the horizon\n";
        if (corrected_)
            o << "    // The anisotropy features g the correction's coefficients multiply (each 0 on an isotropic surface):\n"
              << "    // log(alpha_l / alpha_g), log(alpha_v / alpha_g), rho - cos(dphi), log(alpha_rms / alpha_g), alpha_g = sqrt(alpha_x alpha_y).\n"
              << "    float lg2 = log(alpha_x * alpha_y);\n"
              << "    VEC4 g = VEC4(0.5 * (log(al2) - lg2), 0.5 * (log(av2) - lg2), rho - dot(uv_d, ul_d), 0.5 * (log(0.5 * (a2.x + a2.y)) - lg2));\n";
        // The corrected kind's correction slab of a fetch lies R slabs further down the texture.
        const std::string correction_dz = L(double(grid_.n_dot_v * r.size()) / texture_.depth);
        o << shader_coordinates()
          << "    float c = clamp(cos_phi, -1.0, 1.0);\n" << azimuth_warp_text()
          << "    // cos(2 phi) and cos(3 phi) from cos(phi) (Chebyshev polynomials): no trigonometry.\n"
          << "    VEC4 basis = VEC4(1.0, c, 2.0 * c * c - 1.0, (4.0 * c * c - 3.0) * c);\n";
        const bool edge = grid_.warps.n_dot_l == NdotLWarp::edge_roughness;
        const bool edge_visibility = grid_.warps.visibility == VisibilityWarp::edge_roughness;
        // The edge warp's width from k alpha max(s_e, alpha) (alpha = r^2), capped by w_cap under the view factor.
        auto capped = [&](const std::string& w) { return grid_.n_dot_l_edge_view > 0 ? "min(" + w + ", w_cap)" : w; };
        auto width = [&](double x) { return capped(L(grid_.edge_width * x * x) + " * max(s_e, " + L(x * x) + ")"); };
        // The edge-roughness visibility texel of a slab of squared roughness `alpha` (an expression).
        auto visibility_texel = [&](const std::string& alpha) {
            return "ms_edge_visibility_texel(e_v, c_e, " + L(grid_.visibility_edge_width) + " * min(" + alpha + ", s_view))";
        };
        if (r.size() == 1) {
            if (edge) o << "    float tl = ms_edge_texel(n_dot_l, c_e, l0, " << width(r[0]) << ");\n";
            if (edge_visibility) o << "    float tv = " << visibility_texel(L(r[0] * r[0])) << ";\n";
            o << "    VEC3 c0 = VEC3((tv + 0.5) * " << L(1.0 / texture_.width) << ", (tl + 0.5) * " << L(1.0 / texture_.height)
              << ", (tz + 0.5) * " << L(1.0 / texture_.depth) << ");\n"
              << (corrected_ ? "    VEC3 d0 = c0 + VEC3(0.0, 0.0, " + correction_dz + ");  // the correction slab\n"
                               "    return clamp(dot(FETCH(c0), basis) + dot(FETCH(d0), g), 0.0, 1.0);\n}\n"
                             : "    return clamp(dot(FETCH(c0), basis), 0.0, 1.0);\n}\n");
        } else {
            // Nodes in geometric progression (r_k = r_0 q^k, as the full-range preset's): the slab from a
            // logarithm, a dozen ALU, instead of a comparison per node.
            const double q = r[1] / r[0];
            bool geometric = r.size() > 2;
            for (std::size_t k = 1; k < r.size() && geometric; ++k) geometric = std::abs(r[k] / r[k - 1] - q) <= 1e-9 * q;
            o << "    // The roughness slabs j and j + 1 that bracket the roughness, and the weight of j + 1.\n"
              << "    float r = clamp(roughness, " << L(r.front()) << ", " << L(r.back()) << ");\n";
            if (geometric) {
                o << "    // Geometric nodes r_k = " << L(r[0]) << " * " << L(q) << "^k: j = floor(log(r / r_0) / log(q)).\n"
                  << "    float j = floor(clamp(log(r * " << L(1 / r[0]) << ") * " << L(1 / std::log(q)) << ", 0.0, " << L(double(r.size() - 2))
                  << "));\n"
                  << "    float rj = " << L(r[0]) << " * exp(j * " << L(std::log(q)) << ");\n"
                  << "    float f = clamp((r - rj) / (rj * " << L(q - 1) << "), 0.0, 1.0);\n";
                if (edge)
                    o << "    float rj1 = rj * " << L(q) << ";\n"
                      << "    float al0 = rj * rj, al1 = rj1 * rj1;\n    float ka0 = " << L(grid_.edge_width) << " * al0, ka1 = "
                      << L(grid_.edge_width) << " * al1;\n";
            } else {
                o << "    float j = 0.0;\n    float f = (r - " << L(r[0]) << ") * " << L(1 / (r[1] - r[0])) << ";\n";
            }
            // Under the edge-roughness warp each slab has its own NdotL axis: its width w0, w1 too.
            // The edge warp's k alpha and alpha of nodes j and j + 1 (w = k alpha max(s_e, alpha)).
            auto ka = [&](double x) { return L(grid_.edge_width * x * x); };
            auto al = [&](double x) { return L(x * x); };
            if (edge && !geometric)
                o << "    float ka0 = " << ka(r[0]) << ", al0 = " << al(r[0]) << ", ka1 = " << ka(r[1]) << ", al1 = " << al(r[1]) << ";\n";
            for (std::size_t k = 1; k + 1 < r.size() && !geometric; ++k) {
                o << "    if (r > " << L(r[k]) << ") { j = " << L(k) << "; f = (r - " << L(r[k]) << ") * " << L(1 / (r[k + 1] - r[k]));
                if (edge) o << "; ka0 = " << ka(r[k]) << "; al0 = " << al(r[k]) << "; ka1 = " << ka(r[k + 1]) << "; al1 = " << al(r[k + 1]);
                o << "; }\n";
            }
            if (edge)
                o << "    float tl = ms_edge_texel(n_dot_l, c_e, l0, " << capped("ka0 * max(s_e, al0)") << ");\n"
                  << "    float tl1 = ms_edge_texel(n_dot_l, c_e, l0, " << capped("ka1 * max(s_e, al1)") << ");\n";
            // Under the edge-roughness visibility warp each slab has its own visibility axis too.
            if (edge_visibility)
                o << "    float tv = " << visibility_texel("al0") << ";\n    float tv1 = " << visibility_texel("al1") << ";\n";
            o << "    VEC3 c0 = VEC3((tv + 0.5) * " << L(1.0 / texture_.width) << ", (tl + 0.5) * " << L(1.0 / texture_.height)
              << ", (j * " << L(grid_.n_dot_v) << " + tz + 0.5) * " << L(1.0 / texture_.depth) << ");\n";
            if (edge)
                o << "    VEC3 c1 = VEC3(" << (edge_visibility ? "(tv1 + 0.5) * " + L(1.0 / texture_.width) : std::string("c0.x")) << ", (tl1 + 0.5) * " << L(1.0 / texture_.height) << ", c0.z + "
                  << L(double(grid_.n_dot_v) / texture_.depth) << ");\n";
            else
                o << "    VEC3 c1 = c0 + VEC3(0.0, 0.0, " << L(double(grid_.n_dot_v) / texture_.depth) << ");\n";
            if (corrected_)
                o << "    // The correction slabs of j and j + 1.\n"
                  << "    VEC3 d0 = c0 + VEC3(0.0, 0.0, " << correction_dz << "), d1 = c1 + VEC3(0.0, 0.0, " << correction_dz << ");\n"
                  << "    return clamp(MIX(dot(FETCH(c0), basis) + dot(FETCH(d0), g), dot(FETCH(c1), basis) + dot(FETCH(d1), g), f), 0.0, 1.0);\n}\n";
            else
                o << "    return clamp(MIX(dot(FETCH(c0), basis), dot(FETCH(c1), basis), f), 0.0, 1.0);\n}\n";
        }
        return finish_shader(o.str(), language);
    }

private:
    // The anisotropic entry point's first statements: the zero region at the light's own NdotL, then
    // the isotropic equivalent (isotropic_equivalent above, statement for statement) in the names the
    // isotropic body reads: n_dot_l, n_dot_v, roughness, cos_phi.
    std::string mapping_prologue() const {
        const auto L = shader_literal;
        const MappingConstants& k = kMapping;
        std::ostringstream o;
        o << "ENTRY(float visibility, VEC3 v_t, VEC3 l_t, float alpha_x, float alpha_y)\n{\n"
          << "    if (ms_zero_region(visibility, l_t.z)) return 0.0;  // early-out: no fetch\n"
          << "    if (visibility >= 1.0) return 1.0;  // the cone is the hemisphere: lit wherever above the horizon\n"
          << "    // The isotropic equivalent of the anisotropic surface (host/repr/harmonics.cpp derives it).\n"
          << "    // Horizontal unit directions of V and L (x when one is along the normal).\n"
          << "    float lv = length(v_t.xy), ll = length(l_t.xy);\n"
          << "    VEC2 uv_d = lv > 1e-7 ? v_t.xy / lv : VEC2(1.0, 0.0);\n"
          << "    VEC2 ul_d = ll > 1e-7 ? l_t.xy / ll : VEC2(1.0, 0.0);\n"
          << "    // Squared projected roughnesses along V and L, the slopes' correlation rho, beta = rho alpha_v / alpha_l.\n"
          << "    VEC2 a2 = VEC2(alpha_x * alpha_x, alpha_y * alpha_y);\n"
          << "    float av2 = dot(a2, uv_d * uv_d), al2 = dot(a2, ul_d * ul_d);\n"
          << "    float rho = dot(a2, uv_d * ul_d) / sqrt(av2 * al2);\n"
          << "    float beta = rho * sqrt(av2 / al2);\n"
          << "    float n_dot_v0 = clamp(v_t.z, 0.0, 1.0), n_dot_l0 = l_t.z;\n"
          << "    float sin_l = sqrt(max(1.0 - n_dot_l0 * n_dot_l0, 0.0));\n"
          << "    // log alpha^2 as a blend of log alpha_l^2, alpha_v^2, alpha_rms^2 and alpha_g^2 whose weights follow sin theta_l.\n"
          << "    float w_l = " << L(k.w_l) << " + " << L(k.u_l) << " * sin_l, w_v = " << L(k.w_v) << " + " << L(k.u_v)
          << " * sin_l, w_rms = " << L(k.w_rms) << " + " << L(k.u_rms) << " * sin_l;\n"
          << "    float log_a2 = w_l * log(al2) + w_v * log(av2) + w_rms * log(0.5 * (a2.x + a2.y)) + (1.0 - w_l - w_v - w_rms) * log(alpha_x * alpha_y);\n"
          << "    float alpha2 = exp(log_a2);\n"
          << "    float roughness = sqrt(sqrt(alpha2));\n"
          << "    float cos_phi = clamp(rho + " << L(k.k_beta) << " * (beta - rho), -1.0, 1.0);\n"
          << "    // The view's and light's tangents scaled by (alpha_d / alpha)^k.\n"
          << "    float s_v = exp(" << L(0.5 * k.k_v) << " * log(av2 / alpha2)), s_l = exp(" << L(0.5 * k.k_l) << " * log(al2 / alpha2));\n"
          << "    float sin_v2 = max(1.0 - n_dot_v0 * n_dot_v0, 0.0);\n"
          << "    float n_dot_v = n_dot_v0 / sqrt(n_dot_v0 * n_dot_v0 + sin_v2 * s_v * s_v);\n"
          << "    float n_dot_l = n_dot_l0 / sqrt(n_dot_l0 * n_dot_l0 + sin_l * sin_l * s_l * s_l);\n";
        return o.str();
    }

    bool mapped_, corrected_;
    double correction_bound_ = 0;
};

}  // namespace

std::unique_ptr<Representation> make_azimuth_harmonics(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                       nlohmann::json metadata, bool anisotropic_mapped) {
    if (grid.roughness.empty()) throw std::invalid_argument("azimuth-harmonics: at least 1 roughness node");
    if (texture.width != grid.visibility || texture.height != grid.n_dot_l || texture.depth != grid.n_dot_v * grid.roughness.size())
        throw std::invalid_argument("azimuth-harmonics: texture size does not match the grid");
    metadata["fetches_per_light"] = grid.roughness.size() == 1 ? 1 : 2;
    return std::make_unique<AzimuthHarmonics>(std::move(grid), azimuth_nodes, std::move(texture), std::move(metadata),
                                              anisotropic_mapped ? HarmonicsLookup::mapped : HarmonicsLookup::isotropic);
}

std::unique_ptr<Representation> make_anisotropic_corrected(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                           nlohmann::json metadata) {
    if (grid.roughness.empty()) throw std::invalid_argument("anisotropic-corrected-harmonics: at least 1 roughness node");
    if (texture.width != grid.visibility || texture.height != grid.n_dot_l || texture.depth != 2 * grid.n_dot_v * grid.roughness.size())
        throw std::invalid_argument("anisotropic-corrected-harmonics: texture size does not match the grid (two blocks of slabs)");
    if (!(metadata.value("correction_bound", -1.0) >= 0))
        throw std::invalid_argument("anisotropic-corrected-harmonics: metadata needs the correction's coefficient bound");
    metadata["fetches_per_light"] = grid.roughness.size() == 1 ? 2 : 4;
    return std::make_unique<AzimuthHarmonics>(std::move(grid), azimuth_nodes, std::move(texture), std::move(metadata),
                                              HarmonicsLookup::corrected);
}

namespace {

// The harmonics' texture of a bake (derivation at the top), and the truncation residual at the nodes.
Texture3D harmonics_texture(const AzimuthBake& bake, double* residual_max) {
    const auto& g = bake.grid;
    const std::uint32_t K = bake.azimuth_nodes, N = K - 1;
    if (K < 2 * kHarmonics - 1)
        throw std::invalid_argument("azimuth-harmonics: needs at least " + std::to_string(2 * kHarmonics - 1) + " azimuth nodes");
    Texture3D t;
    t.width = g.visibility;
    t.height = g.n_dot_l;
    t.depth = g.n_dot_v * std::uint32_t(g.roughness.size());
    t.texels.resize(std::size_t(t.width) * t.height * t.depth * 4);
    double residual = 0;
    for (std::uint32_t r = 0; r < g.roughness.size(); ++r)
        for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
            for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                    double a[kHarmonics] = {0, 0, 0, 0};
                    for (std::uint32_t k = 0; k <= N; ++k) {
                        const double w = (k == 0 || k == N) ? 0.5 : 1.0, f = bake.value[bake.index(r, k, iv, il, ivv)];
                        // cos(m pi k / N) = T_m(y_k) at the node's series coordinate y_k = cos(pi k / N).
                        for (int m = 0; m < kHarmonics; ++m) a[m] += w * f * std::cos(m * M_PI * k / N);
                    }
                    for (int m = 0; m < kHarmonics; ++m) a[m] *= (m == 0 ? 1.0 : 2.0) / N;
                    // The truncation residual at the nodes (what the series misses of the bake there).
                    for (std::uint32_t k = 0; k <= N; ++k) {
                        double s = 0;
                        for (int m = 0; m < kHarmonics; ++m) s += a[m] * std::cos(m * M_PI * k / N);
                        residual = std::max(residual, std::abs(std::clamp(s, 0.0, 1.0) - bake.value[bake.index(r, k, iv, il, ivv)]));
                    }
                    const std::size_t z = std::size_t(r) * g.n_dot_v + ivv;
                    for (int m = 0; m < kHarmonics; ++m) t.texels[((z * t.height + il) * t.width + iv) * 4 + m] = float(a[m]);
                }
    *residual_max = residual;
    return t;
}

nlohmann::json harmonics_metadata(const AzimuthBake& bake, double residual) {
    nlohmann::json meta = {{"bake", bake.metadata}, {"node_residual_max", residual}};
    for (const char* key : {"version", "command_line", "domain", "preset"})
        if (bake.metadata.contains(key)) meta[key] = bake.metadata[key];
    return meta;
}

}  // namespace

std::unique_ptr<Representation> build_azimuth_harmonics(const AzimuthBake& bake, bool anisotropic_mapped) {
    double residual = 0;
    Texture3D t = harmonics_texture(bake, &residual);
    return make_azimuth_harmonics(bake.grid, bake.azimuth_nodes, std::move(t), harmonics_metadata(bake, residual), anisotropic_mapped);
}

std::size_t anisotropic_correction_texels(const ReprGrid& grid) {
    return std::size_t(grid.visibility) * grid.n_dot_l * grid.n_dot_v * grid.roughness.size();
}

std::unique_ptr<Representation> build_anisotropic_corrected(const AzimuthBake& bake, const std::vector<float>& correction,
                                                            const nlohmann::json& correction_metadata) {
    double residual = 0;
    Texture3D t = harmonics_texture(bake, &residual);
    const std::size_t n = anisotropic_correction_texels(bake.grid);
    if (!correction.empty() && correction.size() != 4 * n)
        throw std::invalid_argument("anisotropic-corrected-harmonics: the correction has " + std::to_string(correction.size() / 4) +
                                    " texels, the grid " + std::to_string(n));
    // Empty: a zero correction (the mapped lookup itself, the start of the correction's fit).
    double bound = 0;
    for (float c : correction) bound = std::max(bound, double(std::fabs(c)));
    t.texels.insert(t.texels.end(), correction.begin(), correction.end());
    t.texels.resize(8 * n, 0.0f);
    t.depth *= 2;
    nlohmann::json meta = harmonics_metadata(bake, residual);
    meta["correction"] = correction_metadata;
    // The bound a file's texels are checked against: the largest |c|, widened by half a half-float step
    // (relative 2^-11) and more, so the RGBA16F rounding of the largest coefficient stays inside.
    meta["correction_bound"] = bound * (1 + 1.0 / 1024);
    return make_anisotropic_corrected(bake.grid, bake.azimuth_nodes, std::move(t), std::move(meta));
}

CorrectionStencil correction_stencil(const Representation& representation, const approx::Inputs& in) {
    const auto* r = dynamic_cast<const AzimuthHarmonics*>(&representation);
    if (!r || r->kind() != "anisotropic-corrected-harmonics")
        throw std::invalid_argument("correction_stencil: not an anisotropic-corrected-harmonics representation");
    CorrectionStencil s;
    r->evaluate(in, &s);
    return s;
}

std::array<double, 4> anisotropy_features(double alpha_x, double alpha_y, double view_azimuth, double light_azimuth) {
    const double cv = std::cos(view_azimuth), sv = std::sin(view_azimuth), cl = std::cos(light_azimuth), sl = std::sin(light_azimuth);
    const double ax2 = alpha_x * alpha_x, ay2 = alpha_y * alpha_y;
    const double av2 = ax2 * cv * cv + ay2 * sv * sv, al2 = ax2 * cl * cl + ay2 * sl * sl;
    const double rho = (ax2 * cv * cl + ay2 * sv * sl) / std::sqrt(av2 * al2);
    const double lg2 = std::log(alpha_x * alpha_y);
    return {0.5 * (std::log(al2) - lg2), 0.5 * (std::log(av2) - lg2), rho - (cv * cl + sv * sl), 0.5 * (std::log(0.5 * (ax2 + ay2)) - lg2)};
}

}  // namespace ms::repr
