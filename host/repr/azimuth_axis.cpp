// "azimuth-axis": the relative azimuth as a fourth axis.
//
// Layout: a 3D texture of width nv * K (K azimuth slots of nv visibility texels side by side: slot k
// holds the nodes phi_k = pi k / (K - 1)), height nl (NdotL), depth nvv (NdotV); channel c of RGBA is
// roughness node c (1 to 4 nodes; missing channels repeat the last). The sampler filters visibility,
// NdotL and NdotV; the visibility coordinate is clamped to [0, nv - 1] inside its slot, so the filter
// never reads the neighbouring slot. The azimuth is blended by hand between the two slots that bracket
// it: t = phi (K - 1) / pi, k0 = min(floor(t), K - 2), weight t - k0; two fetches per light. Then the
// roughness blend across channels, as part 2's LUT does.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "lut/lut_image.hpp"
#include "lut/exr_lut.hpp"
#include "repr/texture_repr.hpp"

namespace ms::repr {

namespace {

class AzimuthAxis final : public TextureRepresentation {
public:
    using TextureRepresentation::TextureRepresentation;
    std::string kind() const override { return "azimuth-axis"; }
    std::string name() const override {
        std::ostringstream o;
        o << "azimuth as an axis: " << grid_.visibility << " visibility (" << to_string(grid_.warps.visibility) << ") x " << grid_.n_dot_l << " NdotL ("
          << to_string(grid_.warps.n_dot_l) << ") x " << grid_.n_dot_v << " NdotV (" << to_string(grid_.warps.n_dot_v) << ") x "
          << azimuth_nodes_ << " azimuth nodes, roughness";
        for (double r : grid_.roughness) o << " " << r;
        return o.str();
    }
    std::vector<std::string> channel_names() const override {
        std::vector<std::string> names;
        for (double r : grid_.roughness) names.push_back(exr_channel_name(r));
        return names;
    }

    double operator()(const approx::Inputs& in) const override {
        if (zero_region(in.visibility, in.n_dot_l)) return 0;
        const double tv = visibility_texel(in.visibility), tl = n_dot_l_texel(in.visibility, in.n_dot_l),
                     tz = n_dot_v_texel(in.n_dot_v);
        const double k_last = azimuth_nodes_ - 1;
        // The shader computes phi = acos(cos_phi); relative_azimuth is that angle already.
        const double t = std::clamp(in.relative_azimuth * k_last / M_PI, 0.0, k_last);
        const double k0 = std::min(std::floor(t), k_last - 1), f = t - k0;
        const auto s0 = texture_.sample(k0 * grid_.visibility + tv, tl, tz);
        const auto s1 = texture_.sample((k0 + 1) * grid_.visibility + tv, tl, tz);
        std::array<double, 4> s;
        for (int c = 0; c < 4; ++c) s[c] = s0[c] + (s1[c] - s0[c]) * f;
        return blend_roughness(s, in.roughness);
    }

    std::string shader(ShaderLanguage language, const std::string& source_name) const override {
        const auto L = shader_literal;
        const auto& r = grid_.roughness;
        std::ostringstream o;
        o << shader_common(source_name);
        o << "// Channels R, G, B, A = roughness";
        for (double x : r) o << " " << x;
        o << "; x = azimuth slot k (node pi k / " << azimuth_nodes_ - 1 << ") * " << grid_.visibility << " + visibility texel.\n";
        o << "float ms_blend_roughness(VEC4 s, float roughness)\n{\n";
        if (r.size() == 1) {
            o << "    return s.r;\n";
        } else {
            o << "    float r = clamp(roughness, " << L(r.front()) << ", " << L(r.back()) << ");\n";
            const char* swz = "rgba";
            for (std::size_t k = 1; k < r.size(); ++k) {
                const std::string line = std::string("MIX(s.") + swz[k - 1] + ", s." + swz[k] + ", (r - " + L(r[k - 1]) + ") * " +
                                         L(1 / (r[k] - r[k - 1])) + ")";
                if (k + 1 < r.size()) o << "    if (r <= " << L(r[k]) << ") return " << line << ";\n";
                else o << "    return " << line << ";\n";
            }
        }
        o << "}\n\n";
        o << "ENTRY(float visibility, float n_dot_l, float n_dot_v, float roughness, float cos_phi)\n{\n"
          << "    if (ms_zero_region(visibility, n_dot_l)) return 0.0;  // early-out: no fetch\n"
          << shader_coordinates()
          << "    // Azimuth slots k0 and k0 + 1 around phi, blended by hand.\n"
          << "    float ta = clamp(acos(clamp(cos_phi, -1.0, 1.0)) * " << L((azimuth_nodes_ - 1) / M_PI) << ", 0.0, "
          << L(azimuth_nodes_ - 1) << ");\n"
          << "    float k0 = min(floor(ta), " << L(azimuth_nodes_ - 2) << ");\n"
          << "    VEC3 c0 = VEC3((k0 * " << L(grid_.visibility) << " + tv + 0.5) * " << L(1.0 / texture_.width) << ", (tl + 0.5) * "
          << L(1.0 / texture_.height) << ", (tz + 0.5) * " << L(1.0 / texture_.depth) << ");\n"
          << "    VEC3 c1 = c0 + VEC3(" << L(double(grid_.visibility) / texture_.width) << ", 0.0, 0.0);\n"
          << "    VEC4 s = MIX(FETCH(c0), FETCH(c1), ta - k0);\n"
          << "    return ms_blend_roughness(s, roughness);\n}\n";
        return finish_shader(o.str(), language);
    }

private:
    double blend_roughness(const std::array<double, 4>& s, double roughness) const {
        const auto& r = grid_.roughness;
        if (r.size() == 1) return s[0];
        const double x = std::clamp(roughness, r.front(), r.back());
        for (std::size_t k = 1; k < r.size(); ++k)
            if (x <= r[k] || k + 1 == r.size()) return s[k - 1] + (s[k] - s[k - 1]) * ((x - r[k - 1]) * (1 / (r[k] - r[k - 1])));
        return s[0];
    }
};

}  // namespace

std::unique_ptr<Representation> make_azimuth_axis(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                  nlohmann::json metadata) {
    if (grid.roughness.empty() || grid.roughness.size() > 4) throw std::invalid_argument("azimuth-axis: 1 to 4 roughness nodes (RGBA)");
    if (azimuth_nodes < 2) throw std::invalid_argument("azimuth-axis: at least 2 azimuth nodes");
    // Its RGBA channels are roughness nodes sharing one NdotL axis; the edge-roughness warp gives each
    // node its own.
    if (grid.warps.n_dot_l == NdotLWarp::edge_roughness)
        throw std::invalid_argument("azimuth-axis: the edge-roughness NdotL warp needs an NdotL axis per roughness node (azimuth-harmonics)");
    if (grid.warps.visibility == VisibilityWarp::edge_roughness)
        throw std::invalid_argument("azimuth-axis: the edge-roughness visibility warp needs a visibility axis per roughness node (azimuth-harmonics)");
    // Its azimuth slots are the same nodes for every texel; the far-side warp moves them per texel.
    if (grid.azimuth_warp > 0) throw std::invalid_argument("azimuth-axis: the far-side azimuth warp is for azimuth-harmonics");
    if (texture.width != grid.visibility * azimuth_nodes || texture.height != grid.n_dot_l || texture.depth != grid.n_dot_v)
        throw std::invalid_argument("azimuth-axis: texture size does not match the grid");
    metadata["fetches_per_light"] = 2;
    return std::make_unique<AzimuthAxis>(std::move(grid), azimuth_nodes, std::move(texture), std::move(metadata));
}

std::unique_ptr<Representation> build_azimuth_axis(const AzimuthBake& bake) {
    const auto& g = bake.grid;
    if (g.roughness.empty() || g.roughness.size() > 4)
        throw std::invalid_argument("azimuth-axis: the bake needs 1 to 4 roughness nodes (one per RGBA channel)");
    Texture3D t;
    t.width = g.visibility * bake.azimuth_nodes;
    t.height = g.n_dot_l;
    t.depth = g.n_dot_v;
    t.texels.resize(std::size_t(t.width) * t.height * t.depth * 4);
    for (std::uint32_t k = 0; k < bake.azimuth_nodes; ++k)
        for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
            for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                for (std::uint32_t iv = 0; iv < g.visibility; ++iv)
                    for (std::uint32_t c = 0; c < 4; ++c) {
                        const std::uint32_t r = std::min<std::uint32_t>(c, std::uint32_t(g.roughness.size()) - 1);
                        const std::size_t x = std::size_t(k) * g.visibility + iv;
                        t.texels[((std::size_t(ivv) * t.height + il) * t.width + x) * 4 + c] = bake.value[bake.index(r, k, iv, il, ivv)];
                    }
    nlohmann::json meta = {{"bake", bake.metadata}};
    for (const char* key : {"version", "command_line", "domain", "preset"})
        if (bake.metadata.contains(key)) meta[key] = bake.metadata[key];
    return make_azimuth_axis(g, bake.azimuth_nodes, std::move(t), std::move(meta));
}

}  // namespace ms::repr
