// The bake's --preview PNG: labelled with the roughness of every column, the NdotV value of
// every row, axis ticks and a colour bar. The labels are found by rendering the expected text with the
// same bitmap font and searching the picture for those exact pixels; the colour bar by its ramp.
#include <gtest/gtest.h>
#include <png.h>

#include <cstdio>
#include <cstring>

#include "cli_runner.hpp"
#include "lut/bitmap_font.hpp"
#include "lut/exr_lut.hpp"
#include "lut/preview.hpp"

namespace {

using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

ms::RgbImage read_rgb_png(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw std::runtime_error("cannot open " + path);
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        throw std::runtime_error("libpng failed reading " + path);
    }
    png_init_io(png, f);
    png_read_info(png, info);
    const std::uint32_t w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    if (png_get_color_type(png, info) != PNG_COLOR_TYPE_RGB || png_get_bit_depth(png, info) != 8)
        throw std::runtime_error(path + ": expected 8-bit RGB");
    ms::RgbImage img(w, h, 0, 0, 0);
    for (std::uint32_t y = 0; y < h; ++y) png_read_row(png, &img.pixels[std::size_t(y) * w * 3], nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    return img;
}

// Whether `text`, drawn at scale 2 in any colour, appears in `img`: every glyph pixel of the rendered
// text has one colour in the picture, and every background pixel of the text box another.
bool contains_text(const ms::RgbImage& img, const std::string& text) {
    const int S = 2;
    const std::uint32_t tw = ms::text_width(text, S), th = ms::kGlyphHeight * S;
    ms::RgbImage mask(tw, th, 0, 0, 0);
    ms::draw_text(mask, 0, 0, text, S, 255, 255, 255);
    auto on = [&](std::uint32_t x, std::uint32_t y) { return mask.pixels[(std::size_t(y) * tw + x) * 3] != 0; };
    auto px = [&](std::uint32_t x, std::uint32_t y) { return &img.pixels[(std::size_t(y) * img.width + x) * 3]; };
    // A cheap filter before the full comparison: the first glyph pixel and the first background pixel
    // of the rendered text must differ in the picture.
    std::int64_t f = -1, b = -1;
    for (std::uint32_t k = 0; k < tw * th; ++k) {
        std::int64_t& first = on(k % tw, k / tw) ? f : b;
        if (first < 0) first = k;
    }
    if (f < 0 || b < 0) return false;
    for (std::uint32_t y0 = 0; y0 + th <= img.height; ++y0)
        for (std::uint32_t x0 = 0; x0 + tw <= img.width; ++x0) {
            if (std::memcmp(px(x0 + f % tw, y0 + f / tw), px(x0 + b % tw, y0 + b / tw), 3) == 0) continue;
            const std::uint8_t *fg = nullptr, *bg = nullptr;
            bool ok = true;
            for (std::uint32_t y = 0; ok && y < th; ++y)
                for (std::uint32_t x = 0; ok && x < tw; ++x) {
                    const std::uint8_t* p = px(x0 + x, y0 + y);
                    const std::uint8_t*& ref = on(x, y) ? fg : bg;
                    if (!ref) ref = p;
                    ok = std::memcmp(ref, p, 3) == 0;
                }
            if (ok && fg && bg && std::memcmp(fg, bg, 3) != 0) return true;
        }
    return false;
}

class PreviewTest : public ScratchDirTest {
protected:
    PreviewTest() : ScratchDirTest("preview") {}
};

TEST_F(PreviewTest, LabelsTicksAndColourBar) {
    const RunResult r = run_shell(std::string(MICROSHADOW_CLI) + " bake -q --size 16 --samples 4096 --out " + path("l.exr") +
                                  " --preview " + path("p.png") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const ms::LutFile lut = ms::read_lut(path("l.exr"));
    const ms::RgbImage img = read_rgb_png(path("p.png"));
    // Column headers, the values of the NdotV slices shown (preview_slices), axis ticks and the footer.
    for (const std::string t : {"R = 0.1", "R = 0.4", "R = 0.7", "R = 1", "VISIBILITY >", "SHOWING 8 OF 16 N.V SLICES"})
        EXPECT_TRUE(contains_text(img, t)) << t;
    for (std::uint32_t k : ms::preview_slices(16, 8)) {
        char value[32];
        std::snprintf(value, sizeof value, "%.3g", lut.n_dot_v().value(k));
        EXPECT_TRUE(contains_text(img, value)) << "NdotV of slice " << k << ": " << value;
        EXPECT_TRUE(contains_text(img, "SLICE " + std::to_string(k))) << k;
    }
    for (const std::string t : {"0", "0.5", "1", "0.25", "0.75"}) EXPECT_TRUE(contains_text(img, t)) << t;
    EXPECT_FALSE(contains_text(img, "R = 0.2")) << "the search must be able to fail";
    // Colour bar: a column running from white at the top to black at the bottom, never increasing.
    bool bar = false;
    for (std::uint32_t x = 0; x < img.width && !bar; ++x)
        for (std::uint32_t y = 0; y + 120 <= img.height && !bar; ++y) {
            const std::uint8_t* top = &img.pixels[(std::size_t(y) * img.width + x) * 3];
            if (top[0] != 255 || top[1] != 255 || top[2] != 255) continue;
            std::uint32_t yy = y;
            std::uint8_t last = 255;
            while (yy + 1 < img.height) {
                const std::uint8_t* p = &img.pixels[(std::size_t(yy + 1) * img.width + x) * 3];
                if (p[0] != p[1] || p[1] != p[2] || p[0] > last) break;
                last = p[0];
                ++yy;
            }
            bar = last == 0 && yy - y >= 119;
        }
    EXPECT_TRUE(bar) << "no white-to-black colour bar of at least 120 pixels";
}

}  // namespace
