// A tiny 5x7 bitmap font (digits, capital letters, a little punctuation; lower case prints as upper
// case) for labelling the PNG previews without a font library. Glyphs drawn for this project.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ms {

struct RgbImage {
    std::uint32_t width = 0, height = 0;
    std::vector<std::uint8_t> pixels;  // RGB, row-major
    RgbImage(std::uint32_t w, std::uint32_t h, std::uint8_t r, std::uint8_t g, std::uint8_t b);
    void set(std::int64_t x, std::int64_t y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
    void fill(std::int64_t x0, std::int64_t y0, std::int64_t w, std::int64_t h, std::uint8_t r, std::uint8_t g, std::uint8_t b);
};

constexpr int kGlyphWidth = 5, kGlyphHeight = 7, kGlyphAdvance = 6;

// Pixel width of `text` at `scale` (each glyph kGlyphAdvance * scale, less the last gap).
std::uint32_t text_width(const std::string& text, int scale);
// Draws `text` with its top-left corner at (x, y); characters without a glyph draw as a box.
void draw_text(RgbImage& image, std::int64_t x, std::int64_t y, const std::string& text, int scale, std::uint8_t r,
               std::uint8_t g, std::uint8_t b);

}  // namespace ms
