// Float images of the IBL jobs (environment maps, cubemap faces, LUTs): interleaved channels, row 0 at
// the top, and the file formats they travel in (OpenEXR in and out, Radiance RGBE in).
#pragma once

#include <nlohmann/json.hpp>

#include <cfloat>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace ms::env {

// Bad environment input (exit status 2 in the CLI): the message names the file and, where it applies,
// the texel, the channel or the header line.
class EnvironmentError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

// The largest radiance a reader accepts: 2^-32 of the largest float, so a sum of up to 2^32 texels
// weighted by at most 1 each (a prefiltered texel, a convolved irradiance texel, a mip average) stays
// finite in the float kernels.
inline constexpr float kMaxRadiance = FLT_MAX / 4294967296.0f;
// Negative values no larger than this fraction of an image's largest value are the residue of
// filtering, resampling or lossy compression in real HDR files (blender-data's forest.exr holds
// -4.5e-6 beside a sky in the hundreds): readers take them as 0. Larger negatives are refused.
inline constexpr float kNegativeResidue = 1e-4f;

struct Image {
    std::uint32_t width = 0, height = 0, channels = 0;
    std::vector<std::string> channel_names;  // written to EXR as given ("R", "G", "B", ...)
    std::vector<float> data;                 // data[(y * width + x) * channels + c]
    std::size_t negative_residue_values = 0; // values a reader set from a small negative to 0 (kNegativeResidue)

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
// The same written to `file` as it is (an OutputSet's temporary; `named` in messages), not atomically.
void write_exr_file(const std::string& file, const std::string& named, const Image& image, const nlohmann::json& metadata,
                    bool half = false);

// The checks every reader applies, in this order, each refusal an EnvironmentError:
//   - the path is a regular file (a FIFO, a device or a directory is refused without blocking in open());
//   - the header's claims fit the file: at most kMaxImagePixels (2^28) pixels, and no more pixels than its
//     bytes can encode (OpenEXR: io/exr_preflight.hpp; Radiance: the smallest run-length encoding);
//   - channels (OpenEXR): R, G and B, or a single Y (copied to all three); others (A, Z, ...) are ignored;
//     a file without them is refused naming what is missing and the channels it has ("diffuse.R" is not R);
//   - every value finite, at most kMaxRadiance and non-negative: the first texel that is not is named
//     with its (x, y) from the top-left of the image and its channel; negatives within kNegativeResidue
//     of the largest value are set to 0 and counted in negative_residue_values.
// OpenEXR: whatever its data window and pixel types (part 0 of a multi-part file). The "microshadow"
// attribute, if present, goes to *metadata.
Image read_exr_rgb(const std::string& path, nlohmann::json* metadata = nullptr);

// Reads a Radiance RGBE (.hdr / .pic) file: "#?RADIANCE" or "#?RGBE" header, FORMAT=32-bit_rle_rgbe,
// orientation "-Y h +X w", flat or new-style run-length encoded scanlines. Divides by EXPOSURE (each
// EXPOSURE line a finite positive number; their product is the file's exposure).
Image read_rgbe(const std::string& path);
// The same from the file's bytes (`name` in messages): what read_rgbe does after reading the file.
Image decode_rgbe(const std::string& bytes, const std::string& name);

// Refuses (EnvironmentError "environment PATH: is a FIFO (named pipe), not a regular file", ...) anything
// but a regular file or a link to one, without blocking in open().
void check_environment_file(const std::string& path);

// By extension: .exr -> read_exr_rgb, .hdr / .pic -> read_rgbe, .ktx2 / .dds -> the base level of
// read_cubemap_file (env/cubemap_file.hpp) as a horizontal cross (cubemap_from_image keeps it as it is).
// Throws EnvironmentError otherwise.
Image read_environment_image(const std::string& path);

}  // namespace ms::env
