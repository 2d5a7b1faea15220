// The one index formula of a LUT atlas (part 2's 3D LUT stored as a 2D image of NdotV slices): the bake
// writes with it, the LUT image (lut/lut_image.hpp) and every reader read with it.
//   x = visibility index, y = NdotV slice * nNdotL + NdotL index, channels interleaved per texel.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ms {

struct AtlasShape {
    std::uint32_t visibility = 0, n_dot_l = 0, n_dot_v = 0, channels = 0;

    std::size_t texels() const { return std::size_t(visibility) * n_dot_l * n_dot_v * channels; }
    std::size_t index(std::uint32_t c, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const {
        return ((std::size_t(ivv) * n_dot_l + il) * visibility + iv) * channels + c;
    }
};

}  // namespace ms
