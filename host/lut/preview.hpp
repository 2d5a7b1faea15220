// A PNG picture of a LUT atlas, like part 2's figure: one tile per (NdotV slice, roughness channel),
// roughness across, NdotV down (at most max_slices slices, evenly spaced), visibility to the right and
// NdotL downwards inside a tile, values 0..1 as grey, a small gap between tiles. Labelled (with a
// built-in bitmap font, lut/bitmap_font.hpp): each column's roughness, each row's NdotV slice value
// and index, tick values of NdotL (left) and visibility (bottom) at the first, middle and last texel,
// a grey-scale colour bar with ticks, and how many of the NdotV slices are shown.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lut/exr_lut.hpp"

namespace ms {

struct LutPreviewInput {
    std::uint32_t visibility_count = 0, n_dot_l_count = 0, n_dot_v_count = 0, channels = 0;
    const float* data = nullptr;  // LutFile::data layout: ((ivv * nl + il) * nv + iv) * channels + c
    // For the labels (optional: without them tiles are labelled by index): the axes visibility,
    // n_dot_l, n_dot_v as in the file, and each channel's roughness.
    std::vector<LutAxis> axes;
    std::vector<double> roughness;
};

// Writes atomically; throws std::runtime_error. Tiles are magnified (nearest texel) to >= 96 pixels.
void write_lut_preview(const std::string& path, const LutPreviewInput& lut, std::uint32_t max_slices = 8);

// The slice indices shown for a LUT with n NdotV slices (first and last always included).
std::vector<std::uint32_t> preview_slices(std::uint32_t n_dot_v_count, std::uint32_t max_slices);

}  // namespace ms
