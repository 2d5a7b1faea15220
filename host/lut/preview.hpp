// A PNG picture of a LUT atlas, like part 2's figure: one tile per (NdotV slice, roughness channel),
// roughness across, NdotV down (at most max_slices slices, evenly spaced), visibility to the right and
// NdotL downwards inside a tile, values 0..1 as grey, a small gap between tiles.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ms {

struct LutPreviewInput {
    std::uint32_t visibility_count = 0, n_dot_l_count = 0, n_dot_v_count = 0, channels = 0;
    const float* data = nullptr;  // LutFile::data layout: ((ivv * nl + il) * nv + iv) * channels + c
};

// Writes atomically; throws std::runtime_error. Tiles are magnified (nearest texel) to >= 96 pixels.
void write_lut_preview(const std::string& path, const LutPreviewInput& lut, std::uint32_t max_slices = 8);

// The slice indices shown for a LUT with n NdotV slices (first and last always included).
std::vector<std::uint32_t> preview_slices(std::uint32_t n_dot_v_count, std::uint32_t max_slices);

}  // namespace ms
