#include "lut/formats/ktx2.hpp"

#include <algorithm>
#include <cstring>
#include <map>
#include <numeric>
#include <stdexcept>

#include "lut/formats/binary_writer.hpp"

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

namespace {

// The basic DFD (with its leading dfdTotalSize) of an RGBA format with 4 equal components.
std::vector<std::uint8_t> rgba_dfd(PixelEncoding e) {
    const std::uint32_t comp_bytes = bytes_per_component(e), bits = comp_bytes * 8;
    const bool is_float = e == PixelEncoding::float32 || e == PixelEncoding::float16;
    const std::uint32_t block_size = 24 + 16 * 4;
    ByteWriter w;
    w.u32(4 + block_size);                 // dfdTotalSize (includes itself)
    w.u32(0u | (0u << 17));                // vendorId KHR (17 bits), descriptorType BASICFORMAT (15 bits)
    w.u32(2u | (block_size << 16));        // versionNumber 1.3 = 2, descriptorBlockSize
    w.u32(1u | (1u << 8) | (1u << 16) | (0u << 24));  // model RGBSDA, primaries BT709, transfer LINEAR, flags STRAIGHT
    w.u32(0);                              // texelBlockDimension0..3: value - 1, a 1x1x1x1 block
    w.u32(4 * comp_bytes);                 // bytesPlane0 (bytes per texel), bytesPlane1..3 = 0
    w.u32(0);                              // bytesPlane4..7
    const std::uint32_t channel_ids[4] = {0, 1, 2, 15};  // KHR_DF_CHANNEL_RGBSDA_RED, GREEN, BLUE, ALPHA
    // Qualifier bits of channelType: LINEAR 0x10, EXPONENT 0x20, SIGNED 0x40, FLOAT 0x80. LINEAR only
    // matters for alpha under a non-linear transfer function; ours is LINEAR already, so it stays clear.
    const std::uint32_t qualifiers = is_float ? 0x80u | 0x40u : 0u;
    for (std::uint32_t c = 0; c < 4; ++c) {
        w.u32((c * bits) | ((bits - 1) << 16) | ((channel_ids[c] | qualifiers) << 24));
        w.u32(0);  // samplePosition0..3: the sample sits at the block origin
        if (is_float) {
            // For float samples the bounds are float32 bit patterns: -1.0 and 1.0 mark the range the
            // "normalised" value maps from (the convention of the spec's float examples).
            w.u32(0xBF800000u);
            w.u32(0x3F800000u);
        } else {
            w.u32(0);
            w.u32(std::uint32_t((std::uint64_t(1) << bits) - 1));
        }
    }
    return w.bytes;
}

}  // namespace

void write_ktx2(const std::string& path, const LutFile& lut, PixelEncoding encoding) {
    check_lut_shape(lut);
    const bool three_d = lut.n_dot_v().count > 1;
    nlohmann::json meta = format_metadata(lut, encoding, three_d ? "ktx2-3d" : "ktx2-2d", true);
    meta["ktx2_orientation"] = three_d ? "rdi" : "rd";

    const std::uint32_t comp_bytes = bytes_per_component(encoding), texel_bytes = 4 * comp_bytes;
    const std::uint32_t width = lut.visibility().count, height = lut.n_dot_l().count,
                        depth = three_d ? lut.n_dot_v().count : 0;

    ByteWriter w;
    const std::uint8_t identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    w.raw(identifier, 12);
    w.u32(vk_format(encoding));
    w.u32(comp_bytes);  // typeSize: size of the data type the texels are made of (for byte swapping)
    w.u32(width);
    w.u32(height);
    w.u32(depth);
    w.u32(0);  // layerCount: not an array texture
    w.u32(1);  // faceCount
    w.u32(1);  // levelCount: one level, no mips (a LUT must not be minified)
    w.u32(0);  // supercompressionScheme: none
    const std::size_t index_at = w.size();
    w.u32(0), w.u32(0), w.u32(0), w.u32(0);  // dfdByteOffset/Length, kvdByteOffset/Length: patched below
    w.u64(0), w.u64(0);                      // sgdByteOffset/Length: no supercompression global data
    const std::size_t level_index_at = w.size();
    w.u64(0), w.u64(0), w.u64(0);            // level 0: patched below

    const std::size_t dfd_at = w.size();
    const std::vector<std::uint8_t> dfd = rgba_dfd(encoding);
    w.raw(dfd.data(), dfd.size());

    // Key/value data, sorted by key as the specification requires (std::map orders bytewise).
    std::map<std::string, std::string> kv;
    kv["KTXorientation"] = three_d ? "rdi" : "rd";
    kv["KTXwriter"] = std::string("microshadow ") + MICROSHADOW_VERSION;
    kv["microshadow"] = meta.dump();
    const std::size_t kvd_at = w.size();  // 4-aligned: the DFD is whole UInt32s
    for (const auto& [key, value] : kv) {
        // Key NUL value NUL: string values carry their terminating NUL, as KTX's own keys do.
        w.u32(std::uint32_t(key.size() + 1 + value.size() + 1));
        w.raw(key.data(), key.size());
        w.u8(0);
        w.raw(value.data(), value.size());
        w.u8(0);
        w.pad_to(4);  // valuePadding (counted in kvdByteLength)
    }
    const std::size_t kvd_length = w.size() - kvd_at;

    // Level data start at a multiple of lcm(texel block size, 4) (mipPadding).
    w.pad_to(std::lcm<std::size_t>(texel_bytes, 4));
    const std::size_t level_at = w.size();
    append_encoded(w.bytes, rgba_padded(lut), encoding);
    const std::size_t level_length = w.size() - level_at;

    w.patch_u32(index_at + 0, std::uint32_t(dfd_at));
    w.patch_u32(index_at + 4, std::uint32_t(dfd.size()));
    w.patch_u32(index_at + 8, std::uint32_t(kvd_at));
    w.patch_u32(index_at + 12, std::uint32_t(kvd_length));
    w.patch_u64(level_index_at + 0, level_at);
    w.patch_u64(level_index_at + 8, level_length);
    w.patch_u64(level_index_at + 16, level_length);  // uncompressedByteLength: no supercompression
    write_file_atomically(path, w.bytes);
}

}  // namespace ms::lutfmt
