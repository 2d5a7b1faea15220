// Reading a cubemap with its mip chain from one file: the KTX2 (faceCount 6) or DDS (DDSCAPS2_CUBEMAP,
// metadata in "<file>.json") that `ibl prefilter --format ktx2|dds` and `ibl irradiance` write, so an
// engine's mipped cube comes back as the cubemaps the IBL jobs compute with.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "lut/formats/texture.hpp"

namespace ms::env {

struct CubemapFile {
    std::vector<Cubemap> levels;       // base level first; level p is max(1, size >> p) texels a side
    // The file's "microshadow" JSON (object; empty when it has none: a DDS without its `<file>.json`
    // sidecar is read all the same, since radiance needs no axes and other tools' DDS cubemaps have none).
    nlohmann::json metadata;
    std::string encoding;              // "float16" or "float32": the stored texels
    std::size_t negative_residue_values = 0;  // as Image::negative_residue_values
};

// By extension, .ktx2 or .dds. Every refusal is an EnvironmentError "environment PATH: <reason>", one line:
//   - anything but a regular file (a FIFO, a device, a directory) is refused before it is opened;
//   - the container, as lut/formats/texture_reader.hpp checks it: the identifier, every header field,
//     the descriptor and key/value regions, each level's offset and length against the file's size and
//     against the texels its size holds, levels overlapping, bytes after the data;
//   - a cubemap: faceCount 6 (KTX2) / the cubemap flags (DDS), square 2D faces, at most kMaxImagePixels
//     texels over the six base faces; float16 or float32 (unorm formats clip radiance at 1);
//   - every RGB value as the image readers check theirs (image.hpp): finite, at most kMaxRadiance and
//     non-negative, negatives within kNegativeResidue of the file's largest value set to 0; the first
//     that is not is named with its level, face (+X ...), texel (x, y) and channel. A is not data (the
//     writers store 1) and is not read.
CubemapFile read_cubemap_file(const std::string& path);

// What the IBL jobs write, as the one texture writer takes it (lut/formats/texture_writer.hpp):
// an image (a horizontal cross, an EXR: its channels named as the image names them, the metadata with
// its typed copies), and a cubemap's mip chain (KTX2 faceCount 6 / DDS cube: faces +X -X +Y -Y +Z -Z,
// RGB with A = 1; the metadata records the faces, the padding and the encoding).
lutfmt::TextureData image_texture(const Image& image, const nlohmann::json& metadata);
lutfmt::TextureData cubemap_texture(const std::vector<const Cubemap*>& levels, const nlohmann::json& metadata);

}  // namespace ms::env
