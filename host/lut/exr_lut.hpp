// The LUT file: a single-part scanline OpenEXR slice atlas with the bake's metadata.
//
// Contract (the bake writes it, sweeps and tests read it):
// - one FLOAT (or HALF) channel per roughness, 1 to 4 of them, named R, G, B, A (what engines' EXR
//   importers read); the metadata lists them in order with "name" R, G, B, A, "exr_channel" (the EXR
//   channel's name) and "roughness", and the header holds oiio:UnassociatedAlpha = 1 (A is data, not
//   premultiplied alpha). Files that named their channels by roughness (exr_channel_name:
//   "roughness_0p1", ...) read too: the reader follows "exr_channel";
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
#include <stdexcept>
#include <string>
#include <vector>

#include "core/lookup_domain.hpp"
#include "lut/lut_image.hpp"

namespace ms {

// Writes the LUT atomically (temporary file, then rename). `data` is laid out as LutFile::data.
// axes and channels are recorded in the metadata (which must already hold the other fields) and
// checked against width/height/data size. Throws std::invalid_argument or std::runtime_error.
void write_lut(const std::string& path, const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels,
               const std::vector<float>& data, const nlohmann::json& metadata, bool half);

// The domain a LUT without a recorded one answers for: its visibility and NdotV axes' ranges (a 2D LUT,
// made to stand in at every view: NdotV [0, 1]), any NdotL, its roughness channels' range ("counted":
// core/lookup_domain.hpp). write_lut records it as the metadata's "domain" unless one is there.
LookupDomain lut_domain(const std::vector<LutAxis>& axes, const std::vector<LutChannel>& channels);

// A file of this tool that is not a LUT (a representation, an IBL output) or a file with no
// "microshadow" metadata at all, given where a LUT is expected: the message names the file and,
// where it knows one, the command that reads it.
class WrongFileKind : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Reads and checks a LUT file in any format the tool writes (OpenEXR, KTX2, DDS with its .dds.json,
// C header, .inc, PNG atlas; lut/formats/lut_reader.hpp tells them apart by content). Throws
// std::runtime_error naming the file and the problem (WrongFileKind for another kind of file).
LutFile read_lut(const std::string& path);

// The OpenEXR reader behind read_lut. Throws std::runtime_error naming the file and the problem
// (not an EXR, missing "microshadow" attribute, axes that do not match the image size, axis counts
// that are not integers in [1, 65536], ranges outside [0, 1], roughness outside (0, 1], texels that
// are NaN, infinite or outside [0, 1], ...).
LutFile read_exr_lut(const std::string& path);

// The pieces every reader shares. lut_from_metadata: axes, channels, width and height from the
// "microshadow" metadata, each field checked (no data; exr_names receives the EXR channel names);
// throws std::runtime_error or nlohmann::json::exception naming the field, WrongFileKind for a
// representation or metadata without axes. check_lut_texels: the data fill the image, every texel is
// in [0, 1], and a partial bake's unbaked texels (its "coverage" record) are NaN; std::runtime_error.
LutFile lut_from_metadata(const nlohmann::json& metadata, std::vector<std::string>* exr_names = nullptr);
void check_lut_texels(const LutFile& lut);
// True for a partial bake (`bake --scene`): its metadata has a coverage record and unbaked texels are NaN.
bool is_partial_bake(const LutFile& lut);
// The name of channel c in messages: its EXR channel name when the metadata has one, else R/G/B/A.
std::string lut_channel_label(const LutFile& lut, std::size_t c);

// The OpenEXR channel name of a roughness ("roughness_0p1": no '.', which tools read as a layer).
std::string exr_channel_name(double roughness, int significant_digits = 6);

}  // namespace ms
