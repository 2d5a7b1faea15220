#include "scene/histogram_plot.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>

#include "scene/false_colour.hpp"
#include "io/text.hpp"

namespace ms::scene {

namespace {

}  // namespace

RgbImage render_histograms(const std::vector<HistogramPanel>& panels, const std::vector<std::string>& title) {
    const int S = 2;  // font scale: 10 x 14 pixel glyphs
    const std::uint32_t line = kGlyphHeight * S + 6, gap = 12;
    const std::uint32_t plot_w = 480, plot_h = 140;
    // Left margin: the count labels; below the plot: tick labels and the axis caption.
    const std::uint32_t left = gap + text_width("0000000", S) + 8;
    const std::uint32_t panel_h = line + 8 + plot_h + 6 + line + line + gap;
    std::uint32_t w = left + plot_w + 2 * gap;
    for (const auto& t : title) w = std::max(w, text_width(t, S) + 2 * gap);
    const std::uint32_t top = gap + std::uint32_t(title.size()) * line + 6;
    RgbImage img(w, top + std::uint32_t(panels.size()) * panel_h, 30, 40, 70);
    const std::uint8_t fg = 235;
    for (std::size_t i = 0; i < title.size(); ++i) draw_text(img, gap, gap + std::int64_t(i) * line, title[i], S, fg, fg, fg);
    for (std::size_t k = 0; k < panels.size(); ++k) {
        const HistogramPanel& p = panels[k];
        const std::vector<std::uint64_t>& counts = *p.counts;
        std::uint64_t total = 0, peak = 0;
        for (auto c : counts) total += c, peak = std::max(peak, c);
        const std::int64_t y0 = top + std::int64_t(k) * panel_h;
        draw_text(img, gap, y0, to_upper(p.title) + ": DATA " + format_g(p.data_min) + " TO " + format_g(p.data_max), S, fg, fg, fg);
        const std::int64_t px = left, py = y0 + line + 8;
        img.fill(px, py, plot_w, plot_h, 20, 26, 48);
        // Bars: height proportional to the count, the peak filling the plot; coloured by the parameter.
        const std::size_t n = counts.size();
        for (std::size_t b = 0; b < n; ++b) {
            const std::int64_t x0 = px + std::int64_t(b * plot_w / n), x1 = px + std::int64_t((b + 1) * plot_w / n);
            const std::int64_t h = peak ? std::int64_t(double(counts[b]) / double(peak) * plot_h + 0.5) : 0;
            std::uint8_t rgb[3];
            sequential_colour(n > 1 ? double(b) / double(n - 1) : 0.5, rgb);
            img.fill(x0, py + plot_h - h, std::max<std::int64_t>(1, x1 - x0 - 1), h, rgb[0], rgb[1], rgb[2]);
        }
        // Axes: the count axis (left) and the parameter axis (below), with ticks.
        img.fill(px - 2, py, 2, plot_h + 2, fg, fg, fg);
        img.fill(px - 2, py + plot_h, plot_w + 2, 2, fg, fg, fg);
        draw_text(img, px - 8 - text_width("COUNT", S), py + plot_h / 2 - kGlyphHeight, "COUNT", S, 180, 190, 210);
        const std::string peak_label = std::to_string(peak);
        draw_text(img, px - 8 - text_width(peak_label, S), py, peak_label, S, fg, fg, fg);
        draw_text(img, px - 8 - text_width("0", S), py + plot_h - kGlyphHeight * S, "0", S, fg, fg, fg);
        for (int t = 0; t <= 2; ++t) {
            const double v = p.min + (p.max - p.min) * t / 2.0;
            const std::int64_t x = px + std::int64_t(plot_w) * t / 2;
            img.fill(x - 1, py + plot_h + 2, 2, 6, fg, fg, fg);
            const std::string label = format_g(v);
            const std::int64_t lw = text_width(label, S);
            draw_text(img, std::clamp<std::int64_t>(x - lw / 2, px - 4, px + plot_w - lw + 4), py + plot_h + 10, label, S, fg, fg, fg);
        }
        draw_text(img, px, py + plot_h + 10 + line, "BARS: LOOKUPS PER BIN OF " + format_g((p.max - p.min) / double(n)) + ", " +
                      std::to_string(total) + " IN ALL", S, 180, 190, 210);
    }
    return img;
}

}  // namespace ms::scene
