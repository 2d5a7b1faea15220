// The LUT file: a single-part scanline OpenEXR slice atlas with the bake's metadata.
//
// Contract (the bake writes it, sweeps and tests read it):
// - one FLOAT (or HALF) channel per roughness, 1 to 4 of them, named exr_channel_name(roughness)
//   ("roughness_0p1", ...: never "A", which image tools treat as premultiplied alpha); the metadata lists
//   them in order with "name" R, G, B, A (their place in RGBA texture formats) and "exr_channel".
//   Files written before that named the channels R, G, B, A; read_lut reads both;
// - width = visibility count (x = visibility, increasing left to right); height = nNdotL * nNdotV;
//   NdotV slice k occupies rows [k * nNdotL, (k + 1) * nNdotL), row j of a slice is NdotL index j
//   (increasing top to bottom); a 2D LUT has nNdotV = 1;
// - header string attribute "microshadow" holds the JSON metadata: layout, axes (name, min, max, count,
//   texel), channels (name, roughness, alpha_x, alpha_y), azimuth, form, ao_weighting, sequence, seed,
//   samples, max_error, device, version, command_line, ...; the main fields are also written as typed
//   attributes "microshadow.<field>" for people reading the header with exrheader.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "lut/lut_image.hpp"

namespace ms {

// Writes the LUT atomically (temporary file, then rename). `data` is laid out as LutFile::data.
// axes and channels are recorded in the metadata (which must already hold the other fields) and
// checked against width/height/data size. Throws std::invalid_argument or std::runtime_error.
void write_lut(const std::string& path, const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels,
               const std::vector<float>& data, const nlohmann::json& metadata, bool half);

// Reads and checks a LUT file. Throws std::runtime_error naming the file and the problem
// (not an EXR, missing "microshadow" attribute, axes that do not match the image size, axis counts
// that are not integers in [1, 65536], ranges outside [0, 1], roughness outside (0, 1], texels that
// are NaN, infinite or outside [0, 1], ...).
LutFile read_lut(const std::string& path);

// The OpenEXR channel name of a roughness ("roughness_0p1": no '.', which tools read as a layer).
std::string exr_channel_name(double roughness, int significant_digits = 6);

}  // namespace ms
