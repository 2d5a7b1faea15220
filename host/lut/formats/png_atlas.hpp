// The LUT atlas as an 8- or 16-bit RGBA PNG: the same image as the OpenEXR (x = visibility, y = NdotL
// rows of slice 0, then slice 1, ..., i.e. height = NdotL count x NdotV count), RGBA = roughness
// channels padded as the texture formats are, values round(v * (2^n - 1)). The metadata JSON (with
// the error budget) is an uncompressed iTXt chunk with keyword "microshadow". PNG's 4th channel is
// straight alpha by definition: the metadata says it is data; load it without premultiplying.
#pragma once

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

// The LUT as the TextureData texture_writer.hpp writes as PNG; encoding must be unorm8 or unorm16
// (std::invalid_argument otherwise).
TextureData png_lut_texture(const LutFile& lut, PixelEncoding encoding);

}  // namespace ms::lutfmt
