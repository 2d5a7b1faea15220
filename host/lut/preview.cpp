#include "lut/preview.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "io/atomic_file.hpp"

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

void write_lut_preview(const std::string& path, const LutPreviewInput& lut, std::uint32_t max_slices) {
    if (!lut.data || lut.visibility_count == 0 || lut.n_dot_l_count == 0 || lut.n_dot_v_count == 0 || lut.channels == 0)
        throw std::invalid_argument("write_lut_preview: empty LUT");
    const std::vector<std::uint32_t> slices = preview_slices(lut.n_dot_v_count, max_slices);
    const std::uint32_t zoom = std::max(1u, (96 + std::max(lut.visibility_count, lut.n_dot_l_count) - 1) /
                                                std::max(lut.visibility_count, lut.n_dot_l_count));
    const std::uint32_t gap = 4;
    const std::uint32_t tw = lut.visibility_count * zoom, th = lut.n_dot_l_count * zoom;
    const std::uint32_t width = lut.channels * tw + (lut.channels + 1) * gap;
    const std::uint32_t height = std::uint32_t(slices.size()) * th + std::uint32_t(slices.size() + 1) * gap;
    // Background between tiles: a dark blue-grey so 0-valued texels stay distinguishable from the gap.
    std::vector<png_byte> image(std::size_t(width) * height * 3);
    for (std::size_t i = 0; i < image.size(); i += 3) image[i] = 30, image[i + 1] = 40, image[i + 2] = 70;
    for (std::size_t si = 0; si < slices.size(); ++si)
        for (std::uint32_t c = 0; c < lut.channels; ++c)
            for (std::uint32_t y = 0; y < th; ++y)
                for (std::uint32_t x = 0; x < tw; ++x) {
                    const std::size_t texel =
                        ((std::size_t(slices[si]) * lut.n_dot_l_count + y / zoom) * lut.visibility_count + x / zoom) *
                            lut.channels + c;
                    const float v = lut.data[texel];
                    const png_byte g = png_byte(std::lround(255.0 * std::clamp(std::isfinite(v) ? double(v) : 0.0, 0.0, 1.0)));
                    const std::size_t px = gap + c * (tw + gap) + x, py = gap + si * (th + gap) + y;
                    png_byte* p = &image[(py * width + px) * 3];
                    p[0] = p[1] = p[2] = g;
                }

    check_writable_destination(path);
    AtomicPath atomic(path);
    std::FILE* f = std::fopen(atomic.temp_path().c_str(), "wb");
    if (!f) throw std::runtime_error("cannot open " + atomic.temp_path() + " for writing");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        throw std::runtime_error("libpng: out of memory");
    }
    // libpng reports errors by longjmp; nothing with a destructor is created between here and the end.
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        throw std::runtime_error("libpng failed writing " + path);
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (std::uint32_t y = 0; y < height; ++y) png_write_row(png, &image[std::size_t(y) * width * 3]);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    if (std::fclose(f) != 0) throw std::runtime_error("cannot write " + path);
    atomic.commit();
}

}  // namespace ms
