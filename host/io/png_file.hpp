// The one PNG writer of the project (libpng): previews, PNG LUT atlases and scene images all use it.
#pragma once

#include <cstdint>
#include <string>

namespace ms {

struct PngImage {
    std::uint32_t width = 0, height = 0;
    int channels = 3;  // 3 (RGB) or 4 (RGBA)
    int bits = 8;      // 8, or 16 with big-endian samples (PNG's byte order)
    const std::uint8_t* pixels = nullptr;  // rows top to bottom, width * channels * bits / 8 bytes each
    // Data, not colour (LUT atlases): a gAMA chunk of 1.0 and no sRGB chunk, so that importers
    // (OpenImageIO, engines' texture importers) read the samples as linear values instead of sRGB.
    bool linear_data = false;
};

// Writes `image` to `path` as it is (callers pass an atomic output's temporary), with an optional
// international text chunk (iTXt: UTF-8, e.g. JSON metadata) under `text_key`. Throws
// std::runtime_error naming the path when libpng or the file system fails.
void write_png(const std::string& path, const PngImage& image, const std::string& text_key = "",
               const std::string& text = "");

}  // namespace ms
