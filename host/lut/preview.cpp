#include "lut/preview.hpp"

#include "io/png_file.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "lut/bitmap_font.hpp"

namespace ms {

std::vector<std::uint32_t> preview_slices(std::uint32_t n, std::uint32_t max_slices) {
    std::vector<std::uint32_t> out;
    if (n == 0) return out;
    const std::uint32_t k = std::max(1u, std::min(n, max_slices));
    for (std::uint32_t i = 0; i < k; ++i) {
        const std::uint32_t s = k == 1 ? 0 : std::uint32_t(std::lround(double(i) * (n - 1) / double(k - 1)));
        if (out.empty() || out.back() != s) out.push_back(s);
    }
    return out;
}

namespace {

std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

}  // namespace

void write_lut_preview(const std::string& path, const LutPreviewInput& lut, std::uint32_t max_slices) {
    if (!lut.data || lut.visibility_count == 0 || lut.n_dot_l_count == 0 || lut.n_dot_v_count == 0 || lut.channels == 0)
        throw std::invalid_argument("write_lut_preview: empty LUT");
    const bool labelled = lut.axes.size() == 3 && lut.roughness.size() == lut.channels;
    const std::vector<std::uint32_t> slices = preview_slices(lut.n_dot_v_count, max_slices);
    // Tiles of at least 128 pixels: room for two tick labels side by side under each.
    const std::uint32_t zoom = std::max(1u, (128 + std::max(lut.visibility_count, lut.n_dot_l_count) - 1) /
                                                std::max(lut.visibility_count, lut.n_dot_l_count));
    const std::uint32_t gap = 6;
    const std::uint32_t tw = lut.visibility_count * zoom, th = lut.n_dot_l_count * zoom;
    // Text at twice the font's size; a label line is 7 * 2 pixels plus spacing.
    const int S = 2;
    const std::uint32_t line = kGlyphHeight * S + 6;
    auto axis_value = [&](std::size_t a, std::uint32_t i) { return labelled ? lut.axes[a].value(i) : double(i); };
    // Ticks at the axis range's min, middle and max, placed where a lookup of that parameter lands in
    // the tile (texel centres: the tile's edges and middle; endpoints: the first and last texel centres).
    struct Tick {
        std::int64_t pixel;
        std::string label;
    };
    auto ticks = [&](std::size_t a, std::uint32_t n) {
        std::vector<Tick> t;
        const LutAxis ax = labelled ? lut.axes[a] : LutAxis{"", 0, double(n), n, TexelConvention::centres};
        for (double f : {0.0, 0.5, 1.0}) {
            const double texel = ax.texel == TexelConvention::centres ? f * n : f * (n - 1) + 0.5;
            t.push_back({std::min<std::int64_t>(std::int64_t(texel * zoom), std::int64_t(n) * zoom - 1),
                         labelled ? fmt(ax.min + f * (ax.max - ax.min)) : fmt(texel)});
            if (n == 1) break;
        }
        return t;
    };
    // Left margin: the row label ("N.V" over its value and "K/N"), then NdotL tick labels and marks.
    std::uint32_t row_label_w = text_width("N.V", S);
    for (auto k : slices) {
        row_label_w = std::max(row_label_w, text_width(fmt(axis_value(2, k)), S));
        row_label_w = std::max(row_label_w, text_width("SLICE " + std::to_string(k), S));
    }
    std::uint32_t tick_w = 0;
    for (const auto& t : ticks(1, lut.n_dot_l_count)) tick_w = std::max(tick_w, text_width(t.label, S));
    const std::uint32_t left = gap + row_label_w + 2 * gap + tick_w + 6;
    const std::uint32_t top = gap + 2 * line + gap + line;  // title (2 lines), column headers
    const std::uint32_t bar_w = 18, bar_area = 3 * gap + bar_w + 10 + text_width("0.75", S) + gap;
    const std::uint32_t tiles_w = lut.channels * tw + (lut.channels - 1) * gap;
    const std::uint32_t tiles_h = std::uint32_t(slices.size()) * th + std::uint32_t(slices.size() - 1) * gap;
    const std::uint32_t bottom = 6 + line + line + line + gap;  // tick labels, axis name, footer
    const std::string title1 = "MICROSHADOW LUT: R = ROUGHNESS (COLUMNS), N.V = NDOTV SLICE (ROWS)";
    const std::string title2 = "IN A TILE: VISIBILITY > (RIGHT), N.L v (DOWN). GREY: 0 (BLACK) TO 1 (WHITE)";
    const std::uint32_t width = std::max(left + tiles_w + bar_area, std::max(text_width(title1, S), text_width(title2, S)) + 2 * gap);
    const std::uint32_t height = top + std::max(tiles_h, 120u) + bottom;
    // Background: a dark blue-grey so 0-valued texels stay distinguishable from it.
    RgbImage img(width, height, 30, 40, 70);
    const std::uint8_t fg = 235;
    draw_text(img, gap, gap, title1, S, fg, fg, fg);
    draw_text(img, gap, gap + line, title2, S, fg, fg, fg);
    auto grey = [](float v) { return std::uint8_t(std::lround(255.0 * std::clamp(std::isfinite(v) ? double(v) : 0.0, 0.0, 1.0))); };
    for (std::uint32_t c = 0; c < lut.channels; ++c) {
        const std::int64_t x0 = left + c * (tw + gap);
        const std::string header = labelled ? "R = " + fmt(lut.roughness[c]) : "CHANNEL " + std::to_string(c);
        draw_text(img, x0 + (std::int64_t(tw) - text_width(header, S)) / 2, top - line, header, S, fg, fg, fg);
    }
    for (std::size_t si = 0; si < slices.size(); ++si) {
        const std::int64_t y0 = top + si * (th + gap);
        // Row label: "N.V", the slice's NdotV, and its index among the file's slices.
        draw_text(img, gap, y0, "N.V", S, fg, fg, fg);
        draw_text(img, gap, y0 + line, fmt(axis_value(2, slices[si])), S, fg, fg, fg);
        draw_text(img, gap, y0 + 2 * line, "SLICE " + std::to_string(slices[si]), S, 150, 160, 190);
        const auto lt = ticks(1, lut.n_dot_l_count);
        for (std::size_t k = 0; k < lt.size(); ++k) {  // NdotL ticks; end labels align inwards (rows never overlap)
            const std::int64_t ty = y0 + lt[k].pixel;
            img.fill(left - 5, ty, 4, 1, fg, fg, fg);
            std::int64_t ly = ty - kGlyphHeight * S / 2;
            if (k == 0) ly = y0;
            if (k + 1 == lt.size() && k != 0) ly = y0 + th - kGlyphHeight * S;
            draw_text(img, left - 6 - text_width(lt[k].label, S), ly, lt[k].label, S, fg, fg, fg);
        }
        for (std::uint32_t c = 0; c < lut.channels; ++c)
            for (std::uint32_t y = 0; y < th; ++y)
                for (std::uint32_t x = 0; x < tw; ++x) {
                    const std::size_t texel =
                        ((std::size_t(slices[si]) * lut.n_dot_l_count + y / zoom) * lut.visibility_count + x / zoom) * lut.channels + c;
                    const std::uint8_t g = grey(lut.data[texel]);
                    img.set(left + c * (tw + gap) + x, y0 + y, g, g, g);
                }
    }
    // Visibility ticks under every column, then the axis name.
    const std::int64_t yb = top + tiles_h;
    const auto vt = ticks(0, lut.visibility_count);
    for (std::uint32_t c = 0; c < lut.channels; ++c)
        for (std::size_t k = 0; k < vt.size(); ++k) {
            const std::int64_t x0 = left + c * (tw + gap), tx = x0 + vt[k].pixel;
            img.fill(tx, yb + 1, 1, 4, fg, fg, fg);
            // Labels under the first column only, at the ends, aligned inwards, so nothing overlaps or
            // runs into the next tile's; the middle tick is a mark (its value is halfway).
            if (c > 0) continue;
            if (k == 0) draw_text(img, x0, yb + 6, vt[k].label, S, fg, fg, fg);
            else if (k + 1 == vt.size()) draw_text(img, x0 + tw - text_width(vt[k].label, S), yb + 6, vt[k].label, S, fg, fg, fg);
        }
    const std::string vis = "VISIBILITY >";
    draw_text(img, left + (std::int64_t(tiles_w) - text_width(vis, S)) / 2, yb + 6 + line, vis, S, fg, fg, fg);
    const std::string footer = "SHOWING " + std::to_string(slices.size()) + " OF " + std::to_string(lut.n_dot_v_count) +
                               " N.V SLICES (0 TO " + std::to_string(lut.n_dot_v_count - 1) + ")";
    draw_text(img, gap, yb + 6 + 2 * line, footer, S, 150, 160, 190);
    // Colour bar: 1 at the top, 0 at the bottom, ticks every 0.25.
    const std::int64_t bx = left + tiles_w + 3 * gap, bh = std::max<std::int64_t>(tiles_h, 120);
    for (std::int64_t y = 0; y < bh; ++y) {
        const std::uint8_t g = grey(float(1.0 - double(y) / double(bh - 1)));
        img.fill(bx, top + y, bar_w, 1, g, g, g);
    }
    for (int k = 0; k <= 4; ++k) {
        const std::int64_t ty = top + std::lround((1.0 - k / 4.0) * double(bh - 1));
        img.fill(bx + bar_w, ty, 4, 1, fg, fg, fg);  // a short mark, a clear gap: not read as a minus sign
        draw_text(img, bx + bar_w + 10, ty - kGlyphHeight * S / 2, fmt(k / 4.0), S, fg, fg, fg);
    }
    std::vector<png_byte>& image = img.pixels;

    check_writable_destination(path);
    AtomicPath atomic(path);
    write_png(atomic.temp_path(), PngImage{width, height, 3, 8, image.data()});
    atomic.commit();
}

}  // namespace ms
