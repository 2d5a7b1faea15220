#include "lut/formats/texture_reader.hpp"


#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "io/bounded_json.hpp"
#include "io/input_file.hpp"
#include "io/input_guard.hpp"
#include "platform/files.hpp"
#include "lut/formats/dds.hpp"
#include "lut/formats/ktx2.hpp"

namespace ms::lutfmt {

namespace {

constexpr unsigned char kKtx2Identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
constexpr std::uint32_t kDdsMagicWord = 0x20534444u, kFourCcDx10 = 0x30315844u;
// A sidecar holds a few KiB of JSON; this bounds what a hostile one can make the reader parse.
constexpr std::uint64_t kMaxSidecarBytes = std::uint64_t(16) << 20;

bool starts_with(const std::string& path, const unsigned char* magic, std::size_t n) {
    platform::FileStatus st;
    if (platform::path_status(path, st) != 0 || st.kind != platform::FileKind::regular) return false;  // a FIFO would block open()
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    unsigned char head[16] = {};
    const bool ok = std::fread(head, 1, n, f) == n && std::memcmp(head, magic, n) == 0;
    std::fclose(f);
    return ok;
}

// Little-endian fields of a file held in memory; every read is bounds-checked, so a truncated or
// lying file ends in a message, never a read past the buffer.
struct Bytes {
    const std::string& b;
    void need(std::uint64_t at, std::uint64_t n, const char* what) const {
        if (at > b.size() || n > b.size() - at)
            throw std::runtime_error(std::string(what) + " (bytes " + std::to_string(at) + " to " + std::to_string(at + n) +
                                     ") lies beyond the end of the " + std::to_string(b.size()) + "-byte file");
    }
    std::uint32_t u32(std::uint64_t at) const {
        need(at, 4, "a header field");
        const auto* p = reinterpret_cast<const unsigned char*>(b.data() + at);
        return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
    }
    std::uint64_t u64(std::uint64_t at) const { return u32(at) | std::uint64_t(u32(at + 4)) << 32; }
};

// `count` stored components at `at` in `encoding`, as floats (unorm q -> q / (2^n - 1)), appended to `out`.
void decode_components(const std::string& b, std::uint64_t at, std::uint64_t count, PixelEncoding encoding, std::vector<float>& out) {
    const auto* p = reinterpret_cast<const unsigned char*>(b.data() + at);
    out.reserve(out.size() + count);
    for (std::uint64_t i = 0; i < count; ++i) {
        switch (encoding) {
            case PixelEncoding::float32: {
                const std::uint32_t x = std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
                float f;
                std::memcpy(&f, &x, 4);
                out.push_back(f);
                p += 4;
                break;
            }
            case PixelEncoding::float16:
                out.push_back(half_to_float(std::uint16_t(p[0] | p[1] << 8)));
                p += 2;
                break;
            case PixelEncoding::unorm8:
                out.push_back(float(double(p[0]) / 255.0));
                p += 1;
                break;
            case PixelEncoding::unorm16:
                out.push_back(float(double(p[0] | p[1] << 8) / 65535.0));
                p += 2;
                break;
        }
    }
}

std::uint64_t level_texels(const TextureData& t, std::uint32_t p) {
    return std::uint64_t(level_size(t.width, p)) * level_size(t.height, p) * level_size(t.depth, p);
}

// Checks the base level's size against the caller's limit, and the level count against the sizes.
void check_dimensions(const TextureData& t, std::uint32_t levels, std::uint64_t max_texels) {
    if (t.width == 0 || t.height == 0 || t.depth == 0) throw std::runtime_error("width, height and depth must be > 0");
    const std::uint64_t texels = std::uint64_t(t.width) * t.height * t.depth * t.faces;
    if (texels > max_texels)
        throw std::runtime_error(std::to_string(t.width) + " x " + std::to_string(t.height) + " x " + std::to_string(t.depth) +
                                 (t.faces == 6 ? " x 6 faces" : "") + " texels is more than the limit of " + std::to_string(max_texels));
    std::uint32_t largest = std::max({t.width, t.height, t.depth}), max_levels = 1;
    while ((largest >> max_levels) > 0) ++max_levels;
    if (levels < 1 || levels > max_levels)
        throw std::runtime_error(std::to_string(levels) + " mip levels for this size (1 to " + std::to_string(max_levels) + ")");
    if (t.faces == 6 && (t.width != t.height || t.depth != 1)) throw std::runtime_error("a cubemap's faces must be square and 2D");
}

nlohmann::json parse_metadata(const std::string& text, const std::string& where) {
    const nlohmann::json j = parse_bounded_json(text, where);
    if (!j.is_object()) throw std::runtime_error(where + " is not a JSON object");
    return j;
}

// The KTX2 key/value data: the "microshadow" entry's JSON, or null.
nlohmann::json ktx2_metadata(const std::string& b) {
    const Bytes r{b};
    const std::uint64_t kvd_offset = r.u32(56), kvd_length = r.u32(60);
    r.need(kvd_offset, kvd_length, "the key/value data");
    for (std::uint64_t at = kvd_offset; at + 4 <= kvd_offset + kvd_length;) {
        const std::uint64_t n = r.u32(at);
        if (n > kvd_offset + kvd_length - at - 4) throw std::runtime_error("a key/value entry runs past the key/value data");
        const std::string entry = b.substr(std::size_t(at + 4), std::size_t(n));
        const std::size_t nul = entry.find('\0');
        if (nul != std::string::npos && entry.compare(0, nul, "microshadow") == 0) {
            std::string value = entry.substr(nul + 1);
            if (!value.empty() && value.back() == '\0') value.pop_back();
            return parse_metadata(value, "the \"microshadow\" key/value entry");
        }
        at += 4 + (n + 3) / 4 * 4;  // entries are padded to 4 bytes
    }
    return nullptr;
}

// Every region the KTX2 header claims, against the bytes (the KTX 2.0 "File Structure"): the DFD right
// after the level index and exactly the one this tool writes for the format, the key/value data right
// after it, no supercompression global data, and each level inside the file, after the key/value data
// and apart from every other level. A level offset pointing into the key/value data read the metadata's
// bytes as texels.
void check_ktx2_regions(const Bytes& r, PixelEncoding encoding, std::uint32_t levels) {
    const std::uint64_t index_end = 80 + 24 * std::uint64_t(levels);
    r.need(0, index_end, "the level index");
    const std::uint64_t dfd_offset = r.u32(48), dfd_length = r.u32(52), kvd_offset = r.u32(56), kvd_length = r.u32(60);
    const std::uint64_t sgd_offset = r.u64(64), sgd_length = r.u64(72);
    if (dfd_offset != index_end)
        throw std::runtime_error("dfdByteOffset " + std::to_string(dfd_offset) + ": the data format descriptor follows the level index, at byte " +
                                 std::to_string(index_end));
    const std::vector<std::uint8_t> dfd = ktx2_basic_dfd(encoding, 4);
    if (dfd_length != dfd.size())
        throw std::runtime_error("dfdByteLength " + std::to_string(dfd_length) + ": the " + to_string(encoding) +
                                 " RGBA descriptor is " + std::to_string(dfd.size()) + " bytes");
    r.need(dfd_offset, dfd_length, "the data format descriptor");
    if (std::memcmp(r.b.data() + dfd_offset, dfd.data(), dfd.size()) != 0)
        throw std::runtime_error("the data format descriptor does not describe vkFormat " + std::to_string(r.u32(12)) +
                                 " (its channels, bit widths or total size disagree with the header)");
    const std::uint64_t dfd_end = dfd_offset + dfd_length;
    if (kvd_length > 0 && kvd_offset != dfd_end)
        throw std::runtime_error("kvdByteOffset " + std::to_string(kvd_offset) + ": the key/value data follow the descriptor, at byte " +
                                 std::to_string(dfd_end));
    if (kvd_length == 0 && kvd_offset != 0 && kvd_offset != dfd_end)
        throw std::runtime_error("kvdByteOffset " + std::to_string(kvd_offset) + " with no key/value data");
    r.need(kvd_offset, kvd_length, "the key/value data");
    if (sgd_offset != 0 || sgd_length != 0)
        throw std::runtime_error("supercompression global data (sgdByteOffset " + std::to_string(sgd_offset) + ", sgdByteLength " +
                                 std::to_string(sgd_length) + ") in a file that is not supercompressed");
    const std::uint64_t data_start = std::max(dfd_end, kvd_offset + kvd_length);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> spans;
    for (std::uint32_t p = 0; p < levels; ++p) {
        const std::uint64_t offset = r.u64(80 + 24 * std::uint64_t(p)), length = r.u64(88 + 24 * std::uint64_t(p));
        const std::uint64_t uncompressed = r.u64(96 + 24 * std::uint64_t(p));
        const std::string level = "level " + std::to_string(p);
        if (uncompressed != length)
            throw std::runtime_error(level + ": uncompressedByteLength " + std::to_string(uncompressed) + " differs from byteLength " +
                                     std::to_string(length) + " in a file that is not supercompressed");
        if (offset < data_start)
            throw std::runtime_error(level + " starts at byte " + std::to_string(offset) + ", inside the header, descriptor or key/value data (which end at byte " +
                                     std::to_string(data_start) + ")");
        r.need(offset, length, level.c_str());
        spans.emplace_back(offset, offset + length);
    }
    std::sort(spans.begin(), spans.end());
    for (std::size_t i = 1; i < spans.size(); ++i)
        if (spans[i].first < spans[i - 1].second) throw std::runtime_error("two mip levels overlap in the file");
}

std::string read_whole(const std::string& path, std::uint64_t max_texels) {
    // RGBA32F is 16 bytes a texel; a full mip chain adds at most a third (2D) or a seventh (3D).
    const std::uint64_t max_bytes = max_texels * 16 * 2 + (std::uint64_t(1) << 20);
    require_regular_file(path, "texture");
    note_input(path);
    return read_input_file(path, max_bytes, "texture file");
}

}  // namespace

bool has_ktx2_identifier(const std::string& path) { return starts_with(path, kKtx2Identifier, 12); }

bool has_dds_magic(const std::string& path) {
    const unsigned char magic[4] = {'D', 'D', 'S', ' '};
    return starts_with(path, magic, 4);
}

nlohmann::json read_ktx2_metadata(const std::string& path) {
    require_regular_file(path, "texture");
    const std::string b = read_input_file(path, std::uint64_t(1) << 32, "texture file");
    if (b.size() < 80 || std::memcmp(b.data(), kKtx2Identifier, 12) != 0) throw std::runtime_error("not a KTX2 file");
    return ktx2_metadata(b);
}

TextureFile read_ktx2_texture(const std::string& path, std::uint64_t max_texels) {
    const std::string b = read_whole(path, max_texels);
    const Bytes r{b};
    if (b.size() < 80 || std::memcmp(b.data(), kKtx2Identifier, 12) != 0) throw std::runtime_error("not a KTX2 file");
    TextureFile out;
    const std::uint32_t vk = r.u32(12), type_size = r.u32(16);
    bool known = false;
    for (PixelEncoding e : {PixelEncoding::float32, PixelEncoding::float16, PixelEncoding::unorm8, PixelEncoding::unorm16})
        if (vk_format(e) == vk) out.encoding = e, known = true;
    if (!known)
        throw std::runtime_error("vkFormat " + std::to_string(vk) + " is none of the RGBA formats this tool writes (109, 97, 37, 91)");
    if (type_size != bytes_per_component(out.encoding))
        throw std::runtime_error("typeSize " + std::to_string(type_size) + " does not match vkFormat " + std::to_string(vk));
    TextureData& t = out.texture;
    t.width = r.u32(20);
    t.height = r.u32(24);
    t.depth = std::max<std::uint32_t>(r.u32(28), 1);  // pixelDepth 0: a 2D texture
    const std::uint32_t layers = r.u32(32), levels = r.u32(40);
    t.faces = r.u32(36);
    if (layers != 0) throw std::runtime_error("an array texture (layerCount " + std::to_string(layers) + ")");
    if (t.faces != 1 && t.faces != 6) throw std::runtime_error("faceCount " + std::to_string(t.faces) + " (1 or 6)");
    if (r.u32(44) != 0) throw std::runtime_error("supercompressed (scheme " + std::to_string(r.u32(44)) + ")");
    check_dimensions(t, levels, max_texels);
    check_ktx2_regions(r, out.encoding, levels);
    t.channels = 4;
    t.metadata = ktx2_metadata(b);
    if (!t.metadata.is_object()) t.metadata = nlohmann::json::object();
    t.ktx2_orientation.clear();
    const std::uint64_t comp = bytes_per_component(out.encoding);
    t.levels.resize(levels);
    for (std::uint32_t p = 0; p < levels; ++p) {
        const std::uint64_t offset = r.u64(80 + 24 * std::uint64_t(p)), length = r.u64(88 + 24 * std::uint64_t(p));
        const std::uint64_t components = level_texels(t, p) * t.faces * 4;
        if (length != components * comp)
            throw std::runtime_error("level " + std::to_string(p) + " holds " + std::to_string(length) + " bytes, not the " +
                                     std::to_string(components * comp) + " of its texels");
        r.need(offset, length, ("level " + std::to_string(p)).c_str());
        decode_components(b, offset, components, out.encoding, t.levels[p]);
    }
    return out;
}

nlohmann::json read_dds_metadata(const std::string& path) {
    const std::string sidecar = path + ".json";
    // No sidecar: the caller says what that means for it. One that exists but cannot be read (a FIFO,
    // a directory, more than the limit) is refused with its reason, not taken for a missing one.
    platform::FileStatus st;
    if (platform::link_status(sidecar, st) != 0 && errno == ENOENT) return nullptr;
    require_regular_file(sidecar, "DDS metadata sidecar");
    note_input(sidecar);
    const std::string text = read_input_file(sidecar, kMaxSidecarBytes, "DDS metadata sidecar");
    return parse_metadata(text, "the metadata sidecar " + sidecar);
}

TextureFile read_dds_texture(const std::string& path, std::uint64_t max_texels) {
    const std::string b = read_whole(path, max_texels);
    const Bytes r{b};
    if (b.size() < 148 || r.u32(0) != kDdsMagicWord) throw std::runtime_error("not a DDS file with a DX10 header");
    if (r.u32(4) != 124 || r.u32(76) != 32) throw std::runtime_error("DDS_HEADER or DDS_PIXELFORMAT has the wrong size");
    if (!(r.u32(80) & 0x4u) || r.u32(84) != kFourCcDx10) throw std::runtime_error("no DX10 header (the only DDS this tool writes)");
    TextureFile out;
    const std::uint32_t dxgi = r.u32(128);
    bool known = false;
    for (PixelEncoding e : {PixelEncoding::float32, PixelEncoding::float16, PixelEncoding::unorm8, PixelEncoding::unorm16})
        if (dxgi_format(e) == dxgi) out.encoding = e, known = true;
    if (!known) throw std::runtime_error("DXGI format " + std::to_string(dxgi) + " is none of the RGBA formats this tool writes (2, 10, 28, 11)");
    constexpr std::uint32_t DDSCAPS2_CUBEMAP = 0x200, DDSCAPS2_VOLUME = 0x200000, MISC_TEXTURECUBE = 0x4;
    const std::uint32_t caps2 = r.u32(112), dimension = r.u32(132), misc = r.u32(136), array_size = r.u32(140);
    const bool volume = (caps2 & DDSCAPS2_VOLUME) != 0, cube = (misc & MISC_TEXTURECUBE) != 0;
    if (volume != (dimension == 4) || (dimension != 3 && dimension != 4))
        throw std::runtime_error("resourceDimension " + std::to_string(dimension) + " does not match the volume flag");
    if (array_size != 1) throw std::runtime_error("arraySize " + std::to_string(array_size) + " (an array texture)");
    if (cube != ((caps2 & DDSCAPS2_CUBEMAP) != 0)) throw std::runtime_error("the cubemap flags disagree");
    TextureData& t = out.texture;
    t.height = r.u32(12);
    t.width = r.u32(16);
    t.depth = volume ? r.u32(24) : 1;
    t.faces = cube ? 6 : 1;
    const std::uint32_t levels = std::max<std::uint32_t>(r.u32(28), 1);
    check_dimensions(t, levels, max_texels);
    t.channels = 4;
    const std::uint64_t comp = bytes_per_component(out.encoding);
    // Face by face, each face with its whole mip chain (base level first): gathered into levels whose
    // faces follow one another, as TextureData holds them.
    std::uint64_t at = 148;
    t.levels.assign(levels, {});
    for (std::uint32_t f = 0; f < t.faces; ++f)
        for (std::uint32_t p = 0; p < levels; ++p) {
            const std::uint64_t components = level_texels(t, p) * 4;
            r.need(at, components * comp, ("face " + std::to_string(f) + " level " + std::to_string(p)).c_str());
            decode_components(b, at, components, out.encoding, t.levels[p]);
            at += components * comp;
        }
    if (at != b.size())
        throw std::runtime_error(std::to_string(b.size() - at) + " bytes after the texels (the header describes " + std::to_string(at) + ")");
    t.metadata = read_dds_metadata(path);
    if (t.metadata.is_null()) t.metadata = nlohmann::json::object();
    return out;
}

}  // namespace ms::lutfmt
