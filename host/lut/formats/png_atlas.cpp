#include "lut/formats/png_atlas.hpp"

#include <png.h>

#include <cstdio>
#include <stdexcept>

#include "io/atomic_file.hpp"

namespace ms::lutfmt {

void write_png_atlas(const std::string& path, const LutFile& lut, PixelEncoding encoding) {
    check_lut_shape(lut);
    if (encoding != PixelEncoding::unorm8 && encoding != PixelEncoding::unorm16)
        throw std::invalid_argument("a PNG LUT stores unorm8 or unorm16, not " + to_string(encoding) + " (" + path + ")");
    const nlohmann::json meta = format_metadata(lut, encoding, "png-atlas", true);
    const std::string json = meta.dump();
    const unsigned bits = encoding == PixelEncoding::unorm8 ? 8 : 16;
    const std::vector<float> rgba = rgba_padded(lut);
    const std::size_t row_bytes = std::size_t(lut.width) * 4 * (bits / 8);
    std::vector<png_byte> image(row_bytes * lut.height);
    for (std::size_t i = 0; i < rgba.size(); ++i) {
        const std::uint32_t q = to_unorm(rgba[i], bits);
        if (bits == 8) image[i] = png_byte(q);
        else image[2 * i] = png_byte(q >> 8), image[2 * i + 1] = png_byte(q);  // PNG samples are big-endian
    }

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
    png_text text{};
    // libpng reports errors by longjmp: everything with a destructor above is constructed already and
    // not touched again until after the last libpng call.
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        throw std::runtime_error("libpng failed writing " + path);
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, lut.width, lut.height, row_bytes == std::size_t(lut.width) * 4 ? 8 : 16, PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    text.compression = PNG_ITXT_COMPRESSION_NONE;
    text.key = const_cast<char*>("microshadow");
    text.text = const_cast<char*>(json.c_str());
    text.itxt_length = json.size();
    png_set_text(png, info, &text, 1);
    png_write_info(png, info);
    for (std::uint32_t y = 0; y < lut.height; ++y) png_write_row(png, &image[std::size_t(y) * row_bytes]);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    if (std::fclose(f) != 0) throw std::runtime_error("cannot write " + path);
    atomic.commit();
}

}  // namespace ms::lutfmt
