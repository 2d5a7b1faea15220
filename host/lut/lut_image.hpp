// The LUT image: one type for what a bake produces, a file holds and a lookup samples, with the one
// index formula of the project.
//
// Layout (part 2's 3D LUT as a slice atlas; a 2D LUT has one NdotV slice):
//   width = visibility count (x = visibility, increasing left to right), height = nNdotL * nNdotV;
//   NdotV slice k occupies rows [k * nNdotL, (k + 1) * nNdotL), row j of a slice is NdotL index j
//   (increasing top to bottom); each texel holds one float per channel (one roughness each), interleaved:
//       data[index(c, iv, il, ivv)], the index of grid/atlas.hpp.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "grid/atlas.hpp"
#include "grid/axis.hpp"

namespace ms {

using LutAxis = Axis;

struct LutChannel {
    std::string name;  // "R", "G", "B" or "A": the channel's place in RGBA textures (EXR: exr_channel_name)
    double roughness = 0, alpha_x = 0, alpha_y = 0;
};

struct LutImage {
    nlohmann::json metadata;          // how it was made (the file's "microshadow" header attribute)
    std::vector<LutAxis> axes;        // visibility, n_dot_l, n_dot_v
    std::vector<LutChannel> channels;
    std::uint32_t width = 0, height = 0;
    bool half = false;                // stored as HALF (read back as float)
    std::vector<float> data;          // data[index(c, iv, il, ivv)]

    const LutAxis& visibility() const { return axes.at(0); }
    const LutAxis& n_dot_l() const { return axes.at(1); }
    const LutAxis& n_dot_v() const { return axes.at(2); }
    AtlasShape shape() const {
        return {visibility().count, n_dot_l().count, n_dot_v().count, std::uint32_t(channels.size())};
    }
    std::size_t index(std::uint32_t c, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const {
        return shape().index(c, iv, il, ivv);
    }
    // Texel of channel c at visibility index iv, NdotL index il, NdotV index ivv.
    float at(std::uint32_t c, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const {
        return data.at(index(c, iv, il, ivv));
    }
};

// The name the file reader and the sweeps have used since the first bake.
using LutFile = LutImage;

}  // namespace ms
