#include "lut/formats/dds.hpp"

#include "lut/formats/binary_writer.hpp"

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

void write_dds(const std::string& path, const LutFile& lut, PixelEncoding encoding) {
    check_lut_shape(lut);
    const bool volume = lut.n_dot_v().count > 1;
    nlohmann::json meta = format_metadata(lut, encoding, volume ? "dds-volume" : "dds-2d", true);
    const std::uint32_t texel_bytes = 4 * bytes_per_component(encoding);
    const std::uint32_t width = lut.visibility().count, height = lut.n_dot_l().count, depth = lut.n_dot_v().count;

    constexpr std::uint32_t DDSD_CAPS = 0x1, DDSD_HEIGHT = 0x2, DDSD_WIDTH = 0x4, DDSD_PITCH = 0x8,
                            DDSD_PIXELFORMAT = 0x1000, DDSD_MIPMAPCOUNT = 0x20000, DDSD_DEPTH = 0x800000;
    constexpr std::uint32_t DDPF_FOURCC = 0x4, DDSCAPS_COMPLEX = 0x8, DDSCAPS_TEXTURE = 0x1000, DDSCAPS2_VOLUME = 0x200000;
    ByteWriter w;
    w.u32(0x20534444u);  // "DDS "
    w.u32(124);
    w.u32(DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PITCH | DDSD_PIXELFORMAT | DDSD_MIPMAPCOUNT | (volume ? DDSD_DEPTH : 0));
    w.u32(height);
    w.u32(width);
    w.u32(width * texel_bytes);  // pitch of an uncompressed row
    w.u32(volume ? depth : 0);
    w.u32(1);                    // one mip level
    for (int i = 0; i < 11; ++i) w.u32(0);
    w.u32(32);                   // DDS_PIXELFORMAT.dwSize
    w.u32(DDPF_FOURCC);
    w.u32(0x30315844u);          // "DX10": the format is in the DXT10 header
    for (int i = 0; i < 5; ++i) w.u32(0);  // RGB bit count and masks: unused with DX10
    // DDSCAPS_COMPLEX on a volume: Microsoft's volume texture example sets it, and readers (OpenImageIO)
    // reject a volume without it.
    w.u32(DDSCAPS_TEXTURE | (volume ? DDSCAPS_COMPLEX : 0));
    w.u32(volume ? DDSCAPS2_VOLUME : 0);
    w.u32(0), w.u32(0), w.u32(0);
    w.u32(dxgi_format(encoding));
    w.u32(volume ? 4 : 3);       // D3D10_RESOURCE_DIMENSION_TEXTURE3D / TEXTURE2D
    w.u32(0);                    // miscFlag
    w.u32(1);                    // arraySize (must be 1 for a 3D texture)
    w.u32(4);                    // miscFlags2: DDS_ALPHA_MODE_CUSTOM
    append_encoded(w.bytes, rgba_padded(lut), encoding);

    meta["dds_dxgi_format"] = dxgi_format(encoding);
    write_text_atomically(path + ".json", meta.dump(2) + "\n");
    write_file_atomically(path, w.bytes);
}

}  // namespace ms::lutfmt
