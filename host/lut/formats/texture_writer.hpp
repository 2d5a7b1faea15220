// The one texture writer: every output that is a texture (a LUT, a DFG table, a representation, a
// cubemap) describes itself as a TextureData (texture.hpp) and is written here in the format its
// file's extension (or --format) picked from texture_format.hpp's table:
//
//   exr     level 0 as an OpenEXR image (depth slices one under the other), FLOAT or HALF channels named
//           channel_names, the metadata as the "microshadow" attribute (and typed copies of its scalars
//           unless exr_typed_metadata is off), exr_attributes besides (io/exr_file.hpp);
//   ktx2    the KTX 2.0 texture of texture.hpp (every level and face);
//   dds     the DDS texture of texture.hpp and its "<file>.json" sidecar;
//   png     level 0 as an 8- or 16-bit PNG (unorm8 / unorm16), RGBA for 4 channels, else RGB with the
//           missing channels 0, the metadata JSON in an iTXt chunk "microshadow" (linear data, no sRGB);
//   header  C/C++ source, the one convention of every kind:
//               /* comment lines */
//               #ifndef ID_H / #define ID_H / #include <stdint.h>
//               the kind's #defines (ID_WIDTH, ID_HEIGHT, ID_DEPTH, ...)
//               static const char id_metadata[] = "<metadata JSON>";
//               static const TYPE id_data[ID_DEPTH * ID_HEIGHT * ID_WIDTH * Cu] = { values };
//               #endif
//           texels x fastest, then y, then z, C = channels components each:
//               id_data[((z * height + y) * width + x) * C + c]
//   inc     the same comment, the metadata on one line ("/* microshadow-metadata: JSON */", read back by
//           lut_reader.hpp) and the values alone, to #include inside an initialiser.
// C component types: float32 -> float (9 significant digits: the exact float back, always with a point
// or exponent), float16 -> uint16_t binary16 bits, unorm8 -> uint8_t, unorm16 -> uint16_t.
//
// Every output is written into an OutputSet's temporaries (io/atomic_file.hpp): its files appear together
// at the set's commit, or not at all.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include "io/atomic_file.hpp"
#include "lut/formats/texture.hpp"
#include "lut/formats/texture_format.hpp"

namespace ms::lutfmt {

// The entries one texture output takes in an output set: the file, and the metadata sidecar of a
// format that has one (texture_format.hpp). Added before any work, so that a bad or colliding
// destination is refused first.
struct TextureFiles {
    TextureFormat format = TextureFormat::exr;
    std::size_t file = 0;
    std::optional<std::size_t> sidecar;
};
TextureFiles add_texture_files(OutputSet& outputs, const std::string& path, TextureFormat format);

// Writes `t` in `files.format` with `encoding` into the set's temporaries (the caller commits).
// std::invalid_argument for a texture the format cannot hold (an encoding it does not store, a cubemap
// or mip chain in a single-image format); std::runtime_error naming the file on I/O errors.
void write_texture(OutputSet& outputs, const TextureFiles& files, const TextureData& t, PixelEncoding encoding);
// The same, one texture on its own, committed at once.
void write_texture(const std::string& path, TextureFormat format, const TextureData& t, PixelEncoding encoding);

// The EXR of `t` written to `path` on its own, atomically (for writers whose callers hand them a path,
// which may be another set's temporary).
void write_exr_texture(const std::string& path, const TextureData& t, bool half);

// The C source text of `t` (header, or inc when `inc_only`).
std::string c_source(const TextureData& t, PixelEncoding encoding, bool inc_only);

// A float literal C and C++ read back as the same float ("%.9g", with a point or an exponent, and "f").
std::string c_float_literal(float v);

}  // namespace ms::lutfmt
