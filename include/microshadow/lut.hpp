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
};

// A baked or loaded LUT: texels over (visibility, NdotL, NdotV) per roughness channel, sampled as a
// renderer does (linear filtering, clamp to edge, linear blend between roughness channels).
class Lut {
public:
    std::uint32_t visibility_count() const;
    std::uint32_t n_dot_l_count() const;
    std::uint32_t n_dot_v_count() const;  // 1 for a 2D LUT (it stands for NdotV = 1)
    std::vector<double> roughness() const;  // of each channel, in channel order
    // The stored texel of channel c at indices (visibility, NdotL, NdotV).
    float texel(std::uint32_t channel, std::uint32_t visibility, std::uint32_t n_dot_l, std::uint32_t n_dot_v) const;
    // The renderer's lookup. Throws std::domain_error where a partial bake left the texels unbaked.
    double lookup(double visibility, double n_dot_l, double n_dot_v, double roughness) const;
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

Lut bake(const BakeOptions& options = {});
// Opens a LUT file in any format the bake writes (std::runtime_error naming the file and problem).
Lut open_lut(const std::string& path);

}  // namespace microshadow
