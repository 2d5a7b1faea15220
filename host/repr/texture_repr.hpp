// The two texture representations (representation.hpp describes them) and what they share: the 3D
// texture, its trilinear sampling as a GPU does it, the warped texel coordinates, the shader text and
// its cost. Internal to host/repr/: everything else sees representation.hpp.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "lut/shader/alu_count.hpp"
#include "repr/representation.hpp"

namespace ms::repr {

// A 3D texture of RGBA floats sampled with linear filtering and clamp-to-edge, as a GPU does, from
// continuous texel coordinates (texel centres at integers): the caller clamps each coordinate to
// [0, n - 1] first, so the sampler's own clamping never acts.
struct Texture3D {
    std::uint32_t width = 0, height = 0, depth = 0;
    std::vector<float> texels;  // RGBA, x fastest, then y, then z
    std::array<double, 4> sample(double x, double y, double z) const;
    // The texels sample() blends and their weights (texel numbers, x fastest; zero weights included):
    // sample() is sum_k weight_k texel_k.
    std::array<std::pair<std::size_t, double>, 8> corners(double x, double y, double z) const;
};

class TextureRepresentation : public Representation {
public:
    TextureRepresentation(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture, nlohmann::json metadata);

    std::uint32_t texture_width() const override { return texture_.width; }
    std::uint32_t texture_height() const override { return texture_.height; }
    std::uint32_t texture_depth() const override { return texture_.depth; }
    const std::vector<float>& texels() const override { return texture_.texels; }
    const ReprGrid& grid() const override { return grid_; }
    nlohmann::json provenance() const override;
    approx::Cost cost() const override;
    lutfmt::TextureData texture_file(lutfmt::TextureFormat format, bool half) const override;
    const nlohmann::json& metadata() const { return metadata_; }
    // The metadata's "domain", or without one the grid's: its roughness nodes' range, any visibility,
    // NdotL and NdotV (core/lookup_domain.hpp).
    std::optional<LookupDomain> domain() const override { return domain_; }
    std::uint32_t azimuth_nodes() const { return azimuth_nodes_; }
    // EXR channel names of the meaningful channels (the texture repeats the last one up to RGBA).
    virtual std::vector<std::string> channel_names() const = 0;
    // The values a baked texel of RGBA channel c can hold: [0, 1] for a term value.
    virtual std::array<double, 2> channel_range(std::size_t c) const {
        (void)c;
        return {0.0, 1.0};
    }
    // Checks what a file gave: `file_channels` (the metadata's texture.channels) are the kind's own
    // channel_names(), each once, and every texel is inside its channel_range(). Throws
    // std::runtime_error naming the channel or the first texel outside (x, y, z and channel).
    void check_contents(const std::vector<std::string>& file_channels) const;

protected:
    // The metadata every file of this representation records ("microshadow"): the bake's, plus kind,
    // grid, azimuth nodes, texture layout, file format and precision.
    nlohmann::json file_metadata(const std::string& file_format, bool half) const;
    // True where the term is 0 by rule: NdotL <= 0 or in the zero region of the grid's AO weighting
    // (lut/lookup.hpp's lookup_zero_region: decided in binary32, as the shaders decide it).
    bool zero_region(double visibility, double n_dot_l) const;
    // Clamped texel coordinates of (visibility, NdotL, NdotV) within one block of the texture.
    double visibility_texel(double visibility, std::uint32_t roughness_node = 0, double n_dot_v = 1) const;
    double n_dot_l_texel(double visibility, double n_dot_l, std::uint32_t roughness_node = 0, double n_dot_v = 1) const;
    double n_dot_v_texel(double n_dot_v) const;
    // Shader text shared by both kinds: header comment lines, the zero region, the three coordinates
    // (statements that set tv, tl, tz), written in GLSL with VEC3/VEC4/MIX/FETCH placeholders.
    std::string shader_common(const std::string& source_name) const;
    std::string shader_coordinates() const;
    // The GLSL expression of an NdotL or NdotV texel coordinate from the warped coordinate `u` on an
    // n-texel axis (ReprGrid::texel_of written out).
    std::string axis_texel(const std::string& u, std::uint32_t n) const;
    // Replaces the placeholders for the language and adds the entry point's signature.
    std::string finish_shader(const std::string& body, ShaderLanguage language) const;

    ReprGrid grid_;
    std::uint32_t azimuth_nodes_;
    Texture3D texture_;
    nlohmann::json metadata_;
    LookupDomain domain_;
};

// The grid as the file's metadata records it, and back (std::runtime_error naming the field).
nlohmann::json grid_to_json(const ReprGrid& grid);
ReprGrid grid_from_json(const nlohmann::json& j);

// A float literal both languages read as the same binary32 value.
std::string shader_literal(double v);
// ALU estimate of a generated shader (lut/shader/alu_count.hpp).
using lutshader::count_alu;

std::unique_ptr<Representation> make_azimuth_axis(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                  nlohmann::json metadata);
std::unique_ptr<Representation> make_anisotropic_harmonics(ReprGrid grid, Texture3D texture, nlohmann::json metadata);
// anisotropic_mapped: the "anisotropic-mapped-harmonics" kind (harmonics.cpp), the same texture looked up
// at an anisotropic surface's isotropic equivalent.
std::unique_ptr<Representation> make_azimuth_harmonics(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                       nlohmann::json metadata, bool anisotropic_mapped = false);
// How an azimuth-harmonics texture is looked up: at the caller's isotropic inputs, at an anisotropic
// surface's isotropic equivalent, or there plus the anisotropy correction of the texture's second block.
enum class HarmonicsLookup { isotropic, mapped, corrected };
// The "anisotropic-corrected-harmonics" kind: texture depth 2 n_dot_v R (the harmonics' slabs, then the
// correction's); metadata records "correction_bound".
std::unique_ptr<Representation> make_anisotropic_corrected(ReprGrid grid, std::uint32_t azimuth_nodes, Texture3D texture,
                                                           nlohmann::json metadata);

}  // namespace ms::repr
