// Baking LUTs, opening LUT files, looking them up (included by <microshadow/microshadow.hpp>).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// A LUT bake. layout "seed-3d" (visibility x NdotL x NdotV, roughness 0.1, 0.4, 0.7, 1 in RGBA),
// "seed-2d" (the NdotV = 1 slice) or "custom" (roughness and ranges from here); every axis `size`
// texels unless its own count is set. The relative azimuth is averaged over [0, 180] degrees.
struct BakeOptions {
    std::string layout = "seed-3d";
    std::uint32_t size = 32;
    std::uint32_t visibility_count = 0, n_dot_l_count = 0, n_dot_v_count = 0;  // 0: size
    std::vector<double> roughness;  // custom layout: 1 to 4 values in (0, 1]; empty: the seed's
    double tolerance = 0;  // > 0: add batches until every texel's standard error is at most this
    SamplingOptions sampling{Method::sampled, Backend::opencl, "default", 0};  // samples 0: the default batch
    std::string texel = "centres";  // texel parameters: "centres" (i + 0.5) / n or "endpoints" i / (n - 1)
    std::string azimuth = "mean";   // "mean" (the mean over [0, 180] degrees) or a fixed angle in degrees
    // custom layout: the axis ranges as {min, max} (empty: [0, 1])
    std::vector<double> visibility_range, n_dot_l_range, n_dot_v_range;
    std::uint32_t max_batches = 64;  // most batches per slice with a sampled tolerance
};

// A baked or loaded LUT: texels over (visibility, NdotL, NdotV) per roughness channel, sampled as a
// renderer does (linear filtering, clamp to edge, linear blend between roughness channels).
class Lut {
public:
    std::uint32_t visibility_count() const;
    std::uint32_t n_dot_l_count() const;
    std::uint32_t n_dot_v_count() const;  // 1 for a 2D LUT (it stands for NdotV = 1)
    std::vector<double> roughness() const;  // of each channel, in channel order
    // The parameter of each texel along an axis ("visibility", "n_dot_l" or "n_dot_v").
    std::vector<double> axis_values(const std::string& axis) const;
    // Every texel, laid out [n_dot_v][n_dot_l][visibility][channel] (the channel fastest).
    std::vector<float> texels() const;
    // The stored texel of channel c at indices (visibility, NdotL, NdotV).
    float texel(std::uint32_t channel, std::uint32_t visibility, std::uint32_t n_dot_l, std::uint32_t n_dot_v) const;
    // The renderer's lookup. Throws std::invalid_argument naming the input when one is not a number
    // (NaN), std::domain_error where a partial bake left the texels unbaked.
    double lookup(double visibility, double n_dot_l, double n_dot_v, Roughness roughness) const;
    // The bound on |texel - term| the file records (sampling + azimuth quadrature + quantisation).
    double max_total_error() const;
    // How the LUT was made, as JSON (the file's "microshadow" metadata).
    std::string metadata_json() const;
    // Writes the LUT; the format from the extension (.exr, .ktx2, .dds + .dds.json, .h/.hpp, .inc,
    // .png), the encoding "float32", "float16", "unorm8" or "unorm16" (empty: the format's default).
    void save(const std::string& path, const std::string& encoding = "") const;

    struct Data;  // the engine's LUT (opaque)
    explicit Lut(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

// `progress` is told (slices done, slices) and may stop the bake.
Lut bake(const BakeOptions& options = {}, const Progress& progress = {});
// Opens a LUT file in any format the bake writes (std::runtime_error naming the file and problem).
Lut open_lut(const std::string& path);

// What a renderer's lookup (and part 1's analytic terms) read of a query, as `eval --compare` and the
// sweeps compute it: the visibility, NdotL = wo_z and NdotV = wi_z of the normalised directions, the
// isotropic-equivalent roughness (alpha_x alpha_y)^(1/4), and the relative azimuth between the
// tangent-plane projections of wi and wo in degrees in [0, 180] (0 when either is along the normal).
struct LookupInputs {
    double visibility = 1, n_dot_l = 1, n_dot_v = 1, roughness = 0.5, relative_azimuth_deg = 0;
};
LookupInputs lookup_inputs(const Query& query);

// Any file a renderer samples: a LUT of bake() (any format) or a representation of `microshadow repr
// bake` (OpenEXR, KTX2 or DDS), which also keeps the relative azimuth between view and light.
class LookupFile {
public:
    // "lut", or the representation's kind ("azimuth-axis", "azimuth-harmonics").
    std::string kind() const;
    bool keeps_azimuth() const;  // a representation: lookup reads the relative azimuth
    // The renderer's lookup at the relative azimuth in degrees in [0, 180] (a LUT ignores it). Throws
    // std::invalid_argument naming the input when one is not a number (NaN), std::domain_error where
    // a partial bake left the LUT unbaked.
    double lookup(double visibility, double n_dot_l, double n_dot_v, Roughness roughness,
                  double relative_azimuth_deg = 0) const;
    // The file's "microshadow" metadata as JSON.
    std::string metadata_json() const;
    // The LUT itself (kind() == "lut"); std::logic_error for a representation.
    const Lut& lut() const;
    // A representation's texture as a renderer uploads it: width x height x depth texels of RGBA,
    // laid out [depth][height][width][4] (for a LUT: lut().texels()).
    std::uint32_t texture_width() const;
    std::uint32_t texture_height() const;
    std::uint32_t texture_depth() const;
    std::vector<float> texture() const;
    // Writes the file: a LUT as Lut::save (encoding as there, half: "float16"); a representation as
    // `repr bake --out`: .exr (what eval --compare and sweeps open), .ktx2 or .dds (+ .dds.json), half:
    // 16-bit channels.
    void save(const std::string& path, bool half = false) const;

    struct Data;
    explicit LookupFile(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

// Opens a LUT or representation file, told apart by its metadata (std::runtime_error naming the file).
LookupFile open_file(const std::string& path);

// A representation bake (`microshadow repr bake`, docs/representations.md): the term at
// `azimuth_nodes` relative azimuths over [0, 180] degrees per texel, built into `kind`; or a preset.
struct ReprBakeOptions {
    // A preset's name ("full-range", "realistic", "anisotropic": `repr bake --preset`): its kind and
    // whole layout, the fields below up to the sampling left at their defaults (std::invalid_argument
    // otherwise, as the CLI refuses layout options beside --preset). Empty: the layout below.
    std::string preset;
    std::string kind = "azimuth-harmonics";  // or "azimuth-axis" (1 to 4 roughness nodes)
    std::uint32_t visibility_count = 16, n_dot_l_count = 16, n_dot_v_count = 16;
    std::uint32_t azimuth_nodes = 9;
    std::vector<double> roughness{0.1, 0.4, 0.7, 1.0};  // increasing
    std::uint32_t roughness_count = 0;  // > 0: keep this many of `roughness`, chosen by error
    std::string n_dot_v_warp = "linear";     // or "sqrt"
    std::string n_dot_l_warp = "linear";     // or "shadow-edge", "sqrt-top"
    std::string visibility_warp = "linear";  // or "sqrt-top"
    SamplingOptions sampling{Method::exact};
};
LookupFile repr_bake(const ReprBakeOptions& options = {}, const Progress& progress = {});

}  // namespace microshadow
