// False-colour pictures of scene images that a person reads at a glance: a sequential map (viridis-like)
// for terms in [0, 1], a diverging map (blue - white - red) for signed errors, colour bars with ticks,
// and labelled panels side by side (reference | approximation | error). Masked pixels are dark grey.
// Large images are box-filtered down to at most `max_panel` pixels across.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lut/bitmap_font.hpp"

namespace ms::scene {

struct Panel {
    std::string label;
    const float* data = nullptr;  // width * height
    bool diverging = false;       // false: [lo, hi] sequential; true: [-range, range]
    double lo = 0, hi = 1, range = 1;
};

// Panels side by side, each with its own colour bar; `mask` (nullable) marks shaded pixels (non-zero).
// `title` lines go above.
RgbImage render_panels(std::uint32_t width, std::uint32_t height, const std::vector<Panel>& panels, const float* mask,
                       const std::vector<std::string>& title, std::uint32_t max_panel = 384);

// RGB of the maps (t in [0, 1]; diverging: t = 0.5 is white).
void sequential_colour(double t, std::uint8_t rgb[3]);
void diverging_colour(double t, std::uint8_t rgb[3]);

}  // namespace ms::scene
