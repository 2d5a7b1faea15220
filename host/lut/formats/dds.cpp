#include "lut/formats/dds.hpp"

#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

std::uint32_t dxgi_format(PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return kDxgiR32G32B32A32Float;
        case PixelEncoding::float16: return kDxgiR16G16B16A16Float;
        case PixelEncoding::unorm8: return kDxgiR8G8B8A8Unorm;
        case PixelEncoding::unorm16: return kDxgiR16G16B16A16Unorm;
    }
    return 0;
}

std::uint32_t dxgi_format_rg(PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return kDxgiR32G32Float;
        case PixelEncoding::float16: return kDxgiR16G16Float;
        case PixelEncoding::unorm8: return kDxgiR8G8Unorm;
        case PixelEncoding::unorm16: return kDxgiR16G16Unorm;
    }
    return 0;
}

TextureData dds_lut_texture(const LutFile& lut, PixelEncoding encoding) {
    check_lut_shape(lut);
    const bool volume = lut.n_dot_v().count > 1;
    TextureData t;
    t.metadata = format_metadata(lut, encoding, volume ? "dds-volume" : "dds-2d", true);
    t.width = lut.visibility().count;
    t.height = lut.n_dot_l().count;
    t.depth = lut.n_dot_v().count;
    t.channels = 4;
    t.levels = {rgba_padded(lut)};
    return t;
}

}  // namespace ms::lutfmt
