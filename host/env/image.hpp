// Float images of the IBL jobs (environment maps, cubemap faces, LUTs): interleaved channels, row 0 at
// the top, and the file formats they travel in (OpenEXR in and out, Radiance RGBE in).
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace ms::env {

struct Image {
    std::uint32_t width = 0, height = 0, channels = 0;
    std::vector<std::string> channel_names;  // written to EXR as given ("R", "G", "B", ...)
    std::vector<float> data;                 // data[(y * width + x) * channels + c]

    Image() = default;
    Image(std::uint32_t w, std::uint32_t h, std::vector<std::string> names)
        : width(w), height(h), channels(std::uint32_t(names.size())), channel_names(std::move(names)),
          data(std::size_t(w) * h * channels, 0.0f) {}
    float& at(std::uint32_t x, std::uint32_t y, std::uint32_t c) { return data[(std::size_t(y) * width + x) * channels + c]; }
    float at(std::uint32_t x, std::uint32_t y, std::uint32_t c) const { return data[(std::size_t(y) * width + x) * channels + c]; }
};

// Writes a single-part scanline OpenEXR atomically, FLOAT (or HALF) channels in the image's order, with
// the metadata JSON as the string attribute "microshadow" and its scalar fields as typed
// "microshadow.<field>" attributes. Throws std::invalid_argument or std::runtime_error.
void write_exr(const std::string& path, const Image& image, const nlohmann::json& metadata, bool half = false);

// Reads an OpenEXR as RGB (R, G, B; a single Y channel is copied to all three; missing channels are 0),
// whatever its data window and pixel types. The "microshadow" attribute, if present, goes to *metadata.
Image read_exr_rgb(const std::string& path, nlohmann::json* metadata = nullptr);

// Reads a Radiance RGBE (.hdr / .pic) file: "#?RADIANCE" or "#?RGBE" header, FORMAT=32-bit_rle_rgbe,
// orientation "-Y h +X w", flat or new-style run-length encoded scanlines. Applies EXPOSURE if given.
Image read_rgbe(const std::string& path);

// By extension: .exr -> read_exr_rgb, .hdr / .pic -> read_rgbe. Throws std::invalid_argument otherwise.
Image read_environment_image(const std::string& path);

}  // namespace ms::env
