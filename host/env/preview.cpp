#include "env/preview.hpp"

#include "io/png_file.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "env/cubemap.hpp"
#include "io/atomic_file.hpp"

namespace ms::env {

namespace {

// 5 x 7 glyphs, one string of 7 rows of 5 pixels each ('#' on).
const std::map<char, const char*>& font() {
    static const std::map<char, const char*> f = {
        {'0', ".###.#...##..###.#.###..##...#.###."},
        {'1', "..#...##....#....#....#....#...###."},
        {'2', ".###.#...#....#...#...#...#...#####"},
        {'3', "####.....#....#.###.....#....#####."},
        {'4', "...#...##..#.#.#..#.#####...#....#."},
        {'5', "######....####.....#....##...#.###."},
        {'6', "..##..#...#....####.#...##...#.###."},
        {'7', "#####....#...#...#...#....#....#..."},
        {'8', ".###.#...##...#.###.#...##...#.###."},
        {'9', ".###.#...##...#.####....#...#..##.."},
        {'.', "..........................##...##.."},
        {'-', "...............#####..............."},
        {'=', "..........#####.....#####.........."},
        {' ', "..................................."},
        {'(', "...#...#...#....#....#.....#.....#."},
        {')', ".#.....#.....#....#....#...#...#..."},
        {',', ".....................##....#...#..."},
        {':', "......##...##........##...##......."},
        {'/', ".........#...#...#...#...#........."},
        {'^', "..#...#.#.#...#...................."},
        {'+', ".......#....#..#####..#....#......."},
        {'x', "..........#...#.#.#...#...#.#.#...#"},
        {'a', "...........###.....#.#####...#.####"},
        {'b', "#....#....####.#...##...##...#####."},
        {'c', "...........###.#....#....#...#.###."},
        {'d', "....#....#.#####...##...##...#.####"},
        {'e', "...........###.#...#######.....###."},
        {'f', "..##..#..#.#...###...#....#....#..."},
        {'g', "......#####...##...#.####....#.###."},
        {'h', "#....#....#.##.##..##...##...##...#"},
        {'i', "..#........##....#....#....#...###."},
        {'k', "#....#....#..#.#.#..##...#.#..#..#."},
        {'l', ".##....#....#....#....#....#...###."},
        {'m', "..........##.#.#.#.##.#.##...##...#"},
        {'n', "..........#.##.##..##...##...##...#"},
        {'o', "...........###.#...##...##...#.###."},
        {'p', "..........####.#...#####.#....#...."},
        {'q', "...........#####...#.####....#....#"},
        {'r', "..........#.##.##..##....#....#...."},
        {'s', "...........#####.....###.....#####."},
        {'t', ".#....#...###...#....#....#..#..##."},
        {'u', "..........#...##...##...##..##.##.#"},
        {'v', "..........#...##...##...#.#.#...#.."},
        {'w', "..........#...##...##.#.##.#.#.#.#."},
        {'y', "..........#...##...#.####....#.###."},
        {'z', "..........#####...#...#...#...#####"},
        {'A', ".###.#...##...#######...##...##...#"},
        {'B', "####.#...##...#####.#...##...#####."},
        {'C', ".###.#...##....#....#....#...#.###."},
        {'D', "####.#...##...##...##...##...#####."},
        {'E', "######....#....####.#....#....#####"},
        {'F', "######....#....####.#....#....#...."},
        {'G', ".###.#...##....#.####...##...#.####"},
        {'H', "#...##...##...#######...##...##...#"},
        {'I', ".###...#....#....#....#....#...###."},
        {'K', "#...##..#.#.#..##...#.#..#..#.#...#"},
        {'L', "#....#....#....#....#....#....#####"},
        {'M', "#...###.###.#.##.#.##...##...##...#"},
        {'N', "#...##...###..##.#.##..###...##...#"},
        {'O', ".###.#...##...##...##...##...#.###."},
        {'P', "####.#...##...#####.#....#....#...."},
        {'R', "####.#...##...#####.#.#..#..#.#...#"},
        {'S', ".#####....#.....###.....#....#####."},
        {'T', "#####..#....#....#....#....#....#.."},
        {'U', "#...##...##...##...##...##...#.###."},
        {'V', "#...##...##...##...##...#.#.#...#.."},
        {'X', "#...##...#.#.#...#...#.#.#...##...#"},
        {'Y', "#...##...#.#.#...#....#....#....#.."},
        {'Z', "#####....#...#...#...#...#....#####"},
    };
    return f;
}

std::uint8_t srgb8(double linear) {
    const double c = std::clamp(linear, 0.0, 1.0);
    const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1 / 2.4) - 0.055;
    return std::uint8_t(std::lround(255 * s));
}

}  // namespace

void Canvas::set(std::int64_t x, std::int64_t y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    if (x < 0 || y < 0 || x >= std::int64_t(width) || y >= std::int64_t(height)) return;
    std::uint8_t* p = &rgb[(std::size_t(y) * width + std::size_t(x)) * 3];
    p[0] = r, p[1] = g, p[2] = b;
}

std::uint32_t text_width(const std::string& s, std::uint32_t scale) { return std::uint32_t(s.size()) * 6 * scale; }

std::uint32_t Canvas::text(std::int64_t x, std::int64_t y, const std::string& s, std::uint32_t scale, std::uint8_t grey) {
    const auto& f = font();
    for (std::size_t i = 0; i < s.size(); ++i) {
        auto it = f.find(s[i]);
        if (it == f.end()) it = f.find(' ');
        const std::string g = it->second;
        for (int row = 0; row < 7; ++row)
            for (int col = 0; col < 5; ++col) {
                const std::size_t k = std::size_t(row) * 5 + col;
                if (k < g.size() && g[k] == '#')
                    for (std::uint32_t dy = 0; dy < scale; ++dy)
                        for (std::uint32_t dx = 0; dx < scale; ++dx)
                            set(x + std::int64_t((i * 6 + col) * scale + dx), y + std::int64_t(row * scale + dy), grey, grey, grey);
            }
    }
    return text_width(s, scale);
}

void Canvas::line(std::int64_t x0, std::int64_t y0, std::int64_t x1, std::int64_t y1, std::uint8_t grey) {
    const std::int64_t n = std::max(std::abs(x1 - x0), std::abs(y1 - y0));
    for (std::int64_t i = 0; i <= n; ++i) {
        const double t = n == 0 ? 0 : double(i) / n;
        set(std::llround(x0 + t * (x1 - x0)), std::llround(y0 + t * (y1 - y0)), grey, grey, grey);
    }
}

void write_png_file(const std::string& file, const Canvas& c) { ms::write_png(file, PngImage{c.width, c.height, 3, 8, c.rgb.data()}); }

void write_png(const std::string& path, const Canvas& c) {
    check_writable_destination(path);
    AtomicPath atomic(path);
    write_png_file(atomic.temp_path(), c);
    atomic.commit();
}

void write_png_preview(const std::string& path, const Image& img, double exposure, const std::string& caption) {
    write_png(path, preview_canvas(img, exposure, caption));
}

Canvas preview_canvas(const Image& img, double exposure, const std::string& caption) {
    Canvas mapped = tone_map(img, exposure);
    if (caption.empty() && img.width >= 384) return mapped;
    // Small images (a 32-texel irradiance cross is 128 x 96) are magnified by whole texels to at least
    // 384 pixels across, so a person sees the faces; the caption goes on a dark strip below.
    const std::uint32_t zoom = std::max(1u, (384 + img.width - 1) / img.width);
    const std::uint32_t w = std::max(img.width * zoom, caption.empty() ? 0u : text_width(caption, 1) + 16);
    Canvas c(w, img.height * zoom + (caption.empty() ? 0 : 24), 30);
    for (std::uint32_t y = 0; y < img.height * zoom; ++y)
        for (std::uint32_t x = 0; x < img.width * zoom; ++x) {
            const std::uint8_t* p = &mapped.rgb[(std::size_t(y / zoom) * img.width + x / zoom) * 3];
            c.set(x, y, p[0], p[1], p[2]);
        }
    if (!caption.empty()) c.text(8, img.height * zoom + 8, caption, 1, 220);
    return c;
}

std::string tone_map_caption(double exposure) {
    char text[64];
    std::snprintf(text, sizeof text, "Reinhard x / (1 + x), sRGB, exposure %g", exposure);
    return text;
}

void label_cross_faces(Canvas& canvas, std::int64_t ox, std::int64_t oy, std::uint32_t face_pixels) {
    static const char* const kNames[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    const std::uint32_t scale = face_pixels >= 96 ? 2 : 1;
    if (face_pixels < 8 * scale + 4) return;  // too small to hold a label
    for (int f = 0; f < 6; ++f) {
        std::uint32_t fx, fy;
        cross_face_offset(f, face_pixels, fx, fy);
        canvas.text(ox + fx + 3, oy + fy + 3, kNames[f], scale, 0);  // shadow
        canvas.text(ox + fx + 2, oy + fy + 2, kNames[f], scale, 255);
    }
}

Canvas cross_preview_canvas(const Image& cross, double exposure, const std::string& caption) {
    const std::string full = caption.empty() ? tone_map_caption(exposure) : caption + "; " + tone_map_caption(exposure);
    Canvas c = preview_canvas(cross, exposure, full);
    const std::uint32_t zoom = std::max(1u, (384 + cross.width - 1) / cross.width);  // preview_canvas's magnification
    label_cross_faces(c, 0, 0, cross.width / 4 * zoom);
    return c;
}

Canvas tone_map(const Image& img, double exposure) {
    if (img.channels < 3) throw std::invalid_argument("tone_map: need RGB");
    Canvas c(img.width, img.height, 0);
    for (std::uint32_t y = 0; y < img.height; ++y)
        for (std::uint32_t x = 0; x < img.width; ++x) {
            std::uint8_t v[3];
            for (int k = 0; k < 3; ++k) {
                const double l = std::max(0.0, double(img.at(x, y, k))) * exposure;
                v[k] = srgb8(std::isfinite(l) ? l / (1 + l) : 1.0);
            }
            c.set(x, y, v[0], v[1], v[2]);
        }
    return c;
}

void write_plot_png(const std::string& path, const std::vector<PlotTile>& tiles, const std::string& x_label,
                    const std::string& y_label, const std::string& caption) {
    write_png(path, plot_canvas(tiles, x_label, y_label, caption));
}

Canvas plot_canvas(const std::vector<PlotTile>& tiles, const std::string& x_label, const std::string& y_label,
                   const std::string& caption) {
    if (tiles.empty()) throw std::invalid_argument("write_plot_png: no tiles");
    const std::uint32_t tw = tiles[0].width, th = tiles[0].height;
    const std::uint32_t zoom = std::max(1u, 256 / std::max(tw, th));
    const std::uint32_t pw = tw * zoom, ph = th * zoom;
    // The y label sits above the tick labels, right-aligned to the axis, at the size of the other text.
    const std::uint32_t left = std::max(110u, text_width(y_label) + 24), top = 56, gap = left, bottom = 80;
    const std::uint32_t bar = 70;  // the grey scale's colour bar at the right
    const std::uint32_t width = left + std::uint32_t(tiles.size()) * (pw + gap) + bar, height = top + ph + bottom;
    Canvas c(width, height, 255);
    for (std::size_t t = 0; t < tiles.size(); ++t) {
        const PlotTile& tile = tiles[t];
        const std::int64_t x0 = left + std::int64_t(t) * (pw + gap), y0 = top;
        c.text(x0 + (pw - text_width(tile.title)) / 2, 18, tile.title);
        for (std::uint32_t y = 0; y < ph; ++y)
            for (std::uint32_t x = 0; x < pw; ++x) {
                const float v = tile.values[std::size_t(y / zoom) * tile.width + x / zoom];
                const std::uint8_t g = std::uint8_t(std::lround(255.0 * std::clamp(std::isfinite(v) ? double(v) : 0.0, 0.0, 1.0)));
                c.set(x0 + x, y0 + y, g, g, g);
            }
        // Frame, ticks (0, 0.5, 1) and tick labels.
        c.line(x0 - 1, y0 - 1, x0 + pw, y0 - 1);
        c.line(x0 - 1, y0 + ph, x0 + pw, y0 + ph);
        c.line(x0 - 1, y0 - 1, x0 - 1, y0 + ph);
        c.line(x0 + pw, y0 - 1, x0 + pw, y0 + ph);
        const char* labels[3] = {"0", "0.5", "1"};
        for (int k = 0; k < 3; ++k) {
            const std::int64_t xt = x0 + std::int64_t(k * (pw - 1) / 2), yt = y0 + std::int64_t(k * (ph - 1) / 2);
            c.line(xt, y0 + ph, xt, y0 + ph + 6);
            c.text(xt - text_width(labels[k]) / 2, y0 + ph + 10, labels[k]);
            c.line(x0 - 7, yt, x0 - 1, yt);
            c.text(x0 - 10 - text_width(labels[k]), yt - 7, labels[k]);
        }
        c.text(x0 + (pw - text_width(x_label)) / 2, y0 + ph + 32, x_label);
        c.text(x0 - 10 - std::int64_t(text_width(y_label)), y0 - 22, y_label);
    }
    // Colour bar: 0 (black, bottom) to 1 (white, top), ticks at 0, 0.5, 1.
    const std::int64_t bx = left + std::int64_t(tiles.size()) * (pw + gap) - gap + 30;  // right of the last tile
    for (std::uint32_t y = 0; y < ph; ++y) {
        const std::uint8_t g = std::uint8_t(std::lround(255.0 * (1.0 - double(y) / double(ph - 1))));
        for (std::int64_t x = 0; x < 16; ++x) c.set(bx + x, top + y, g, g, g);
    }
    c.line(bx - 1, top - 1, bx + 16, top - 1);
    c.line(bx - 1, top + ph, bx + 16, top + ph);
    c.line(bx - 1, top - 1, bx - 1, top + ph);
    c.line(bx + 16, top - 1, bx + 16, top + ph);
    const char* bar_labels[3] = {"1", "0.5", "0"};
    for (int k = 0; k < 3; ++k) c.text(bx + 22, top + std::int64_t(k * (ph - 1) / 2) - 7, bar_labels[k]);
    c.text(left, height - 20, caption, 1, 80);
    return c;
}

}  // namespace ms::env
