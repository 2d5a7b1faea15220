// PNG previews a person can read: HDR images tone-mapped (Reinhard, sRGB), and labelled plots of
// [0, 1] data (LUT tiles with axes and titles, drawn with a built-in 5 x 7 pixel font).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "env/image.hpp"

namespace ms::env {

// An 8-bit RGB canvas.
struct Canvas {
    std::uint32_t width = 0, height = 0;
    std::vector<std::uint8_t> rgb;
    Canvas(std::uint32_t w, std::uint32_t h, std::uint8_t grey = 255) : width(w), height(h), rgb(std::size_t(w) * h * 3, grey) {}
    void set(std::int64_t x, std::int64_t y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
    // Text at (x, y) top-left, scale s (pixels per font pixel); returns the width drawn.
    std::uint32_t text(std::int64_t x, std::int64_t y, const std::string& s, std::uint32_t scale = 2, std::uint8_t grey = 0);
    void line(std::int64_t x0, std::int64_t y0, std::int64_t x1, std::int64_t y1, std::uint8_t grey = 0);
};
std::uint32_t text_width(const std::string& s, std::uint32_t scale = 2);

// Atomically (checked destination, temporary, rename).
void write_png(const std::string& path, const Canvas& canvas);
// To `file` as it is, not atomically: for a temporary of an OutputSet whose files are committed together.
void write_png_file(const std::string& file, const Canvas& canvas);

// An HDR image (first three channels) tone-mapped onto a canvas: x * exposure, Reinhard, sRGB.
Canvas tone_map(const Image& image, double exposure = 1.0);
// An HDR image (first three channels) as PNG: x * exposure, Reinhard x / (1 + x), sRGB encoded.
// Images narrower than 384 pixels are magnified by whole texels; a caption, if any, goes below.
void write_png_preview(const std::string& path, const Image& image, double exposure = 1.0, const std::string& caption = "");
// That preview's canvas (write it with write_png or write_png_file).
Canvas preview_canvas(const Image& image, double exposure = 1.0, const std::string& caption = "");

// A horizontal cross (4n x 3n) as preview_canvas draws it, each face labelled with its name (+X, -X, +Y,
// -Y, +Z, -Z; white on a black shadow, so it reads on any sky), and the caption followed by the tone map
// named: "Reinhard x / (1 + x), sRGB, exposure E".
Canvas cross_preview_canvas(const Image& cross, double exposure, const std::string& caption);
// Labels the faces of a cross drawn at (ox, oy) with `face_pixels` canvas pixels per face.
void label_cross_faces(Canvas& canvas, std::int64_t ox, std::int64_t oy, std::uint32_t face_pixels);
// "Reinhard x / (1 + x), sRGB, exposure E": what tone_map does, for captions.
std::string tone_map_caption(double exposure);

// One tile of a labelled plot: a w x h grid of values in [0, 1] (grey), title above, x axis label
// below, y axis label to the left, ticks at 0, 0.5 and 1 of both axes (y increasing downwards).
struct PlotTile {
    std::string title;
    std::uint32_t width = 0, height = 0;
    std::vector<float> values;  // values[y * width + x]
};
void write_plot_png(const std::string& path, const std::vector<PlotTile>& tiles, const std::string& x_label,
                    const std::string& y_label, const std::string& caption);
Canvas plot_canvas(const std::vector<PlotTile>& tiles, const std::string& x_label, const std::string& y_label,
                   const std::string& caption);

}  // namespace ms::env
