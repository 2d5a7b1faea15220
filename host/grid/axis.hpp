// One axis of a grid, declared once and used by LUT bakes, lookups, sweeps and (next) scene histograms:
// a name, a range, a count, where the samples sit (texel convention) and how they are spaced.
//
// Sample i of n over [min, max], with t its position in [0, 1]:
//   centres   t = (i + 0.5) / n           (a texture's texel centres; the LUT default)
//   endpoints t = i / (n - 1), n > 1       (both ends sampled: sweeps' ranges, --texel endpoints)
//             t = 0 for n = 1              (a lone sample sits at min)
// linear spacing: (1 - t) min + t max, the lerp that hits both ends exactly;
// log spacing:    exp((1 - t) log min + t log max), with the ends pinned to min and max.
// A lookup maps a parameter p back to a continuous sample coordinate (texel_coordinate), which is how
// a GPU addresses a texture: centres u = (p - min) / (max - min) * n - 0.5, endpoints (p - min) /
// (max - min) * (n - 1), clamped to [0, n - 1] (clamp-to-edge).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ms {

enum class TexelConvention { centres, endpoints };
enum class Spacing { linear, log };
std::string to_string(TexelConvention);
TexelConvention parse_texel_convention(const std::string&);  // "centres" | "centers" | "endpoints"
std::string to_string(Spacing);

struct Axis {
    std::string name;
    double min = 0, max = 1;
    std::uint32_t count = 1;
    TexelConvention texel = TexelConvention::centres;
    Spacing spacing = Spacing::linear;

    double value(std::uint32_t i) const;
    std::vector<double> values() const;
    // The continuous sample coordinate of parameter p (linear spacing), clamped to [0, count - 1].
    double texel_coordinate(double p) const;
};

}  // namespace ms
