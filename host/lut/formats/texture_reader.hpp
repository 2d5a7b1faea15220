// Reading back the KTX2 and DDS textures of texture.hpp's writers: the inverse of write_ktx2_texture
// and write_dds_texture, for the files this tool writes (LUTs, representations, IBL outputs).
//
// Accepted (what the writers write, nothing more): the four RGBA formats of encoding.hpp (VkFormat
// 109/97/37/91, DXGI 2/10/28/11), a 2D texture, a 3D texture or a cubemap (6 faces), one or more mip
// levels, no array layers, no supercompression. Every offset and length is checked against the
// file's size before it is read, and the texel count against a caller's limit before anything is
// allocated. The metadata is the KTX2 key/value entry "microshadow" (JSON), or for a DDS the sidecar
// `<file>.json` the writer puts beside it. A DDS without its sidecar reads with empty metadata: what
// that means is the caller's to say. The LUT reader refuses it (a LUT without its axes cannot be read,
// lut/formats/lut_reader.cpp); the cubemap reader takes it (radiance needs no axes, and engines' DDS
// cubemaps have no sidecar: env/cubemap_file.hpp).
#pragma once

#include <cstdint>
#include <string>

#include "lut/formats/encoding.hpp"
#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

struct TextureFile {
    TextureData texture;  // channels = 4 (RGBA as stored), levels base first, metadata = the file's JSON
    PixelEncoding encoding = PixelEncoding::float32;
};

// True when the first bytes of `path` are KTX 2.0's identifier / DDS's magic "DDS ".
bool has_ktx2_identifier(const std::string& path);
bool has_dds_magic(const std::string& path);

// Reads a texture file; `max_texels` bounds width x height x depth x faces of the base level.
// Throws std::runtime_error saying what is wrong (the caller adds the file name).
TextureFile read_ktx2_texture(const std::string& path, std::uint64_t max_texels);
TextureFile read_dds_texture(const std::string& path, std::uint64_t max_texels);

// Just the "microshadow" metadata of a KTX2 file (the key/value data) or a DDS (its sidecar), without
// decoding texels; null JSON when the file has none. Throws std::runtime_error for a malformed file.
nlohmann::json read_ktx2_metadata(const std::string& path);
nlohmann::json read_dds_metadata(const std::string& path);

}  // namespace ms::lutfmt
