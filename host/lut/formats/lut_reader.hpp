// Reading a LUT back from any file the tool writes (lut_formats.hpp lists them), so that every
// command that takes a LUT (eval --compare, scene --lut, sweeps, design, shader, lut info|export)
// takes each format the bake writes.
//
// The format comes from the content, not the name: the first bytes say OpenEXR (76 2F 31 01), KTX2
// (its 12-byte identifier), DDS ("DDS ") or PNG (its 8-byte signature); a text file that begins with
// the writer's "/* microshadow LUT" comment is a C header when it holds the `<prefix>_metadata[]`
// string, else an .inc. Where the metadata comes from:
//   exr     the "microshadow" header attribute (exr_lut.hpp)
//   ktx2    the "microshadow" key/value entry
//   dds     the sidecar `<file>.json` written beside it (a DDS without it cannot be read as a LUT)
//   header  the `<prefix>_metadata[]` C string (the #defines repeat its main fields for a compiler)
//   inc     the comment line "/* microshadow-metadata: {...} */" (JSON with '/' written "\/")
//   png     the iTXt chunk "microshadow"
// Texels come back as floats: float32 exactly, float16 widened exactly, unorm q as q / (2^n - 1), so
// a file equals the EXR of the same bake within its encoding's step (encoding.hpp); the RGBA padding
// of the texture formats is dropped (the metadata says how many channels are data).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/lut_formats.hpp"

namespace ms::lutfmt {

// How a LUT file stores its texels.
struct LutFileInfo {
    LutFormat format = LutFormat::exr;
    PixelEncoding encoding = PixelEncoding::float32;
};

// The format of a file by its content (see above). Throws WrongFileKind for a file that is none of
// them, std::runtime_error when it cannot be opened.
LutFormat detect_lut_format(const std::string& path);

// The file's "microshadow" metadata whatever its format, without decoding texels (null when the file
// has none): lets a command tell a LUT from a representation or an IBL output before reading it.
// Throws std::runtime_error naming the file when it cannot be read.
nlohmann::json read_file_metadata(const std::string& path);

// Reads and checks a LUT in any format (exr_lut.hpp's read_lut is this without `info`). Throws
// std::runtime_error naming the file and the problem; WrongFileKind for another kind of file.
LutFile read_lut_file(const std::string& path, LutFileInfo* info = nullptr);

// The LUT of a file as a writer should record it again (`microshadow lut export`): the source
// container's own fields dropped (file_format, encoding, error_budget, max_total_error, the RGBA
// padding notes, KTX2 orientation, DXGI format: each writer sets its own), the rounding the source's
// encoding already applied kept as "earlier_quantisation_error" (so the next error budget still
// counts it), and "exported_from" naming the source file and its format.
LutFile lut_for_export(LutFile lut, const LutFileInfo& from, const std::string& source);

// The largest difference between a texel read back and the float the bake stored, for `encoding`:
// 0 for float32, half a float16 ulp at 1 (2^-12: every texel is in [0, 1]), half a unorm step.
double encoding_step_bound(PixelEncoding encoding);

}  // namespace ms::lutfmt
