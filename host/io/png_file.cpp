#include "io/png_file.hpp"

#include <png.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

namespace ms {

namespace {

// libpng's message goes into the exception (its default handler prints it raw on stderr).
// libpng's own "Write Error" does not say why: the errno of the failed fwrite (ENOSPC on a full disk)
// is kept with it.
struct PngWriteMessage {
    char text[256] = {};
    int err = 0;
};
void png_write_error(png_structp png, png_const_charp message) {
    auto* m = static_cast<PngWriteMessage*>(png_get_error_ptr(png));
    m->err = errno;
    std::snprintf(m->text, sizeof m->text, "%s", message ? message : "unknown error");
    png_longjmp(png, 1);
}
void png_write_warning(png_structp, png_const_charp) {}

}  // namespace

void write_png(const std::string& path, const PngImage& image, const std::string& text_key, const std::string& text) {
    if ((image.channels != 3 && image.channels != 4) || (image.bits != 8 && image.bits != 16) || !image.pixels ||
        image.width == 0 || image.height == 0)
        throw std::invalid_argument("write_png: " + path + ": not an 8/16-bit RGB or RGBA image");
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) throw std::runtime_error("cannot open " + path + " for writing");
    PngWriteMessage message;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &message, png_write_error, png_write_warning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        throw std::runtime_error("libpng: out of memory");
    }
    png_text chunk{};
    const std::size_t row_bytes = std::size_t(image.width) * image.channels * (image.bits / 8);
    // libpng reports errors by longjmp: everything with a destructor is constructed above and not
    // touched again until after the last libpng call.
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        throw std::runtime_error("cannot write " + path + " (libpng: " + std::string(message.text) +
                                 (message.err ? std::string(": ") + std::strerror(message.err) : std::string()) + ")");
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, image.width, image.height, image.bits,
                 image.channels == 4 ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (image.linear_data) png_set_gAMA_fixed(png, info, PNG_GAMMA_LINEAR);  // gamma 1.0: samples are linear
    if (!text_key.empty()) {
        chunk.compression = PNG_ITXT_COMPRESSION_NONE;
        chunk.key = const_cast<char*>(text_key.c_str());
        chunk.text = const_cast<char*>(text.c_str());
        chunk.itxt_length = text.size();
        png_set_text(png, info, &chunk, 1);
    }
    png_write_info(png, info);
    for (std::uint32_t y = 0; y < image.height; ++y)
        png_write_row(png, const_cast<png_bytep>(image.pixels + std::size_t(y) * row_bytes));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    if (std::fclose(f) != 0) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
}

}  // namespace ms
