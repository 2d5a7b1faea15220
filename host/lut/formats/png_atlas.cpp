#include "lut/formats/png_atlas.hpp"

#include "io/png_file.hpp"

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
    // The metadata rides along as an iTXt chunk, UTF-8 JSON under the key "microshadow".
    PngImage png{lut.width, lut.height, 4, int(bits), image.data()};
    png.linear_data = true;  // roughness data, not sRGB colour
    write_png(atomic.temp_path(), png, "microshadow", json);
    atomic.commit();
}

}  // namespace ms::lutfmt
