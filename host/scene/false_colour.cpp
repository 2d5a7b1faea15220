#include "scene/false_colour.hpp"
#include "io/text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ms::scene {

namespace {

void lerp_map(const double (*stops)[3], int n, double t, std::uint8_t rgb[3]) {
    t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0) * (n - 1);
    const int i = std::min(n - 2, int(t));
    const double f = t - i;
    for (int c = 0; c < 3; ++c) rgb[c] = std::uint8_t(std::lround(255 * (stops[i][c] + f * (stops[i + 1][c] - stops[i][c]))));
}

}  // namespace

void sequential_colour(double t, std::uint8_t rgb[3]) {
    // Viridis at 9 stops.
    static const double v[9][3] = {{0.267, 0.005, 0.329}, {0.283, 0.141, 0.458}, {0.254, 0.265, 0.530},
                                   {0.207, 0.372, 0.553}, {0.164, 0.471, 0.558}, {0.128, 0.567, 0.551},
                                   {0.135, 0.659, 0.518}, {0.478, 0.821, 0.318}, {0.993, 0.906, 0.144}};
    lerp_map(v, 9, t, rgb);
}

void diverging_colour(double t, std::uint8_t rgb[3]) {
    static const double d[5][3] = {{0.085, 0.180, 0.550}, {0.400, 0.600, 0.900}, {0.970, 0.970, 0.970},
                                   {0.930, 0.450, 0.350}, {0.600, 0.050, 0.100}};
    lerp_map(d, 5, t, rgb);
}

RgbImage render_panels(std::uint32_t width, std::uint32_t height, const std::vector<Panel>& panels, const float* mask,
                       const std::vector<std::string>& title, std::uint32_t max_panel) {
    const std::uint32_t f = std::max(1u, (std::max(width, height) + max_panel - 1) / max_panel);
    const std::uint32_t pw = std::max(1u, width / f), ph = std::max(1u, height / f);
    const int S = 2;
    const std::uint32_t line = kGlyphHeight * S + 6, gap = 10, bar_w = 14;
    const std::uint32_t bar_area = gap + bar_w + 10 + text_width("-0.00000", S) + gap;
    std::uint32_t cell = pw + bar_area;
    for (const auto& p : panels) cell = std::max(cell, text_width(p.label, S) + gap);
    std::uint32_t w = gap + std::uint32_t(panels.size()) * cell;
    for (const auto& t : title) w = std::max(w, text_width(t, S) + 2 * gap);
    const std::uint32_t top = gap + std::uint32_t(title.size()) * line + line + 10;  // room for the bar's top label
    const std::uint32_t h = top + std::max(ph, 100u) + gap + line + 8;
    RgbImage img(w, h, 30, 40, 70);
    const std::uint8_t fg = 235;
    for (std::size_t i = 0; i < title.size(); ++i) draw_text(img, gap, gap + std::int64_t(i) * line, title[i], S, fg, fg, fg);
    for (std::size_t k = 0; k < panels.size(); ++k) {
        const Panel& p = panels[k];
        const std::int64_t x0 = gap + std::int64_t(k) * cell, y0 = top;
        draw_text(img, x0, top - line - 10, p.label, S, fg, fg, fg);
        auto colour = [&](double v, std::uint8_t rgb[3]) {
            if (p.diverging) diverging_colour(p.range > 0 ? 0.5 + 0.5 * v / p.range : 0.5, rgb);
            else sequential_colour(p.hi > p.lo ? (v - p.lo) / (p.hi - p.lo) : 0, rgb);
        };
        for (std::uint32_t y = 0; y < ph; ++y)
            for (std::uint32_t x = 0; x < pw; ++x) {
                double sum = 0;
                std::uint32_t n = 0;
                for (std::uint32_t dy = 0; dy < f; ++dy)
                    for (std::uint32_t dx = 0; dx < f; ++dx) {
                        const std::size_t i = std::size_t(y * f + dy) * width + (x * f + dx);
                        if (y * f + dy >= height || x * f + dx >= width) continue;
                        if (mask && mask[i] == 0) continue;
                        sum += p.data[i];
                        ++n;
                    }
                std::uint8_t rgb[3] = {60, 60, 60};
                if (n) colour(sum / n, rgb);
                img.set(x0 + x, y0 + y, rgb[0], rgb[1], rgb[2]);
            }
        // Colour bar with 5 ticks.
        const std::int64_t bx = x0 + pw + gap, bh = std::max<std::int64_t>(ph, 100);
        for (std::int64_t y = 0; y < bh; ++y) {
            std::uint8_t rgb[3];
            const double t = 1.0 - double(y) / double(bh - 1);
            if (p.diverging) diverging_colour(t, rgb);
            else sequential_colour(t, rgb);
            img.fill(bx, y0 + y, bar_w, 1, rgb[0], rgb[1], rgb[2]);
        }
        for (int t = 0; t <= 4; ++t) {
            const std::int64_t ty = y0 + std::lround((1.0 - t / 4.0) * double(bh - 1));
            const double value = p.diverging ? -p.range + 2 * p.range * t / 4.0 : p.lo + (p.hi - p.lo) * t / 4.0;
            img.fill(bx + bar_w, ty, 4, 1, fg, fg, fg);
            draw_text(img, bx + bar_w + 10, ty - kGlyphHeight * S / 2, format_g(value), S, fg, fg, fg);
        }
    }
    if (f > 1)
        draw_text(img, gap, h - line, "SHOWN AT 1/" + std::to_string(f) + " SIZE (BOX FILTER), GREY: MASKED", S, 150, 160, 190);
    else
        draw_text(img, gap, h - line, "GREY: MASKED", S, 150, 160, 190);
    return img;
}

}  // namespace ms::scene
