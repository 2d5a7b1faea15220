#include "lut/formats/texture.hpp"

#include <algorithm>
#include <map>
#include <numeric>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "lut/formats/binary_writer.hpp"
#include "lut/formats/dds.hpp"
#include "lut/formats/ktx2.hpp"
#include "lut/formats/texture_writer.hpp"

namespace ms::lutfmt {

namespace {

}  // namespace

std::vector<std::uint8_t> ktx2_basic_dfd(PixelEncoding e, std::uint32_t components) {
    const std::uint32_t comp_bytes = bytes_per_component(e), bits = comp_bytes * 8;
    const bool is_float = e == PixelEncoding::float32 || e == PixelEncoding::float16;
    const std::uint32_t block_size = 24 + 16 * components;
    ByteWriter w;
    w.u32(4 + block_size);                 // dfdTotalSize (includes itself)
    w.u32(0u | (0u << 17));                // vendorId KHR (17 bits), descriptorType BASICFORMAT (15 bits)
    w.u32(2u | (block_size << 16));        // versionNumber 1.3 = 2, descriptorBlockSize
    w.u32(1u | (1u << 8) | (1u << 16) | (0u << 24));  // model RGBSDA, primaries BT709, transfer LINEAR, flags STRAIGHT
    w.u32(0);                              // texelBlockDimension0..3: value - 1, a 1x1x1x1 block
    w.u32(components * comp_bytes);        // bytesPlane0 (bytes per texel), bytesPlane1..3 = 0
    w.u32(0);                              // bytesPlane4..7
    const std::uint32_t channel_ids[4] = {0, 1, 2, 15};  // KHR_DF_CHANNEL_RGBSDA_RED, GREEN, BLUE, ALPHA
    // Qualifier bits of channelType: LINEAR 0x10, EXPONENT 0x20, SIGNED 0x40, FLOAT 0x80. LINEAR only
    // matters for alpha under a non-linear transfer function; ours is LINEAR already, so it stays clear.
    const std::uint32_t qualifiers = is_float ? 0x80u | 0x40u : 0u;
    for (std::uint32_t c = 0; c < components; ++c) {
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

namespace {

std::size_t level_texels(const TextureData& t, std::size_t p) {
    const auto q = std::uint32_t(p);
    return std::size_t(level_size(t.width, q)) * level_size(t.height, q) * level_size(t.depth, q) * t.faces;
}

}  // namespace

void check_texture(const TextureData& t) {
    if (t.width == 0 || t.height == 0 || t.depth == 0) throw std::invalid_argument("texture: width, height and depth must be > 0");
    if (t.faces != 1 && t.faces != 6) throw std::invalid_argument("texture: faces must be 1 or 6");
    if (t.faces == 6 && (t.width != t.height || t.depth != 1))
        throw std::invalid_argument("texture: a cubemap's faces must be square and 2D");
    if (t.channels < 1 || t.channels > 4) throw std::invalid_argument("texture: 1 to 4 channels");
    if (t.alpha && t.channels != 3) throw std::invalid_argument("texture: an alpha fill needs 3 data channels");
    if (t.stored_components != 4 && !(t.stored_components == 2 && t.channels == 2))
        throw std::invalid_argument("texture: stored components are 4 (RGBA) or 2 (RG, for 2 channels)");
    if (t.levels.empty()) throw std::invalid_argument("texture: no levels");
    const std::uint32_t largest = std::max({t.width, t.height, t.depth});
    std::uint32_t max_levels = 1;
    while ((largest >> max_levels) > 0) ++max_levels;
    if (t.levels.size() > max_levels)
        throw std::invalid_argument("texture: " + std::to_string(t.levels.size()) + " levels, at most " + std::to_string(max_levels));
    for (std::size_t p = 0; p < t.levels.size(); ++p)
        if (t.levels[p].size() != level_texels(t, p) * t.channels)
            throw std::invalid_argument("texture: level " + std::to_string(p) + " has " + std::to_string(t.levels[p].size()) +
                                        " floats, expected " + std::to_string(level_texels(t, p) * t.channels));
}

std::vector<float> rgba_level(const TextureData& t, std::size_t p) {
    if (t.stored_components == 2) return t.levels.at(p);  // RG: stored as given
    const std::size_t n = level_texels(t, p), nc = t.channels;
    const std::vector<float>& in = t.levels.at(p);
    std::vector<float> out(n * 4);
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t c = 0; c < 4; ++c) out[i * 4 + c] = in[i * nc + std::min(c, nc - 1)];
        if (t.alpha) out[i * 4 + 3] = *t.alpha;
    }
    return out;
}

std::vector<std::uint8_t> encode_ktx2_texture(const TextureData& t, PixelEncoding encoding) {
    check_texture(t);
    const bool three_d = t.depth > 1;
    const std::uint32_t comp_bytes = bytes_per_component(encoding), texel_bytes = t.stored_components * comp_bytes;
    const std::uint32_t levels = std::uint32_t(t.levels.size());

    ByteWriter w;
    const std::uint8_t identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    w.raw(identifier, 12);
    w.u32(t.stored_components == 2 ? vk_format_rg(encoding) : vk_format(encoding));
    w.u32(comp_bytes);  // typeSize: size of the data type the texels are made of (for byte swapping)
    w.u32(t.width);
    w.u32(t.height);
    w.u32(three_d ? t.depth : 0);
    w.u32(0);        // layerCount: not an array texture
    w.u32(t.faces);  // faceCount: 6 for a cubemap
    w.u32(levels);   // levelCount: the levels given (1: the texture must not be minified, e.g. a LUT)
    w.u32(0);        // supercompressionScheme: none
    const std::size_t index_at = w.size();
    w.u32(0), w.u32(0), w.u32(0), w.u32(0);  // dfdByteOffset/Length, kvdByteOffset/Length: patched below
    w.u64(0), w.u64(0);                      // sgdByteOffset/Length: no supercompression global data
    const std::size_t level_index_at = w.size();
    for (std::uint32_t p = 0; p < levels; ++p) w.u64(0), w.u64(0), w.u64(0);  // base level first: patched below

    const std::size_t dfd_at = w.size();
    const std::vector<std::uint8_t> dfd = ktx2_basic_dfd(encoding, t.stored_components);
    w.raw(dfd.data(), dfd.size());

    // Key/value data, sorted by key as the specification requires (std::map orders bytewise).
    std::map<std::string, std::string> kv;
    kv["KTXorientation"] = !t.ktx2_orientation.empty() ? t.ktx2_orientation : three_d ? "rdi" : "rd";
    kv["KTXwriter"] = std::string("microshadow ") + MICROSHADOW_VERSION;
    kv["microshadow"] = t.metadata.dump();
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

    // Mip level array: smallest level first, each at a multiple of lcm(texel block size, 4) (mipPadding);
    // within a level the faces one after the other.
    for (std::uint32_t q = levels; q-- > 0;) {
        w.pad_to(std::lcm<std::size_t>(texel_bytes, 4));
        const std::size_t level_at = w.size();
        append_encoded(w.bytes, rgba_level(t, q), encoding);
        const std::size_t level_length = w.size() - level_at;
        w.patch_u64(level_index_at + 24 * q + 0, level_at);
        w.patch_u64(level_index_at + 24 * q + 8, level_length);
        w.patch_u64(level_index_at + 24 * q + 16, level_length);  // uncompressedByteLength: no supercompression
    }

    w.patch_u32(index_at + 0, std::uint32_t(dfd_at));
    w.patch_u32(index_at + 4, std::uint32_t(dfd.size()));
    w.patch_u32(index_at + 8, std::uint32_t(kvd_at));
    w.patch_u32(index_at + 12, std::uint32_t(kvd_length));
    return std::move(w.bytes);
}

void write_ktx2_texture(const std::string& path, const TextureData& t, PixelEncoding encoding) {
    write_texture(path, TextureFormat::ktx2, t, encoding);
}

std::vector<std::uint8_t> encode_dds_texture(const TextureData& t, PixelEncoding encoding) {
    check_texture(t);
    const bool volume = t.depth > 1, cube = t.faces == 6, mipped = t.levels.size() > 1;
    const std::uint32_t texel_bytes = t.stored_components * bytes_per_component(encoding);
    const std::uint32_t levels = std::uint32_t(t.levels.size());

    constexpr std::uint32_t DDSD_CAPS = 0x1, DDSD_HEIGHT = 0x2, DDSD_WIDTH = 0x4, DDSD_PITCH = 0x8,
                            DDSD_PIXELFORMAT = 0x1000, DDSD_MIPMAPCOUNT = 0x20000, DDSD_DEPTH = 0x800000;
    constexpr std::uint32_t DDPF_FOURCC = 0x4, DDSCAPS_COMPLEX = 0x8, DDSCAPS_TEXTURE = 0x1000, DDSCAPS_MIPMAP = 0x400000,
                            DDSCAPS2_CUBEMAP = 0x200, DDSCAPS2_CUBEMAP_ALLFACES = 0xFC00, DDSCAPS2_VOLUME = 0x200000;
    constexpr std::uint32_t D3D10_RESOURCE_MISC_TEXTURECUBE = 0x4;
    ByteWriter w;
    w.u32(0x20534444u);  // "DDS "
    w.u32(124);
    w.u32(DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PITCH | DDSD_PIXELFORMAT | DDSD_MIPMAPCOUNT | (volume ? DDSD_DEPTH : 0));
    w.u32(t.height);
    w.u32(t.width);
    w.u32(t.width * texel_bytes);  // pitch of an uncompressed row (base level)
    w.u32(volume ? t.depth : 0);
    w.u32(levels);                 // dwMipMapCount
    for (int i = 0; i < 11; ++i) w.u32(0);
    w.u32(32);                     // DDS_PIXELFORMAT.dwSize
    w.u32(DDPF_FOURCC);
    w.u32(0x30315844u);            // "DX10": the format is in the DXT10 header
    for (int i = 0; i < 5; ++i) w.u32(0);  // RGB bit count and masks: unused with DX10
    // DDSCAPS_COMPLEX on a volume, a cubemap or a mip chain (Microsoft's examples set it, and readers
    // such as OpenImageIO reject a volume without it); DDSCAPS_MIPMAP with mips.
    w.u32(DDSCAPS_TEXTURE | (volume || cube || mipped ? DDSCAPS_COMPLEX : 0) | (mipped ? DDSCAPS_MIPMAP : 0));
    w.u32((volume ? DDSCAPS2_VOLUME : 0) | (cube ? DDSCAPS2_CUBEMAP | DDSCAPS2_CUBEMAP_ALLFACES : 0));
    w.u32(0), w.u32(0), w.u32(0);
    w.u32(t.stored_components == 2 ? dxgi_format_rg(encoding) : dxgi_format(encoding));
    w.u32(volume ? 4 : 3);         // D3D10_RESOURCE_DIMENSION_TEXTURE3D / TEXTURE2D (a cubemap is 2D)
    w.u32(cube ? D3D10_RESOURCE_MISC_TEXTURECUBE : 0);  // miscFlag
    w.u32(1);                      // arraySize: 1 (a 3D texture; one cube for a cubemap)
    w.u32(4);                      // miscFlags2: DDS_ALPHA_MODE_CUSTOM
    // Face by face (array slice by slice), each with its whole mip chain, base level first.
    std::vector<std::vector<float>> rgba(levels);
    for (std::uint32_t p = 0; p < levels; ++p) rgba[p] = rgba_level(t, p);
    for (std::uint32_t f = 0; f < t.faces; ++f)
        for (std::uint32_t p = 0; p < levels; ++p) {
            const std::size_t face_floats = rgba[p].size() / t.faces;
            const std::vector<float> face(rgba[p].begin() + std::ptrdiff_t(f * face_floats),
                                          rgba[p].begin() + std::ptrdiff_t((f + 1) * face_floats));
            append_encoded(w.bytes, face, encoding);
        }
    return std::move(w.bytes);
}

nlohmann::json dds_sidecar_json(const TextureData& t, PixelEncoding encoding) {
    nlohmann::json meta = t.metadata;
    meta["dds_dxgi_format"] = t.stored_components == 2 ? dxgi_format_rg(encoding) : dxgi_format(encoding);
    return meta;
}

void write_dds_texture(const std::string& path, const TextureData& t, PixelEncoding encoding) {
    // The texels and their sidecar are one set (texture_writer.hpp): a failure between the two renames
    // (a full disk) must not leave a new sidecar describing old texels, which every reader would accept.
    write_texture(path, TextureFormat::dds, t, encoding);
}

}  // namespace ms::lutfmt
