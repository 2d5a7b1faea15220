// Choosing and writing a LUT file format: the container comes from the file's extension (or an
// explicit --format, which must agree with it), the pixel encoding from --encoding (or --half).
//
//   extension     format   encodings (default first)
//   .exr          exr      float32, float16                   (OpenEXR, lut/exr_lut.hpp)
//   .ktx2         ktx2     float32, float16, unorm8, unorm16  (3D texture, or 2D for one NdotV slice)
//   .dds          dds      float32, float16, unorm8, unorm16  (DX10 header, volume or 2D) + .dds.json
//   .h .hpp       header   float32, float16, unorm8, unorm16  (C/C++ header with a static array)
//   .inc          inc      float32, float16, unorm8, unorm16  (values only, for an initialiser)
//   .png          png      unorm8, unorm16                    (RGBA atlas, same layout as the EXR)
#pragma once

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"

namespace ms::lutfmt {

enum class LutFormat { exr, ktx2, dds, header, inc, png };
std::string to_string(LutFormat);
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

// A LutFile from the pieces a bake has (width/height from the axes).
LutFile make_lut_file(const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels, std::vector<float> data,
                      nlohmann::json metadata);

}  // namespace ms::lutfmt
