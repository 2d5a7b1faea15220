// Writing OpenEXR images the project's way, for every writer (LUTs, environments and cubemaps,
// representation atlases): ZIP-compressed FLOAT or HALF channels from interleaved floats, written
// atomically (io/atomic_file.hpp), with the "microshadow" JSON attribute and typed copies of its fields.
#pragma once

#include <ImfHeader.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace ms::exr {

// A ZIP-compressed width x height header with `names` as HALF (half = true) or FLOAT channels.
Imf::Header image_header(std::uint32_t width, std::uint32_t height, const std::vector<std::string>& names, bool half);

// The "microshadow" attribute (the JSON) and typed copies of its top-level scalars as
// "microshadow.<key>" (string, int, double; booleans as 0/1), for people reading the header with exrheader.
void insert_metadata(Imf::Header& header, const nlohmann::json& metadata);

// Writes `data` (floats_per_pixel interleaved floats a pixel, row by row; channel c of `names` is the c-th
// float of a pixel) under `header` to `path`, atomically: the destination is checked first, nothing is
// left on failure. HALF channels are rounded here (nearest even): OpenEXR does not convert on write.
// Throws std::runtime_error "cannot write PATH: ...".
void write_interleaved(const std::string& path, const Imf::Header& header, const std::vector<std::string>& names,
                       const std::vector<float>& data, std::size_t floats_per_pixel, bool half);
// The same written to `file` as it is, not atomically: for a temporary of an OutputSet whose files
// are committed together. Throws std::runtime_error "cannot write NAMED: ..." (`named`: the output's name).
void write_interleaved_file(const std::string& file, const std::string& named, const Imf::Header& header,
                            const std::vector<std::string>& names, const std::vector<float>& data, std::size_t floats_per_pixel,
                            bool half);

// The base pointer OpenEXR's Slice wants for a buffer that holds the data window starting at (min_x,
// min_y): data - (min_x x_stride + min_y y_stride), computed in integers. The pointer lies outside the
// buffer whenever the window does not start at the origin, and forming it by pointer arithmetic is
// undefined behaviour (UBSan: "pointer overflow"); OpenEXR only adds the offsets back.
inline char* frame_base(void* data, std::int64_t min_x, std::int64_t min_y, std::size_t x_stride, std::size_t y_stride) {
    const std::uintptr_t offset = std::uintptr_t(min_x * std::int64_t(x_stride) + min_y * std::int64_t(y_stride));
    return reinterpret_cast<char*>(reinterpret_cast<std::uintptr_t>(data) - offset);
}

}  // namespace ms::exr
