// Bar charts of a scene's domain (`microshadow bake --scene`): one panel per histogram, stacked, each
// with its title and unit, the count axis (0 and the largest bin, labelled), the parameter axis (ticks
// at its ends and middle, labelled in its unit) and the number of values counted with their range.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lut/bitmap_font.hpp"

namespace ms::scene {

struct HistogramPanel {
    std::string title;                  // with its unit, e.g. "NDOTL (COSINE)"; drawn upper case
    double min = 0, max = 1;            // the bins' range
    const std::vector<std::uint64_t>* counts = nullptr;
    double data_min = 0, data_max = 0;
};

RgbImage render_histograms(const std::vector<HistogramPanel>& panels, const std::vector<std::string>& title);

}  // namespace ms::scene
