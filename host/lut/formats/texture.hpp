// The lowest layer of the KTX2 and DDS writers: a texture given as plain float data, with no LUT
// semantics (no axes, no roughness channels, no error budget). The LUT writers (ktx2.hpp, dds.hpp)
// build their metadata and call these; the IBL outputs (DFG LUT, prefiltered cubemaps) call them directly.
//
// What it can describe: a 2D texture (depth 1), a 3D texture (depth > 1) or a cubemap (faces 6,
// width = height, depth 1), each with 1 or more mip levels (level p is max(1, width >> p) x
// max(1, height >> p) x max(1, depth >> p)). Texels are `channels` (1-4) floats each, x fastest, then
// y, then z; a cubemap level holds its 6 faces one after the other in the order +X, -X, +Y, -Y, +Z, -Z
// (KTX 2.0 "faceCount"; DDS "cubic environment maps"), each face with its top-left texel first (KTX2
// orientation "rd").
//
// RGBA padding (both formats store 4 components): channels beyond `channels` repeat the last channel,
// as the LUT writers pad, unless `alpha` is set: then A = *alpha (RGB data -> A = 1 for radiance);
// alpha may be set only with channels = 3.
//
// KTX2 file layout (KTX 2.0 specification, "File Structure", "Level Index", "Mip Level Array"):
// header with faceCount = faces, levelCount = levels, pixelDepth 0 unless a 3D texture; a level index
// with every level, base level first; the level data in the file from the smallest level to the
// base level, each level at a multiple of lcm(bytes per texel, 4) (mipPadding), each level's images in
// the order face, z, y, x. DFD and key/value data as ktx2.hpp describes ("microshadow" = metadata JSON).
//
// DDS layout (Microsoft "DDS_HEADER", "DDS_HEADER_DXT10", "Cubic environment maps"): dwMipMapCount =
// levels, DDSCAPS_MIPMAP | DDSCAPS_COMPLEX for mips, DDSCAPS2_CUBEMAP | DDSCAPS2_CUBEMAP_ALLFACES and
// DX10 miscFlag D3D10_RESOURCE_MISC_TEXTURECUBE (arraySize 1 = one cube) for a cubemap; the data face
// by face, each face with its whole mip chain (base level first). The metadata goes beside the file
// as `<file>.json` (with "dds_dxgi_format" added), written first.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "lut/formats/encoding.hpp"

namespace ms::lutfmt {

struct TextureData {
    std::uint32_t width = 0, height = 0, depth = 1;
    std::uint32_t faces = 1;    // 1, or 6 for a cubemap
    std::uint32_t channels = 4; // floats per texel in `levels`, 1-4
    std::optional<float> alpha; // A when the data have 3 channels and A is not a data channel
    // Components per stored texel: 4 (RGBA, padded as above) or 2 (RG: R16G16_SFLOAT / R32G32_SFLOAT /
    // R16G16_UNORM / R8G8_UNORM, DXGI R16G16_FLOAT / R32G32_FLOAT / R16G16_UNORM / R8G8_UNORM), which
    // needs channels = 2: two-channel tables (split-sum scale and bias) at half the bytes.
    std::uint32_t stored_components = 4;
    // levels[p]: level p's texels (all faces), channels floats per texel.
    std::vector<std::vector<float>> levels;
    nlohmann::json metadata = nlohmann::json::object();  // recorded verbatim ("microshadow" key / sidecar)
    std::string ktx2_orientation;  // KTXorientation; empty: "rd" (2D, cubemap) or "rdi" (3D)

    // What the other formats of texture_writer.hpp need besides the texels (level 0, one face; depth
    // slices one under the other, so an image of width x height depth):
    // OpenEXR: a name per data channel (empty: R, G, B, A), header attributes besides the metadata, and
    // whether the metadata's top-level scalars are also copied as typed "microshadow.<key>" attributes.
    std::vector<std::string> channel_names;
    std::vector<std::pair<std::string, std::variant<int, double, std::string>>> exr_attributes;
    bool exr_typed_metadata = true;
    // C source (.h / .inc, the one convention of texture_writer.hpp): the identifier (ID_..., id_data,
    // id_metadata), the opening comment's lines, and the #define lines of a header, which define at least
    // ID_WIDTH, ID_HEIGHT and ID_DEPTH (the array is ID_DEPTH * ID_HEIGHT * ID_WIDTH * channels values).
    std::string c_identifier;
    std::vector<std::string> c_comment;
    std::vector<std::string> c_defines;
};

// Level p's size along an axis of base size n.
inline std::uint32_t level_size(std::uint32_t n, std::uint32_t p) { return n >> p ? n >> p : 1; }

// Checks sizes and data lengths; std::invalid_argument naming the field.
void check_texture(const TextureData& t);
// Level p's texels as RGBA (the padding above), faces one after the other.
std::vector<float> rgba_level(const TextureData& t, std::size_t p);

// The file's bytes, for callers that write several files as one set (io/atomic_file.hpp's OutputSet).
// A DDS file's metadata (its `<file>.json` sidecar, with "dds_dxgi_format") comes from dds_sidecar_json.
std::vector<std::uint8_t> encode_ktx2_texture(const TextureData& t, PixelEncoding encoding);
std::vector<std::uint8_t> encode_dds_texture(const TextureData& t, PixelEncoding encoding);
nlohmann::json dds_sidecar_json(const TextureData& t, PixelEncoding encoding);

// The basic data format descriptor (with its leading dfdTotalSize) the KTX2 writer stores for
// `components` equal components (RGBA: 4, RG: 2) in `encoding`; the reader requires these bytes.
std::vector<std::uint8_t> ktx2_basic_dfd(PixelEncoding encoding, std::uint32_t components);

// Write atomically, through the one texture writer (texture_writer.hpp). std::invalid_argument (bad
// texture) or std::runtime_error (I/O), naming the file.
void write_ktx2_texture(const std::string& path, const TextureData& t, PixelEncoding encoding);
void write_dds_texture(const std::string& path, const TextureData& t, PixelEncoding encoding);

}  // namespace ms::lutfmt
