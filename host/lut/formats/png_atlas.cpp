#include "lut/formats/png_atlas.hpp"

#include <stdexcept>

namespace ms::lutfmt {

TextureData png_lut_texture(const LutFile& lut, PixelEncoding encoding) {
    check_lut_shape(lut);
    if (encoding != PixelEncoding::unorm8 && encoding != PixelEncoding::unorm16)
        throw std::invalid_argument("a PNG LUT stores unorm8 or unorm16, not " + to_string(encoding));
    // The atlas: NdotV slices one under the other, as the EXR (width x height rows, height = NdotL x NdotV).
    TextureData t;
    t.width = lut.width;
    t.height = lut.height;
    t.channels = 4;
    t.levels = {rgba_padded(lut)};
    t.metadata = format_metadata(lut, encoding, "png-atlas", true);
    return t;
}

}  // namespace ms::lutfmt
