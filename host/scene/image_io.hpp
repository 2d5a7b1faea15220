// Per-pixel inputs of a scene read from image files, and the images a scene run writes.
//
// Reading: OpenEXR through Imf::MultiPartInputFile, so single-part, multi-part and multilayer files
// (as DCC tools write them) are all read the same way. A channel is named as the file names it
// ("ViewLayer.Normal.X", "roughness", "R"), or as "<part name>.<channel>" for a multi-part file whose
// parts carry names; a name that matches channels of two parts is refused as ambiguous. PNG through
// libpng: 8- or 16-bit grey, grey + alpha, RGB or RGBA (palettes expanded), channels "R", "G", "B",
// "A" ("Y" or "R" for grey), values scaled to [0, 1] with no transfer function (data textures); a
// palette PNG has its colours as R, G, B (A) and its stored indices as "index" ("index" of any other
// PNG is its first channel's stored codes). Only regular files are read (a FIFO would block in open),
// and a PNG header that claims more pixels than the file could hold, or more than 2^28, is refused.
//
// Writing: a labelled RGB PNG (lut/bitmap_font.hpp's RgbImage) and a single-part EXR of FLOAT
// channels, both to a path the caller gives (an OutputSet temporary).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "lut/bitmap_font.hpp"

namespace ms::scene {

// Bad scene input (exit status 2 in the CLI): the message names the file, the channel and the pixel.
class SceneError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

struct Plane {
    std::string file, channel;  // where it came from (for messages)
    std::uint32_t width = 0, height = 0;
    std::vector<float> data;    // row-major, top row first
    // The largest stored code (PNG: 255 or 65535, EXR: 1): data * integer_scale is the stored integer,
    // which is how object and material indices are read from PNG.
    double integer_scale = 1;
    int x0 = 0, y0 = 0;         // the EXR data window's corner (PNG: 0, 0): planes combine only where these agree
    float at(std::size_t x, std::size_t y) const { return data[y * width + x]; }
};

// Throws SceneError unless `path` is a regular file (or a link to one), without opening it.
void require_regular_file(const std::string& path);

// The named channels of one image file, in the order asked. Throws SceneError naming the file and
// the channel (missing channel, with the names the file has; ambiguous name; unreadable file;
// subsampled or deep channels). `display` is the file's name as messages show it.
std::vector<Plane> read_channels(const std::string& path, const std::vector<std::string>& channels);

// Every channel name of an image file, as read_channels accepts them (for messages and tests).
std::vector<std::string> list_channels(const std::string& path);

// An 8-bit RGB PNG. Throws std::runtime_error.
void write_png_rgb(const std::string& path, const RgbImage& image);

struct ExrLayer {
    std::string name;
    const float* data = nullptr;  // width * height floats
};
// A single-part scanline EXR, ZIP compressed, FLOAT channels, with string attributes.
void write_exr(const std::string& path, std::uint32_t width, std::uint32_t height, const std::vector<ExrLayer>& layers,
               const std::vector<std::pair<std::string, std::string>>& attributes = {});

}  // namespace ms::scene
