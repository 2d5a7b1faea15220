#include "grid/axis.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ms {

std::string to_string(TexelConvention t) { return t == TexelConvention::centres ? "centres" : "endpoints"; }

TexelConvention parse_texel_convention(const std::string& s) {
    if (s == "centres" || s == "centers") return TexelConvention::centres;
    if (s == "endpoints") return TexelConvention::endpoints;
    throw std::invalid_argument("texel convention must be centres or endpoints, not '" + s + "'");
}

std::string to_string(Spacing s) { return s == Spacing::linear ? "linear" : "log"; }

double Axis::value(std::uint32_t i) const {
    double t = 0;
    if (texel == TexelConvention::centres) {
        t = (double(i) + 0.5) / double(count);
    } else {
        if (count <= 1) return min;
        // Both ends exact (no rounding drift): the v = 1 exact-one rule and the sweeps' ends rely on it.
        if (i == 0) return min;
        if (i + 1 == count) return max;
        t = double(i) / double(count - 1);
    }
    if (spacing == Spacing::linear) return (1 - t) * min + t * max;
    return std::exp((1 - t) * std::log(min) + t * std::log(max));
}

std::vector<double> Axis::values() const {
    std::vector<double> out(count);
    for (std::uint32_t i = 0; i < count; ++i) out[i] = value(i);
    return out;
}

double Axis::texel_coordinate(double p) const {
    if (count <= 1 || !(max > min)) return 0;
    const double s = (p - min) / (max - min);
    const double t = texel == TexelConvention::centres ? s * count - 0.5 : s * (count - 1);
    return std::clamp(t, 0.0, double(count - 1));
}

}  // namespace ms
