// Choosing and writing a LUT file format: the container comes from the file's extension (or an
// explicit --format, which must agree with it), the pixel encoding from --encoding (or --half). The
// formats, their extensions and the encodings each stores are texture_format.hpp's table (a LUT may be
// written in every one):
//
//   extension     format   encodings (default first)
//   .exr          exr      float32, float16                   (OpenEXR, lut/exr_lut.hpp)
//   .ktx2         ktx2     float32, float16, unorm8, unorm16  (3D texture, or 2D for one NdotV slice)
//   .dds          dds      float32, float16, unorm8, unorm16  (DX10 header, volume or 2D) + .dds.json
//   .h .hpp .hh   header   float32, float16, unorm8, unorm16  (C/C++ header with a static array)
//   .inc          inc      float32, float16, unorm8, unorm16  (values only, for an initialiser)
//   .png          png      unorm8, unorm16                    (RGBA atlas, same layout as the EXR)
#pragma once

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/texture.hpp"
#include "lut/formats/texture_format.hpp"

namespace ms::lutfmt {

// A LUT's format is a texture format (to_string, format_info and the lists are texture_format.hpp's).
using LutFormat = TextureFormat;
LutFormat parse_lut_format(const std::string&);  // the names above; std::invalid_argument

// The format an extension means (the table above, case-insensitive); std::invalid_argument naming
// the path for any other extension.
LutFormat lut_format_for_extension(const std::string& path);

struct LutOutput {
    LutFormat format = LutFormat::exr;
    PixelEncoding encoding = PixelEncoding::float32;
};

// Resolves and checks an output request before any work is done. `format` and `encoding` may be
// empty (meaning: from the extension, the format's default). Throws std::invalid_argument naming the
// path and the problem: unknown extension, --format that disagrees with the extension, an encoding
// the format cannot store, --half with another encoding.
LutOutput resolve_lut_output(const std::string& path, const std::string& format, const std::string& encoding, bool half);

// Writes `lut` (shape checked) in the resolved format, atomically.
void write_lut_output(const std::string& path, const LutFile& lut, const LutOutput& output);
// The LUT as texture_writer.hpp's TextureData for a format other than exr (whose file write_lut makes).
TextureData lut_texture(const std::string& path, const LutFile& lut, const LutOutput& output);

// A LutFile from the pieces a bake has (width/height from the axes).
LutFile make_lut_file(const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels, std::vector<float> data,
                      nlohmann::json metadata);

}  // namespace ms::lutfmt
