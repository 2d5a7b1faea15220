#include "lut/formats/ktx2.hpp"

#include "lut/formats/texture.hpp"

namespace ms::lutfmt {

std::uint32_t vk_format(PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return kVkR32G32B32A32Sfloat;
        case PixelEncoding::float16: return kVkR16G16B16A16Sfloat;
        case PixelEncoding::unorm8: return kVkR8G8B8A8Unorm;
        case PixelEncoding::unorm16: return kVkR16G16B16A16Unorm;
    }
    return 0;
}

std::uint32_t vk_format_rg(PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return kVkR32G32Sfloat;
        case PixelEncoding::float16: return kVkR16G16Sfloat;
        case PixelEncoding::unorm8: return kVkR8G8Unorm;
        case PixelEncoding::unorm16: return kVkR16G16Unorm;
    }
    return 0;
}

TextureData ktx2_lut_texture(const LutFile& lut, PixelEncoding encoding) {
    check_lut_shape(lut);
    const bool three_d = lut.n_dot_v().count > 1;
    TextureData t;
    t.metadata = format_metadata(lut, encoding, three_d ? "ktx2-3d" : "ktx2-2d", true);
    t.metadata["ktx2_orientation"] = three_d ? "rdi" : "rd";
    t.ktx2_orientation = three_d ? "rdi" : "rd";
    t.width = lut.visibility().count;
    t.height = lut.n_dot_l().count;
    t.depth = three_d ? lut.n_dot_v().count : 1;
    t.channels = 4;
    t.levels = {rgba_padded(lut)};
    return t;
}

}  // namespace ms::lutfmt
