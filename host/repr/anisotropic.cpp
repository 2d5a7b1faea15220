// "anisotropic-harmonics": the anisotropic term (alpha_x != alpha_y, view and light azimuths measured
// from the tangent) as a texture a renderer samples four times per light.
//
// Derivation. GGX slopes have covariance Sigma = diag(alpha_x^2, alpha_y^2) in the tangent frame. Along
// the unit horizontal directions u_v, u_l of V and L (angle dphi apart) the slope distribution is fixed by
// three numbers: the projected roughnesses alpha_v = sqrt(u_v.Sigma u_v), alpha_l = sqrt(u_l.Sigma u_l)
// and their correlation rho = u_v.Sigma u_l / (alpha_v alpha_l). With dphi these four replace
// (alpha_x, alpha_y, phi_v, phi_l) one for one (Sigma = B^-T M B^-1, B = [u_v u_l], M the 2 x 2
// covariance in that frame), so the term is exactly a function of
//     (visibility, NdotL, NdotV, alpha_v, alpha_l, rho, dphi);
// (checked: 300 random queries up to ratio 25 and the surfaces rebuilt from these four agree to 1e-8
// with the exact method). An isotropic surface is the slice alpha_v = alpha_l, rho = cos dphi. Per texel
// and pair of (alpha_v, alpha_l) nodes the term is fitted as a0 + a1 cos(dphi) + a2 cos(2 dphi) + a3 rho.
// Measured (docs/representations.md, "Anisotropic surfaces"): this 4-term fit misses the term by RMS
// 0.035 (max 0.47) at the bake's own surfaces and texels, and by RMS 0.10 on random queries up to
// ratio 25, short of the 0.03 aimed at; a3 (rho - cos dphi) / sin dphi instead of a3 rho scored worse
// (0.106). Its value is a layout, lookup and shader that are exact to the derivation, to build on.
//
// Layout. Roughness nodes r_k (geometric) stand for projected alphas r_k^2 on both roughness axes. A 3D
// texture of width nv R (slot j_l of nv visibility texels for the light's node j_l, as the azimuth axis
// lays out its slots), height nl (NdotL, edge-roughness warp at the light's node: the shadow edge's
// width follows the light's projected roughness), depth nvv R (slab j_v of nvv NdotV texels for the
// view's node j_v); RGBA = (a0, a1, a2, a3). The lookup finds the nodes bracketing sqrt(alpha_v) and
// sqrt(alpha_l) in log roughness, fetches the four corners (trilinear each: visibility, NdotL, NdotV,
// each clamped inside its slot and slab) and blends the four series values bilinearly: 4 fetches.
//
// Bake (jobs/repr_bake.cpp). Per slab (j_v, j_l) a set of configurations (dphi, rho): dphi at the centres of `azimuth
// configs` cells of (0, pi), rho at `correlation configs` points spread over the values a surface of
// ratio <= max_ratio allows at that dphi. Each configuration is a real surface (alpha_x, alpha_y and the
// frame rotation from Sigma's eigenvectors), its term is computed with the exact method at every texel,
// and the four coefficients are the least-squares fit over the configurations (a small ridge keeps the
// fit defined where cos(dphi) and rho are nearly collinear, as near the isotropic slice). The fit is a
// fixed linear map P of the configurations' values, the same for every texel of a slab, so with values
// in [0, 1] every coefficient lies within the largest row sum of |P|: the channel range a file is
// checked against ("coefficient_bound").
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "repr/texture_repr.hpp"

namespace ms::repr {

namespace {

constexpr int kTerms = 4;

// The slab and weight of a value between geometric nodes (in log roughness), clamped to the ends.
struct NodePosition {
    std::uint32_t j = 0;
    double f = 0;
};
NodePosition geometric_position(const std::vector<double>& r, double x) {
    if (r.size() == 1) return {};
    const double t = std::clamp(std::log(x / r.front()) / std::log(r[1] / r.front()), 0.0, double(r.size() - 1));
    const std::uint32_t j = std::min(std::uint32_t(std::floor(t)), std::uint32_t(r.size() - 2));
    return {j, t - j};
}

bool is_geometric(const std::vector<double>& r) {
    if (r.size() < 2) return true;
    const double q = r[1] / r[0];
    for (std::size_t k = 1; k < r.size(); ++k)
        if (std::abs(r[k] / r[k - 1] - q) > 1e-6 * q) return false;
    return true;
}

class AnisotropicHarmonics final : public TextureRepresentation {
public:
    AnisotropicHarmonics(ReprGrid grid, Texture3D texture, nlohmann::json metadata, double coefficient_bound)
        : TextureRepresentation(std::move(grid), 0, std::move(texture), std::move(metadata)), bound_(coefficient_bound) {}
    std::string kind() const override { return "anisotropic-harmonics"; }
    std::string name() const override {
        std::ostringstream o;
        o << "anisotropic harmonics a0 + a1 cos(dphi) + a2 cos(2 dphi) + a3 rho: " << grid_.visibility << " visibility ("
          << to_string(grid_.warps.visibility) << ") x " << grid_.n_dot_l << " NdotL (" << to_string(grid_.warps.n_dot_l) << ") x "
          << grid_.n_dot_v << " NdotV (" << to_string(grid_.warps.n_dot_v) << ") x " << grid_.roughness.size() << " view x "
          << grid_.roughness.size() << " light projected roughness:";
        for (double r : grid_.roughness) o << " " << r;
        return o.str();
    }
    std::vector<std::string> channel_names() const override { return {"cos0phi", "cos1phi", "cos2phi", "rho"}; }
    std::array<double, 2> channel_range(std::size_t) const override { return {-bound_, bound_}; }

    double operator()(const approx::Inputs& in) const override {
        if (zero_region(in.visibility, in.n_dot_l)) return 0;
        // An isotropic caller's inputs (no alphas): alpha = roughness^2, V at azimuth 0, L at the
        // relative azimuth; an isotropic surface is the slice alpha_v = alpha_l, rho = cos(dphi).
        const bool iso = !(in.alpha_x > 0 && in.alpha_y > 0);
        const double ax = iso ? in.roughness * in.roughness : in.alpha_x, ay = iso ? ax : in.alpha_y;
        const double pv = iso ? 0.0 : in.view_azimuth, pl = iso ? in.relative_azimuth : in.light_azimuth;
        const double cv = std::cos(pv), sv = std::sin(pv), cl = std::cos(pl), sl = std::sin(pl);
        const double av2 = ax * ax * cv * cv + ay * ay * sv * sv, al2 = ax * ax * cl * cl + ay * ay * sl * sl;
        const double rho = (ax * ax * cv * cl + ay * ay * sv * sl) / std::sqrt(av2 * al2);
        const double cd = cv * cl + sv * sl;
        const double basis[kTerms] = {1, cd, 2 * cd * cd - 1, rho};
        const auto& r = grid_.roughness;
        const NodePosition v = geometric_position(r, std::sqrt(std::sqrt(av2))), l = geometric_position(r, std::sqrt(std::sqrt(al2)));
        const double tv = visibility_texel(in.visibility), tz = n_dot_v_texel(in.n_dot_v);
        auto series = [&](std::uint32_t jv, std::uint32_t jl) {
            const double tl = n_dot_l_texel(in.visibility, in.n_dot_l, jl);
            const auto a = texture_.sample(double(jl) * grid_.visibility + tv, tl, double(jv) * grid_.n_dot_v + tz);
            double s = 0;
            for (int m = 0; m < kTerms; ++m) s += a[m] * basis[m];
            return s;
        };
        const std::uint32_t jv1 = std::min<std::uint32_t>(v.j + 1, std::uint32_t(r.size() - 1)),
                            jl1 = std::min<std::uint32_t>(l.j + 1, std::uint32_t(r.size() - 1));
        const double low = series(v.j, l.j) + (series(v.j, jl1) - series(v.j, l.j)) * l.f;
        const double high = series(jv1, l.j) + (series(jv1, jl1) - series(jv1, l.j)) * l.f;
        return std::clamp(low + (high - low) * v.f, 0.0, 1.0);
    }

    std::string shader(ShaderLanguage language, const std::string& source_name) const override {
        const auto L = shader_literal;
        const auto& r = grid_.roughness;
        const double q = r.size() > 1 ? r[1] / r[0] : 2.0;
        std::ostringstream o;
        o << shader_common(source_name);
        o << "// Anisotropic entry point: V and L are unit vectors in the tangent frame (x = tangent, y = bitangent,\n"
          << "// z = normal), alpha_x and alpha_y the GGX roughness along x and y. RGBA = a0..a3 of\n"
          << "// a0 + a1 cos(dphi) + a2 cos(2 dphi) + a3 rho; x = light node j_l * " << grid_.visibility
          << " + visibility texel, z = view node j_v * " << grid_.n_dot_v << " + NdotV texel; nodes at roughness";
        for (double x : r) o << " " << x;
        o << " (projected alpha = node^2).\n";
        o << "ENTRY(float visibility, VEC3 v_t, VEC3 l_t, float alpha_x, float alpha_y)\n{\n"
          << "    float n_dot_l = l_t.z;\n    float n_dot_v = clamp(v_t.z, 0.0, 1.0);\n"
          << "    if (ms_zero_region(visibility, n_dot_l)) return 0.0;  // early-out: no fetch\n"
          << shader_coordinates()
          << "    // Horizontal unit directions of V and L (x when one is along the normal: the term ignores it).\n"
          << "    float lv = length(v_t.xy), ll = length(l_t.xy);\n"
          << "    VEC2 uv_d = lv > 1e-7 ? v_t.xy / lv : VEC2(1.0, 0.0);\n"
          << "    VEC2 ul_d = ll > 1e-7 ? l_t.xy / ll : VEC2(1.0, 0.0);\n"
          << "    // Projected roughnesses along V and L, their slopes' correlation, and cos(dphi).\n"
          << "    VEC2 a2 = VEC2(alpha_x * alpha_x, alpha_y * alpha_y);\n"
          << "    float av2 = dot(a2, uv_d * uv_d), al2 = dot(a2, ul_d * ul_d);\n"
          << "    float rho = dot(a2, uv_d * ul_d) / sqrt(av2 * al2);\n"
          << "    float cd = dot(uv_d, ul_d);\n"
          << "    VEC4 basis = VEC4(1.0, cd, 2.0 * cd * cd - 1.0, rho);\n"
          << "    // Nodes r_k = " << L(r[0]) << " * " << L(q) << "^k: the position of sqrt(alpha) in log roughness.\n"
          << "    float kv = clamp(log(sqrt(sqrt(av2)) * " << L(1 / r[0]) << ") * " << L(1 / std::log(q)) << ", 0.0, "
          << L(double(r.size() - 1)) << ");\n"
          << "    float kl = clamp(log(sqrt(sqrt(al2)) * " << L(1 / r[0]) << ") * " << L(1 / std::log(q)) << ", 0.0, "
          << L(double(r.size() - 1)) << ");\n"
          << "    float jv = min(floor(kv), " << L(double(r.size() - 2)) << "), jl = min(floor(kl), " << L(double(r.size() - 2)) << ");\n"
          << "    float fv = kv - jv, fl = kl - jl;\n"
          << "    // The edge-roughness NdotL texel of the light's two nodes (widths k alpha max(s_e, alpha)).\n"
          << "    float al0 = " << L(r[0] * r[0]) << " * exp(jl * " << L(2 * std::log(q)) << "), al1 = al0 * " << L(q * q) << ";\n"
          << "    float tl = ms_edge_texel(n_dot_l, c_e, l0, " << L(grid_.edge_width) << " * al0 * max(s_e, al0));\n"
          << "    float tl1 = ms_edge_texel(n_dot_l, c_e, l0, " << L(grid_.edge_width) << " * al1 * max(s_e, al1));\n"
          << "    float x0 = (jl * " << L(grid_.visibility) << " + tv + 0.5) * " << L(1.0 / texture_.width) << ";\n"
          << "    float x1 = x0 + " << L(double(grid_.visibility) / texture_.width) << ";\n"
          << "    float y0 = (tl + 0.5) * " << L(1.0 / texture_.height) << ", y1 = (tl1 + 0.5) * " << L(1.0 / texture_.height) << ";\n"
          << "    float z0 = (jv * " << L(grid_.n_dot_v) << " + tz + 0.5) * " << L(1.0 / texture_.depth) << ";\n"
          << "    float z1 = z0 + " << L(double(grid_.n_dot_v) / texture_.depth) << ";\n"
          << "    VEC3 c00 = VEC3(x0, y0, z0), c10 = VEC3(x1, y1, z0), c01 = VEC3(x0, y0, z1), c11 = VEC3(x1, y1, z1);\n"
          << "    float low = MIX(dot(FETCH(c00), basis), dot(FETCH(c10), basis), fl);\n"
          << "    float high = MIX(dot(FETCH(c01), basis), dot(FETCH(c11), basis), fl);\n"
          << "    return clamp(MIX(low, high, fv), 0.0, 1.0);\n}\n";
        return finish_shader(o.str(), language);
    }

private:
    double bound_;
};

}  // namespace

std::unique_ptr<Representation> make_anisotropic_harmonics(ReprGrid grid, Texture3D texture, nlohmann::json metadata) {
    const std::uint32_t R = std::uint32_t(grid.roughness.size());
    if (R < 2 || !is_geometric(grid.roughness)) throw std::invalid_argument("anisotropic-harmonics: 2 or more geometric roughness nodes");
    if (grid.warps.n_dot_l != NdotLWarp::edge_roughness) throw std::invalid_argument("anisotropic-harmonics: the NdotL warp must be edge-roughness");
    // Its lookup reads one visibility coordinate and the NdotL width without the view factor.
    if (grid.warps.visibility == VisibilityWarp::edge_roughness || grid.n_dot_l_edge_view > 0)
        throw std::invalid_argument("anisotropic-harmonics: not with the edge-roughness visibility warp or an NdotL edge view factor");
    if (texture.width != grid.visibility * R || texture.height != grid.n_dot_l || texture.depth != grid.n_dot_v * R)
        throw std::invalid_argument("anisotropic-harmonics: texture size does not match the grid");
    const double bound = metadata.value("coefficient_bound", 0.0);
    if (!(bound > 0 && std::isfinite(bound))) throw std::invalid_argument("anisotropic-harmonics: metadata coefficient_bound must be a positive number");
    metadata["fetches_per_light"] = 4;
    return std::make_unique<AnisotropicHarmonics>(std::move(grid), std::move(texture), std::move(metadata), bound);
}

std::unique_ptr<Representation> build_anisotropic_harmonics(const ReprGrid& grid, std::vector<float> rgba, nlohmann::json metadata) {
    const std::uint32_t R = std::uint32_t(grid.roughness.size());
    Texture3D t;
    t.width = grid.visibility * R, t.height = grid.n_dot_l, t.depth = grid.n_dot_v * R;
    if (rgba.size() != std::size_t(t.width) * t.height * t.depth * 4)
        throw std::invalid_argument("anisotropic-harmonics: " + std::to_string(rgba.size()) + " values for a " +
                                    std::to_string(t.width) + " x " + std::to_string(t.height) + " x " + std::to_string(t.depth) + " RGBA texture");
    t.texels = std::move(rgba);
    if (!metadata.contains("coefficient_bound")) {
        double bound = 0;
        for (float x : t.texels) bound = std::max(bound, double(std::abs(x)));
        metadata["coefficient_bound"] = std::max(bound, 1.0);
    }
    return make_anisotropic_harmonics(grid, std::move(t), std::move(metadata));
}

}  // namespace ms::repr
