// The LUT as C/C++ source to compile into an engine (like Filament cmgen's --ibl-dfg=*.h|*.inc):
//
// - `.h` / `.hpp`: a self-contained header (C99 and C++): #defines with the dimensions, axis ranges and
//   conventions, the roughness of each channel, the error budget; the metadata JSON as a string; and
//   one static array `<prefix>_data` of width x height x depth x 4 components (RGBA, padded as the
//   texture formats are), texels x fastest, then NdotL (y, increasing down), then NdotV (z):
//       <prefix>_data[((z * height + y) * width + x) * 4 + c]
//   The prefix is the file name's stem made an identifier ("lut3d-32.h" -> lut3d_32, LUT3D_32_*).
// - `.inc`: only the comma-separated values (and a comment saying what they are), to #include inside
//   an initialiser: `static const float lut[] = {\n#include "lut.inc"\n};`.
// Component types: float32 -> float (9 significant digits: the exact float back), float16 -> uint16_t
// bit patterns (upload as R16G16B16A16_SFLOAT), unorm8 -> uint8_t, unorm16 -> uint16_t.
#pragma once

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

// The identifier prefix for a path ("out/lut3d-32.h" -> "lut3d_32").
std::string c_identifier_for(const std::string& path);

// The LUT as the TextureData texture_writer.hpp writes as a C header (or, `inc_only`, an initialiser
// list): the comment and #defines above, the identifier from `path`.
TextureData c_lut_texture(const std::string& path, const LutFile& lut, PixelEncoding encoding, bool inc_only);

}  // namespace ms::lutfmt
