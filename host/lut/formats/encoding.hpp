// Pixel encodings of the LUT file formats (host/lut/formats/*): how a baked float becomes stored
// bits, the error that costs, and the RGBA padding texture formats need.
//
// Quantisation rounds to nearest:
// - float16: IEEE 754 binary16, round to nearest, ties to even (what a GPU's float->half conversion
//   does); the error recorded is the measured max |half(v) - v| over the data.
// - unorm8 / unorm16: q = round(v * (2^n - 1)) (v clamped to [0, 1] first); the recorded error is the
//   bound 0.5 / (2^n - 1) (half a step), which the data attain wherever they are not on the grid.
// - float32: the baked floats, stored as they are.
// Every recorded error adds the values' earlier rounding to float32 (they are computed in double): half
// the float spacing at the largest |value| (float32_rounding_bound), 3e-8 for values up to 1.
//
// Error budget: every writer records in the metadata JSON
//   "error_budget": { sampling, azimuth_quadrature, earlier_quantisation, quantisation, total = their sum, ... }
// where sampling is the bake's "max_error" (largest per-texel replicate standard error) and
// azimuth_quadrature its "azimuth_quadrature_error" (0 when the bake has none, e.g. a fixed angle), and
// earlier_quantisation its "earlier_quantisation_error": the rounding of the file a LUT was exported
// from (`microshadow lut export` of a float16 or unorm file; 0 for a bake).
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "lut/exr_lut.hpp"

namespace ms::lutfmt {

enum class PixelEncoding { float32, float16, unorm8, unorm16 };
std::string to_string(PixelEncoding);
// "float32" | "float" | "float16" | "half" | "unorm8" | "rgba8" | "unorm16" | "rgba16"; std::invalid_argument.
PixelEncoding parse_pixel_encoding(const std::string&);
std::uint32_t bytes_per_component(PixelEncoding);

// IEEE binary16 bits of v, round to nearest even (overflow to infinity, NaN stays NaN).
std::uint16_t float_to_half(float v);
float half_to_float(std::uint16_t h);
// round(v * (2^bits - 1)) with v clamped to [0, 1]; bits is 8 or 16.
std::uint32_t to_unorm(float v, unsigned bits);

// Half the float spacing at the largest |value| of `data`: the most a double rounded to them moved.
double float32_rounding_bound(const std::vector<float>& data);
// Quantisation error of storing `data` with `encoding`, float32 rounding included (see the header comment).
double quantisation_error(const std::vector<float>& data, PixelEncoding encoding);
std::string quantisation_kind(PixelEncoding encoding);

// Adds "error_budget" (and "max_total_error", the same sum, at the top level) to `meta`.
void add_error_budget(nlohmann::json& meta, const std::vector<float>& data, PixelEncoding encoding);

// The texels as 4 components (RGBA texture formats): channels beyond the LUT's repeat its last
// channel, so a shader that reads them (or filters across them) sees the highest-index roughness, not
// a made-up 0 or 1. Layout: ((y * width + x) * 4 + c).
std::vector<float> rgba_padded(const LutFile& lut);
// Records the padding in `meta` ("texture_channels": 4, "padded_channels": [...], "padding": "...").
void add_padding_note(nlohmann::json& meta, const LutFile& lut);

// Little-endian stored components of `rgba` (4 per texel) in `encoding`, appended to `out`.
void append_encoded(std::vector<std::uint8_t>& out, const std::vector<float>& rgba, PixelEncoding encoding);

// Checks a LutFile before any writer touches it: 3 axes, 1-4 channels, data size = width x height x
// channels with width = visibility count and height = NdotL count x NdotV count. std::invalid_argument.
void check_lut_shape(const LutFile& lut);

// The metadata a non-EXR writer records: the LUT's metadata with axes and channels (as write_lut
// records them), the encoding, the padding and the error budget.
nlohmann::json format_metadata(const LutFile& lut, PixelEncoding encoding, const std::string& format, bool padded_rgba);

}  // namespace ms::lutfmt
