#include "repr/texture_repr.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "io/exr_file.hpp"
#include "lut/formats/texture.hpp"
#include "lut/lookup.hpp"
#include "lut/shader/alu_count.hpp"
#include "lut/shader/compose.hpp"
#include "lut/shader/wgsl.hpp"

namespace ms::repr {

std::array<double, 4> Texture3D::sample(double x, double y, double z) const {
    // The trilinear blend a linear sampler computes, over the eight corners() and their weights.
    std::array<double, 4> out{0, 0, 0, 0};
    for (const auto& [texel, w] : corners(x, y, z)) {
        if (w == 0) continue;
        for (int c = 0; c < 4; ++c) out[c] += w * texels[texel * 4 + c];
    }
    return out;
}

std::array<std::pair<std::size_t, double>, 8> Texture3D::corners(double x, double y, double z) const {
    // Texels floor(t) and floor(t) + 1 per axis with weight frac(t); the +1 neighbour is clamped to the
    // edge (its weight is 0 there anyway). Corner k takes the +1 texel on axis a where bit a of k is set.
    const double t[3] = {x, y, z};
    const std::uint32_t n[3] = {width, height, depth};
    std::uint32_t i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        const double c = std::clamp(t[a], 0.0, double(n[a] - 1));
        i0[a] = std::uint32_t(std::floor(c));
        i1[a] = std::min(i0[a] + 1, n[a] - 1);
        f[a] = c - i0[a];
    }
    std::array<std::pair<std::size_t, double>, 8> out;
    for (int corner = 0; corner < 8; ++corner) {
        double w = 1;
        std::uint32_t idx[3];
        for (int a = 0; a < 3; ++a) {
            const bool hi = (corner >> a) & 1;
            w *= hi ? f[a] : 1 - f[a];
            idx[a] = hi ? i1[a] : i0[a];
        }
        out[corner] = {(std::size_t(idx[2]) * height + idx[1]) * width + idx[0], w};
    }
    return out;
}

TextureRepresentation::TextureRepresentation(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                             nlohmann::json metadata)
    : grid_(std::move(grid)), azimuth_nodes_(azimuth_nodes), texture_(std::move(texture)), metadata_(std::move(metadata)) {
    if (metadata_.is_object() && metadata_.contains("domain")) {
        domain_ = LookupDomain::from_json(metadata_.at("domain"), "representation");
        // The roughness a file answers for cannot exceed its nodes: outside them the lookup clamps.
        if (domain_.roughness_min < grid_.roughness.front() - 1e-12 || domain_.roughness_max > grid_.roughness.back() + 1e-12)
            throw std::runtime_error("metadata domain.roughness [" + shader_literal(domain_.roughness_min) + ", " +
                                     shader_literal(domain_.roughness_max) + "] exceeds the roughness nodes' range");
    } else {
        domain_ = grid_domain(grid_);
    }
}

LookupDomain grid_domain(const ReprGrid& grid, double visibility_min, double visibility_max, double n_dot_v_min,
                         double n_dot_v_max) {
    LookupDomain d;
    d.roughness_min = grid.roughness.front();
    d.roughness_max = grid.roughness.back();
    d.visibility_min = visibility_min;
    d.visibility_max = visibility_max;
    d.n_dot_v_min = n_dot_v_min;
    d.n_dot_v_max = n_dot_v_max;
    return d;
}

// The one early-out of every lookup, decided in binary32 as the generated shaders decide it.
bool TextureRepresentation::zero_region(double v, double l) const { return lookup_zero_region(grid_.weighting, v, l); }

double TextureRepresentation::visibility_texel(double v, std::uint32_t ir, double nv) const { return grid_.visibility_texel_of(v, ir, nv); }
double TextureRepresentation::n_dot_l_texel(double v, double l, std::uint32_t ir, double nv) const {
    return grid_.texel_of(grid_.n_dot_l_u(v, l, ir, nv), grid_.n_dot_l);
}
double TextureRepresentation::n_dot_v_texel(double nv) const { return grid_.texel_of(grid_.n_dot_v_u(nv), grid_.n_dot_v); }

void TextureRepresentation::check_contents(const std::vector<std::string>& file_channels) const {
    const std::vector<std::string> expected = channel_names();
    for (std::size_t i = 0; i < file_channels.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (file_channels[i] == file_channels[j])
                throw std::runtime_error("texture.channels names channel " + file_channels[i] + " twice");
    if (file_channels != expected) {
        std::string want, got;
        for (const auto& n : expected) want += (want.empty() ? "" : ", ") + n;
        for (const auto& n : file_channels) got += (got.empty() ? "" : ", ") + n;
        throw std::runtime_error("texture.channels [" + got + "] are not the channels of this " + kind() + " grid [" + want +
                                 "]");
    }
    const std::size_t texels = std::size_t(texture_.width) * texture_.height * texture_.depth;
    for (std::size_t i = 0; i < texels; ++i)
        for (std::size_t c = 0; c < 4; ++c) {
            const double v = texture_.texels[i * 4 + c];
            const auto range = channel_range(c);
            if (v >= range[0] && v <= range[1]) continue;
            const std::size_t x = i % texture_.width, y = i / texture_.width % texture_.height,
                              z = i / (std::size_t(texture_.width) * texture_.height);
            const std::string channel = expected[std::min(c, expected.size() - 1)];
            throw std::runtime_error("texel (" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) +
                                     ") channel " + channel + " is " + shader_literal(v) + ", outside [" +
                                     shader_literal(range[0]) + ", " + shader_literal(range[1]) + "]");
        }
}

approx::Cost TextureRepresentation::cost() const {
    approx::Cost c;
    // As a renderer uploads it: RGBA16F (8 bytes a texel), whatever the file's own precision.
    c.bytes = std::uint64_t(texture_.width) * texture_.height * texture_.depth * 8;
    c.fetches_per_light = metadata_.value("fetches_per_light", 2u);
    c.alu_per_light = count_alu(shader(ShaderLanguage::glsl, "cost"));
    c.storage = "3D texture " + std::to_string(texture_.width) + "x" + std::to_string(texture_.height) + "x" +
                std::to_string(texture_.depth) + " RGBA16F";
    return c;
}

nlohmann::json TextureRepresentation::provenance() const {
    nlohmann::json j = {{"kind", "representation"}, {"representation", kind()}, {"description", name()}};
    const auto c = cost();
    j["cost"] = {{"bytes", c.bytes}, {"fetches_per_light", c.fetches_per_light}, {"alu_per_light", c.alu_per_light},
                 {"storage", c.storage}};
    for (const char* key : {"version", "command_line", "preset"})
        if (metadata_.contains(key)) j[key] = metadata_[key];
    j["domain"] = domain_.to_json();
    // How its texels were computed (exact or sampled): what a comparator column of it stands on.
    // And whether they met the tolerance asked of them (recorded by repr bake; absent when none was asked).
    if (metadata_.contains("bake") && metadata_["bake"].is_object())
        for (const char* key : {"method", "tolerance_met", "queries_over_tolerance"})
            if (metadata_["bake"].contains(key)) j[key] = metadata_["bake"][key];
    return j;
}

nlohmann::json TextureRepresentation::file_metadata(const std::string& file_format, bool half) const {
    nlohmann::json meta = metadata_;
    meta["kind"] = "representation";
    meta["representation"] = kind();
    meta["file_format"] = file_format;
    meta["half"] = half;
    meta["grid"] = grid_to_json(grid_);
    meta["azimuth_nodes"] = azimuth_nodes_;
    meta["domain"] = domain_.to_json("the lookups this representation was made for; outside, its axes clamp");
    meta["texture"] = {{"width", texture_.width}, {"height", texture_.height}, {"depth", texture_.depth}, {"channels", channel_names()}};
    return meta;
}

lutfmt::TextureData TextureRepresentation::texture_file(lutfmt::TextureFormat format, bool half) const {
    if (!lutfmt::format_allowed(format, lutfmt::TextureUse::representation))
        throw std::invalid_argument("a representation is written as " + lutfmt::extension_list(lutfmt::TextureUse::representation) +
                                    ", not " + lutfmt::to_string(format));
    // The texture as it is held: already RGBA (channel_names() says which channels hold data; the rest
    // repeat the last), one level.
    lutfmt::TextureData d;
    d.width = texture_.width, d.height = texture_.height, d.depth = texture_.depth;
    d.channels = 4;
    d.levels = {texture_.texels};
    d.metadata = file_metadata(lutfmt::to_string(format), half);
    if (format == lutfmt::TextureFormat::exr) {
        // The atlas: depth slice z occupies rows [z * height, (z + 1) * height); the EXR names only the
        // meaningful channels, and records the metadata as one attribute.
        d.channel_names = channel_names();
        d.exr_typed_metadata = false;
        d.exr_attributes = {{"microshadow.kind", std::string("representation")},
                            {"microshadow.representation", kind()},
                            {"oiio:UnassociatedAlpha", 1}};
    }
    return d;
}

std::string shader_literal(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", double(float(v)));
    std::string s = buf;
    if (s.find_first_of(".eE") == std::string::npos) s += ".0";
    return s;
}

std::string TextureRepresentation::shader_common(const std::string& source_name) const {
    std::ostringstream o;
    o << "// Micro-shadowing " << kind() << " sampler for " << source_name << ", generated by microshadow "
      << MICROSHADOW_VERSION << " from the file's metadata. Do not edit: regenerate with the file.\n"
      << "// " << name() << ".\n"
      << "// Texture: 3D, " << texture_.width << " x " << texture_.height << " x " << texture_.depth
      << " RGBA (RGBA16F in an engine); upload one level, no mips; sampler: linear, clamp-to-edge, level 0.\n"
      << "// Axes (texel centres at (i + 0.5) / n of the warped coordinate): visibility "
      << (grid_.warps.visibility == VisibilityWarp::sqrt_top ? std::string("u = 1 - sqrt(1 - v)")
          : grid_.warps.visibility == VisibilityWarp::edge_roughness
              ? "per roughness slab, of the cone's cosine c(v), H = 1 - sqrt(1 - c) + " +
                    shader_literal(grid_.visibility_edge_share) + " asinh(c / s) / asinh(1 / s), s = " +
                    shader_literal(grid_.visibility_edge_width) + " min(alpha, " + shader_literal(grid_.visibility_edge_view) +
                    " NdotV), texels evenly in H down to v = 1"
              : std::string("linear"))
      << "; NdotL "
      << (grid_.warps.n_dot_l == NdotLWarp::shadow_edge ? "from the shadow edge, u = (NdotL - l0(v)) / (1 - l0(v))"
          : grid_.warps.n_dot_l == NdotLWarp::sqrt_top ? "u = 1 - sqrt(1 - NdotL)"
          : grid_.warps.n_dot_l == NdotLWarp::edge_roughness
              ? "per roughness slab, g(x) = asinh((x - c(v)) / w), w = " + shader_literal(grid_.edge_width) +
                    " alpha max(sin theta_c, alpha)" +
                    (grid_.n_dot_l_edge_view > 0 ? " (at most " + shader_literal(grid_.n_dot_l_edge_view) + " (NdotV + c))" : std::string()) +
                    ", u = (g(NdotL) - g(l0(v))) / (g(1) - g(l0(v)))"
              : std::string("linear"))
      << "; NdotV " << (grid_.warps.n_dot_v == NdotVWarp::sqrt ? "u = sqrt(NdotV)" : "linear") << ".\n"
      << "// cos_phi: cosine of the relative azimuth of L and V (their projections on the surface,\n"
      << "// normalised; 1 when either is along the normal). Anisotropic GGX: roughness = (alpha_x alpha_y)^(1/4).\n\n";
    o << "bool ms_zero_region(float visibility, float n_dot_l)\n{\n";
    if (grid_.weighting == AoWeighting::cosine)
        o << "    // Cosine AO: the term is 0 for NdotL <= 1 - 2 v (and below the horizon).\n"
          << "    return n_dot_l <= 0.0 || 2.0 * visibility + n_dot_l <= 1.0;\n}\n\n";
    else
        o << "    // Uniform AO: the term is 0 for NdotL <= 2 (1 - v)^2 - 1 (and below the horizon).\n"
          << "    // Compared as NdotL + 1 <= 2 cos_t^2: no multiply-add can round it differently (host/lut/lookup.hpp).\n"
          << "    float cos_t = 1.0 - visibility;\n    return n_dot_l <= 0.0 || n_dot_l + 1.0 <= 2.0 * cos_t * cos_t;\n}\n\n";
    if (grid_.warps.n_dot_l == NdotLWarp::edge_roughness || grid_.azimuth_warp > 0)
        o << lutshader::shared_helper("ms_asinh", lutshader::ShaderLanguage::glsl) << "\n";  // the same in HLSL
    if (grid_.warps.n_dot_l == NdotLWarp::edge_roughness) {
        o << "// The NdotL texel of one roughness slab: the distance to the shadow edge c in units of the slab's\n"
          << "// width w, through asinh, from g(l0) (the zero region's edge) to g(1); clamped to [0, n - 1].\n"
          << "float ms_edge_texel(float n_dot_l, float c, float l0, float w)\n{\n"
          << "    float g0 = ms_asinh((l0 - c) / w);\n"
          << "    float u = (ms_asinh((n_dot_l - c) / w) - g0) / (ms_asinh((1.0 - c) / w) - g0);\n"
          << "    return " << axis_texel("u", grid_.n_dot_l) << ";\n}\n\n";
    }
    if (grid_.warps.visibility == VisibilityWarp::edge_roughness) {
        const auto L = shader_literal;
        const double b = grid_.visibility_edge_share, c0 = grid_.edge_cos(grid_.visibility_start), last = grid_.visibility - 1.0;
        o << "// The visibility texel of one roughness slab: of the cone's cosine c (e = 1 - sqrt(1 - c)),\n"
          << "// H(c) = e + " << L(b) << " asinh(c / s) / asinh(1 / s), texels evenly in H from the first (c0 = " << L(c0)
          << ") down to H = 0 (v = 1); clamped to [0, n - 1].\n"
          << "float ms_edge_visibility_texel(float e, float c, float s)\n{\n"
          << "    float a1 = ms_asinh(1.0 / s);\n"
          << "    float h = e + " << L(b) << " * ms_asinh(c / s) / a1;\n"
          << "    float h0 = " << L(1 - std::sqrt(1 - c0)) << " + " << L(b) << " * ms_asinh(" << L(c0) << " / s) / a1;\n"
          << "    return clamp((1.0 - h / h0) * " << L(last) << ", 0.0, " << L(last) << ");\n}\n\n";
    }
    return o.str();
}

std::string TextureRepresentation::axis_texel(const std::string& u, std::uint32_t n) const {
    const auto L = shader_literal;
    if (grid_.placement == TexelPlacement::ends) return "clamp(" + u + " * " + L(n - 1.0) + ", 0.0, " + L(n - 1.0) + ")";
    return "clamp(" + u + " * " + L(n) + " - 0.5, 0.0, " + L(n - 1.0) + ")";
}

std::string TextureRepresentation::shader_coordinates() const {
    const auto L = shader_literal;
    std::ostringstream o;
    o << "    // Texel coordinates within a block, clamped to [0, n - 1] as host/repr/texture_repr.cpp does.\n";
    // The edge-roughness visibility warp's texel is per roughness slab (the sampler's body), from the
    // elevation e_v set with the NdotL coordinates below.
    const bool edge_visibility = grid_.warps.visibility == VisibilityWarp::edge_roughness;
    if (edge_visibility) {
    } else if (grid_.warps.visibility == VisibilityWarp::sqrt_top) {
        o << "    float uv = 1.0 - sqrt(max(1.0 - visibility, 0.0));\n";
    } else {
        o << "    float uv = visibility;\n";
    }
    if (edge_visibility) {
    } else if (grid_.visibility_start > 0 && grid_.visibility > 1) {
        // Texels from the start's coordinate u0 to the last cell centre u1, evenly.
        const double u0 = grid_.visibility_u(grid_.visibility_start), u1 = (grid_.visibility - 0.5) / grid_.visibility;
        o << "    float tv = clamp((uv - " << L(u0) << ") * " << L((grid_.visibility - 1) / (u1 - u0)) << ", 0.0, "
          << L(grid_.visibility - 1) << ");\n";
    } else {
        o << "    float tv = clamp(uv * " << L(grid_.visibility) << " - 0.5, 0.0, " << L(grid_.visibility - 1) << ");\n";
    }
    if (grid_.warps.n_dot_l == NdotLWarp::linear) {
        o << "    float ul = n_dot_l;\n";
    } else if (grid_.warps.n_dot_l == NdotLWarp::sqrt_top) {
        o << "    float ul = 1.0 - sqrt(max(1.0 - n_dot_l, 0.0));\n";
    } else if (grid_.warps.n_dot_l == NdotLWarp::edge_roughness) {
        o << "    // NdotL per roughness slab (ms_edge_texel) from the cone's cosine c_e and the zero region's edge l0.\n";
        if (grid_.weighting == AoWeighting::cosine)
            o << "    float c_e = sqrt(max(1.0 - visibility, 0.0));\n    float l0 = max(1.0 - 2.0 * visibility, 0.0);\n";
        else o << "    float c_e = 1.0 - visibility;\n    float l0 = max(2.0 * c_e * c_e - 1.0, 0.0);\n";
        o << "    float s_e = sqrt(max(1.0 - c_e * c_e, 0.0));  // sin of the cone's half-angle\n";
        if (grid_.n_dot_l_edge_view > 0)
            o << "    // The NdotL widths' cap: a grazing view meeting a cone edge near the horizon shadows on this scale.\n"
              << "    float w_cap = " << L(grid_.n_dot_l_edge_view) << " * (max(n_dot_v, " << L(kViewFloor) << ") + c_e);\n";
        if (edge_visibility)
            o << "    // The visibility warp's linear part, 1 - sqrt(1 - c) (~ the cone's angle near v = 0), and its scales' view bound.\n"
              << "    float e_v = 1.0 - sqrt(max(1.0 - c_e, 0.0));\n"
              << "    float s_view = "
              << (grid_.visibility_edge_view > 0 ? L(grid_.visibility_edge_view) + " * max(n_dot_v, " + L(kViewFloor) + ")" : std::string("1.0"))
              << ";\n";
    } else {
        o << "    // NdotL from the shadow edge l0(v): no texel lies in the zero region (l0 < 1 outside it).\n";
        if (grid_.weighting == AoWeighting::cosine) o << "    float l0 = max(1.0 - 2.0 * visibility, 0.0);\n";
        else o << "    float c_t = 1.0 - visibility;\n    float l0 = max(2.0 * c_t * c_t - 1.0, 0.0);\n";
        o << "    float ul = (n_dot_l - l0) / (1.0 - l0);\n";
    }
    if (grid_.warps.n_dot_l != NdotLWarp::edge_roughness) o << "    float tl = " << axis_texel("ul", grid_.n_dot_l) << ";\n";
    const std::string warped_v = grid_.warps.n_dot_v == NdotVWarp::sqrt ? "sqrt(max(n_dot_v, 0.0))" : "n_dot_v";
    if (grid_.placement == TexelPlacement::ends) {
        // From the first texel's NdotV (w0 = its warped value) to 1: u = (w - w0) / (1 - w0).
        const double w0 = grid_.warps.n_dot_v == NdotVWarp::sqrt ? std::sqrt(grid_.n_dot_v_start) : grid_.n_dot_v_start;
        o << "    float uz = (" << warped_v << " - " << L(w0) << ") * " << L(1 / (1 - w0)) << ";\n";
    } else {
        o << "    float uz = " << warped_v << ";\n";
    }
    o << "    float tz = " << axis_texel("uz", grid_.n_dot_v) << ";\n";
    return o.str();
}

std::string TextureRepresentation::finish_shader(const std::string& body, ShaderLanguage language) const {
    if (language == ShaderLanguage::wgsl) return lutshader::glsl_to_wgsl(finish_shader(body, ShaderLanguage::glsl));
    const bool glsl = language == ShaderLanguage::glsl;
    std::string s = body;
    auto replace_all = [&](const std::string& from, const std::string& to) {
        for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
    };
    replace_all("ENTRY(", glsl ? "float ms_micro_shadowing(sampler3D ms_tex, "
                               : "float ms_micro_shadowing(Texture3D<float4> ms_tex, SamplerState linear_clamp, ");
    replace_all("VEC2", glsl ? "vec2" : "float2");
    replace_all("VEC3", glsl ? "vec3" : "float3");
    replace_all("VEC4", glsl ? "vec4" : "float4");
    replace_all("MIX(", glsl ? "mix(" : "lerp(");
    s = std::regex_replace(s, std::regex(R"(FETCH\((\w+)\))"), glsl ? "textureLod(ms_tex, $1, 0.0)" : "ms_tex.SampleLevel(linear_clamp, $1, 0.0)");
    return s;
}

}  // namespace ms::repr
