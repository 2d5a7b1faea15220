// The texture file formats every output uses (LUTs, DFG tables, representations, cubemaps), in one
// table: a format's name (--format), its extensions, the pixel encodings it stores (default first),
// whether its metadata goes beside it in "<file>.json", and which outputs may be written in it. The
// extension of an output picks its format, case-insensitively, for every command; the CLI's help and
// validation lists are built from this table too (format_list, extension_list).
//
//   name     extensions       encodings (default first)           outputs
//   exr      .exr             float32, float16                    LUT, DFG, representation, cubemap
//   ktx2     .ktx2            float32, float16, unorm8, unorm16   LUT, DFG, representation, cubemap
//   dds      .dds (+ .json)   float32, float16, unorm8, unorm16   LUT, DFG, representation, cubemap
//   header   .h .hpp .hh      float32, float16, unorm8, unorm16   LUT, DFG
//   inc      .inc             float32, float16, unorm8, unorm16   LUT, DFG
//   png      .png             unorm8, unorm16                     LUT, DFG
//
// (What each output stores in a format, and which encodings it offers there, is its writer's: a DFG
// table's PNG is 16-bit, a cubemap's KTX2 float.) Adding a format: a row here (texture_format.cpp), its
// writer, and its case in texture_writer.cpp.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lut/formats/encoding.hpp"

namespace ms::lutfmt {

enum class TextureFormat { exr, ktx2, dds, header, inc, png };

// What is written: the output kinds, each with the formats the table allows it.
enum class TextureUse { lut, dfg, representation, cubemap };

struct TextureFormatInfo {
    TextureFormat format;
    const char* name;                      // the --format value
    std::vector<const char*> extensions;   // lower case with the dot; the first is the one files are named with
    std::vector<PixelEncoding> encodings;  // those it can store, the default first
    bool sidecar = false;                  // its metadata goes beside it, in "<file>.json"
    bool binary = true;                    // false for the C source formats
    std::vector<TextureUse> uses;
};

// Every format, in the order of the table above (the order of every list made from it).
const std::vector<TextureFormatInfo>& texture_formats();
const TextureFormatInfo& format_info(TextureFormat format);
std::string to_string(TextureFormat format);
bool format_supports(TextureFormat format, PixelEncoding encoding);
bool format_allowed(TextureFormat format, TextureUse use);
// The formats `use` may be written in, and their names ("exr", ...), in the table's order.
std::vector<TextureFormat> formats_for(TextureUse use);
std::vector<std::string> format_names(TextureUse use);
// For messages and help: "exr, ktx2, dds, header, inc or png" and ".exr, .ktx2, .dds, .h, .hpp, .hh,
// .inc or .png" (the formats of `use`; `last` joins the last two).
std::string format_list(TextureUse use, const std::string& last = " or ");
std::string extension_list(TextureUse use, const std::string& last = " or ");
// The noun an output is named by in messages: "LUT", "DFG LUT", "representation", "cubemap".
const char* use_noun(TextureUse use);

// The format the extension of `path` means (case-insensitive), or none.
std::optional<TextureFormat> format_for_extension(const std::string& path);
// The same for an output of `use`: std::invalid_argument "PATH: unknown NOUN file extension 'EXT': the
// extension picks the format, and a NOUN is written as LIST" for another extension or a format `use`
// cannot be written in.
TextureFormat texture_format_for_path(const std::string& path, TextureUse use);
// A --format name of `use`; std::invalid_argument "--format must be LIST, not 'NAME'".
TextureFormat parse_texture_format(const std::string& name, TextureUse use);
// The file name of `stem` in `format`: stem + the format's first extension ("dir/specular" -> "dir/specular.ktx2").
std::string file_name(const std::string& stem, TextureFormat format);

}  // namespace ms::lutfmt
