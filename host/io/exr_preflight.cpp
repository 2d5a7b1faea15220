#include "io/exr_preflight.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>

#include "io/input_file.hpp"
#include "io/input_guard.hpp"

namespace ms::exr {
namespace {

constexpr std::uint32_t kMagic = 20000630;
constexpr std::uint32_t kTiledFlag = 0x200, kLongNamesFlag = 0x400, kNonImageFlag = 0x800, kMultiPartFlag = 0x1000;
// Headers are a few kilobytes; a LUT's "microshadow" attribute is the largest we write (~2 KB). The
// headers are read into memory only up to this much (or the file's size, if smaller).
constexpr std::uint64_t kMaxHeaderBytes = std::uint64_t(16) << 20;

// Scan lines per chunk of each compression (OpenEXR's Compression enum 0..9).
int lines_per_chunk(int compression) {
    switch (compression) {
        case 0: case 1: case 2: return 1;        // none, RLE, ZIPS
        case 3: case 5: return 16;               // ZIP, PXR24
        case 4: case 6: case 7: case 8: return 32;  // PIZ, B44, B44A, DWAA
        case 9: return 256;                      // DWAB
        default: return 0;
    }
}

// A little-endian reader over the bytes read from the file, that names what ran out.
class Cursor {
public:
    Cursor(const std::string& path, std::vector<unsigned char> bytes, std::uint64_t file_bytes)
        : path_(path), bytes_(std::move(bytes)), file_bytes_(file_bytes) {}

    std::uint64_t position() const { return pos_; }
    std::uint64_t remaining_in_file() const { return file_bytes_ - pos_; }
    [[noreturn]] void fail(const std::string& what) const {
        throw PreflightError(path_ + ": not a readable OpenEXR file: " + what + " (at byte " + std::to_string(pos_) + " of " +
                             std::to_string(file_bytes_) + ")");
    }
    void need(std::uint64_t n, const std::string& what) const {
        if (n > bytes_.size() - pos_) {
            if (n > remaining_in_file()) fail(what + " needs " + std::to_string(n) + " bytes but " + std::to_string(remaining_in_file()) + " remain in the file");
            fail(what + " lies beyond the first " + std::to_string(kMaxHeaderBytes) + " bytes, more header than any image has");
        }
    }
    std::uint8_t peek(const std::string& what) const {
        need(1, what);
        return bytes_[pos_];
    }
    std::uint8_t u8(const std::string& what) {
        need(1, what);
        return bytes_[pos_++];
    }
    std::uint32_t u32(const std::string& what) {
        need(4, what);
        std::uint32_t v = 0;
        for (int i = 3; i >= 0; --i) v = (v << 8) | bytes_[pos_ + std::size_t(i)];
        pos_ += 4;
        return v;
    }
    std::int32_t i32(const std::string& what) {
        const std::uint32_t u = u32(what);
        std::int32_t v;
        std::memcpy(&v, &u, sizeof v);
        return v;
    }
    // A NUL-terminated name of at most max_length characters ("" for the 0 byte that ends a list).
    std::string name(std::size_t max_length, const std::string& what) {
        std::string s;
        for (;;) {
            const std::uint8_t c = u8(what);
            if (c == 0) return s;
            if (s.size() == max_length) fail(what + " is longer than " + std::to_string(max_length) + " characters");
            s.push_back(char(c));
        }
    }
    std::string bytes(std::uint64_t n, const std::string& what) {
        need(n, what);
        std::string s(reinterpret_cast<const char*>(bytes_.data() + pos_), std::size_t(n));
        pos_ += n;
        return s;
    }
    void skip(std::uint64_t n, const std::string& what) { bytes(n, what); }

private:
    std::string path_;
    std::vector<unsigned char> bytes_;
    std::uint64_t file_bytes_;
    std::uint64_t pos_ = 0;
};

// OpenEXR reads a value of a type it knows by that type's layout, not by the declared size: a box2i
// declared 1 byte long is still read as 16, and the rest of the header is then parsed from the wrong
// place (fuzz_lut_file's second finding asked for 1.7 GB that way). So a known fixed-size type must
// declare its own size; -1 marks the types whose size varies and is checked by its layout below.
int natural_size(const std::string& type) {
    static const std::pair<const char*, int> sizes[] = {
        {"box2i", 16},   {"box2f", 16},   {"chromaticities", 32}, {"compression", 1}, {"double", 8},
        {"envmap", 1},   {"float", 4},    {"int", 4},             {"keycode", 28},    {"lineOrder", 1},
        {"m33f", 36},    {"m33d", 72},    {"m44f", 64},           {"m44d", 128},      {"rational", 8},
        {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8},             {"v2f", 8},         {"v2d", 16},
        {"v3i", 12},     {"v3f", 12},     {"v3d", 24},            {"deepImageState", 1},
        {"string", -1},  {"stringvector", -1}, {"floatvector", -1}, {"chlist", -1},  {"preview", -1},
    };
    for (const auto& [name, size] : sizes)
        if (type == name) return size;
    return -2;  // unknown to OpenEXR: read as an opaque block of the declared size
}

std::int32_t le_i32(const std::string& value, std::size_t offset) {
    std::uint32_t u = 0;
    for (int i = 3; i >= 0; --i) u = (u << 8) | std::uint8_t(value[offset + std::size_t(i)]);
    std::int32_t v;
    std::memcpy(&v, &u, sizeof v);
    return v;
}

// The channel count of a "chlist" value: entries of name '\0', int32 type, uint8 pLinear, 3 reserved
// bytes, int32 xSampling, int32 ySampling, ended by a 0 byte.
std::uint32_t count_channels(const std::string& value, const std::string& where) {
    std::uint32_t n = 0;
    std::size_t i = 0;
    for (;;) {
        if (i >= value.size()) throw PreflightError(where + ": the channel list is not terminated");
        if (value[i] == 0) {
            // OpenEXR reads entries up to the terminator and does not skip to the declared end: bytes
            // after it would be parsed as the next attribute.
            if (i + 1 != value.size()) throw PreflightError(where + ": the channel list ends before its declared size");
            return n;
        }
        const std::size_t end = value.find('\0', i);
        if (end == std::string::npos || end + 1 + 16 > value.size())
            throw PreflightError(where + ": channel entry " + std::to_string(n) + " is truncated");
        i = end + 1 + 16;
        ++n;
    }
}

// Declared size and layout agree for every type OpenEXR reads by its layout (natural_size), and the
// variable ones hold what their inner counts claim: a preview's w x h RGBA pixels, a string vector's
// lengths, a channel list's entries.
void check_layout(const std::string& attribute, const std::string& type, const std::string& value, const std::string& where) {
    const std::string what = where + ": attribute '" + attribute + "' (" + type + ") ";
    const int natural = natural_size(type);
    if (natural >= 0 && value.size() != std::size_t(natural))
        throw PreflightError(what + "declares " + std::to_string(value.size()) + " bytes, its type has " + std::to_string(natural));
    if (type == "preview") {
        if (value.size() < 8) throw PreflightError(what + "is shorter than its size fields");
        const std::uint64_t w = std::uint32_t(le_i32(value, 0)), h = std::uint32_t(le_i32(value, 4));
        if (8 + 4 * w * h != value.size())
            throw PreflightError(what + "claims " + std::to_string(w) + " x " + std::to_string(h) + " pixels in " +
                                 std::to_string(value.size()) + " bytes");
    } else if (type == "stringvector") {
        std::size_t i = 0;
        while (i < value.size()) {
            if (value.size() - i < 4) throw PreflightError(what + "ends inside a string length");
            const std::int32_t n = le_i32(value, i);
            if (n < 0 || std::size_t(n) > value.size() - i - 4)
                throw PreflightError(what + "holds a string of " + std::to_string(n) + " bytes beyond its size");
            i += 4 + std::size_t(n);
        }
    } else if (type == "floatvector") {
        if (value.size() % 4 != 0) throw PreflightError(what + "is not a whole number of floats");
    } else if (type == "chlist") {
        count_channels(value, where + ": attribute '" + attribute + "'");
    }
}

}  // namespace

FileSummary preflight(const std::string& path) {
    require_regular_file(path, "OpenEXR image");  // a FIFO would block the open below beyond the reach of signals
    note_input(path);
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw std::runtime_error(path + ": cannot open for reading");
    const std::streamoff end = in.tellg();
    if (end < 0) throw std::runtime_error(path + ": cannot read its size (not a regular file?)");
    FileSummary summary;
    summary.file_bytes = std::uint64_t(end);
    // Only the headers are needed: read up to kMaxHeaderBytes, never more than the file holds.
    const std::uint64_t take = std::min(summary.file_bytes, kMaxHeaderBytes);
    std::vector<unsigned char> head(static_cast<std::size_t>(take));
    in.seekg(0);
    if (take > 0 && !in.read(reinterpret_cast<char*>(head.data()), std::streamsize(take)))
        throw std::runtime_error(path + ": read failed");
    Cursor c(path, std::move(head), summary.file_bytes);

    if (c.u32("the magic number") != kMagic) c.fail("the magic number is not OpenEXR's");
    const std::uint32_t version = c.u32("the version field");
    if ((version & 0xff) != 2) c.fail("format version " + std::to_string(version & 0xff) + " (only 2 exists)");
    summary.multi_part = (version & kMultiPartFlag) != 0;
    const std::size_t max_name = (version & kLongNamesFlag) ? 255 : 31;

    for (std::size_t part = 0;; ++part) {
        const std::string where = path + ": part " + std::to_string(part);
        PartSummary p;
        p.type = summary.multi_part ? "" : ((version & kTiledFlag) ? "tiledimage" : "scanlineimage");
        bool have_window = false, have_channels = false, have_compression = false;
        std::int64_t tile_x = 0, tile_y = 0, chunk_count = -1;
        std::uint64_t attributes = 0;
        for (;;) {
            const std::string attribute = c.name(max_name, "an attribute name");
            if (attribute.empty()) break;
            if (++attributes > 100000) c.fail("more attributes than any header has");
            const std::string type = c.name(max_name, "the type of attribute '" + attribute + "'");
            const std::int32_t size = c.i32("the size of attribute '" + attribute + "'");
            if (size < 0) c.fail("attribute '" + attribute + "' has a negative size " + std::to_string(size));
            // The check this file exists for: a size is a claim on the bytes that follow.
            if (std::uint64_t(size) > c.remaining_in_file())
                c.fail("attribute '" + attribute + "' (" + type + ") claims " + std::to_string(size) + " bytes but " +
                       std::to_string(c.remaining_in_file()) + " remain in the file");
            const std::string value = c.bytes(std::uint64_t(size), "attribute '" + attribute + "'");
            check_layout(attribute, type, value, where);
            if (attribute == "dataWindow" && type == "box2i" && size == 16) {
                const std::int64_t x0 = le_i32(value, 0), y0 = le_i32(value, 4), x1 = le_i32(value, 8), y1 = le_i32(value, 12);
                p.width = x1 - x0 + 1;
                p.height = y1 - y0 + 1;
                if (p.width <= 0 || p.height <= 0) throw PreflightError(where + ": empty or inverted data window");
                have_window = true;
            } else if (attribute == "channels" && type == "chlist") {
                p.channels = count_channels(value, where);
                have_channels = true;
            } else if (attribute == "compression" && type == "compression" && size == 1) {
                p.compression = std::uint8_t(value[0]);
                if (lines_per_chunk(p.compression) == 0)
                    throw PreflightError(where + ": unknown compression " + std::to_string(p.compression));
                have_compression = true;
            } else if (attribute == "tiles" && type == "tiledesc" && size == 9) {
                tile_x = std::uint32_t(le_i32(value, 0));
                tile_y = std::uint32_t(le_i32(value, 4));
                if (tile_x <= 0 || tile_y <= 0) throw PreflightError(where + ": a tile size of 0");
            } else if (attribute == "chunkCount" && type == "int" && size == 4) {
                chunk_count = le_i32(value, 0);
                if (chunk_count < 0) throw PreflightError(where + ": negative chunkCount");
            } else if (attribute == "type" && type == "string") {
                p.type = value;
            } else if (attribute == "name" && type == "string") {
                p.name = value;
            }
        }
        if (!have_window) throw PreflightError(where + ": no dataWindow attribute");
        if (!have_channels) throw PreflightError(where + ": no channels attribute");
        if (!have_compression) throw PreflightError(where + ": no compression attribute");
        const bool tiled = p.type == "tiledimage" || p.type == "deeptile";
        if (tiled && tile_x == 0) throw PreflightError(where + ": a tiled part without a tiles attribute");
        // Level 0 alone needs this many chunks (mip and rip levels add more): a lower bound.
        const std::uint64_t w = std::uint64_t(p.width), h = std::uint64_t(p.height);
        p.chunks = tiled ? ((w + std::uint64_t(tile_x) - 1) / std::uint64_t(tile_x)) * ((h + std::uint64_t(tile_y) - 1) / std::uint64_t(tile_y))
                         : (h + std::uint64_t(lines_per_chunk(p.compression)) - 1) / std::uint64_t(lines_per_chunk(p.compression));
        p.tile_width = tile_x;
        p.tile_height = tile_y;
        p.lines_per_chunk = lines_per_chunk(p.compression);
        if (chunk_count >= 0) p.chunks = std::max<std::uint64_t>(p.chunks, std::uint64_t(chunk_count));
        if (!summary.multi_part && (version & kNonImageFlag) && p.type.rfind("deep", 0) != 0) p.type = "deepscanline";
        summary.parts.push_back(p);
        if (!summary.multi_part) break;
        // Multi-part: the headers end with an empty header, a lone 0 byte where a name would start.
        if (c.peek("the end of the header list") == 0) {
            c.u8("the end of the header list");
            break;
        }
        if (summary.parts.size() >= 1000) c.fail("more than 1000 parts");
    }

    // The offset tables (8 bytes per chunk) and the chunks themselves (at least 8 bytes each: a
    // coordinate and a data size, or more) must fit in what follows the headers. OpenEXR allocates
    // the tables before reading them.
    std::uint64_t chunks = 0;
    for (const auto& p : summary.parts) {
        chunks += p.chunks;
        if (chunks > c.remaining_in_file())
            throw PreflightError(path + ": not a readable OpenEXR file: " + (summary.multi_part ? "part '" + p.name + "'" : std::string("the image")) + " (" +
                                 std::to_string(p.width) + " x " + std::to_string(p.height) + ") needs at least " +
                                 std::to_string(chunks) + " chunks but the file has " + std::to_string(c.remaining_in_file()) +
                                 " bytes after its headers: truncated or forged");
    }
    if (chunks * 16 > c.remaining_in_file())
        throw PreflightError(path + ": not a readable OpenEXR file: " + std::to_string(chunks) + " chunks need at least " + std::to_string(chunks * 16) +
                             " bytes (offset table and chunk headers) but " + std::to_string(c.remaining_in_file()) +
                             " remain after the headers: truncated or forged");
    return summary;
}

FileSummary preflight_image(const std::string& path, std::uint64_t max_pixels) {
    FileSummary summary = preflight(path);
    for (std::size_t i = 0; i < summary.parts.size(); ++i) {
        const PartSummary& p = summary.parts[i];
        const std::uint64_t pixels = std::uint64_t(p.width) * std::uint64_t(p.height);
        const std::uint64_t tile = std::uint64_t(p.tile_width) * std::uint64_t(p.tile_height);
        if (pixels > max_pixels || tile > max_pixels)
            throw PreflightError(path + ": part " + std::to_string(i) + " (" + std::to_string(p.width) + " x " + std::to_string(p.height) +
                                 (tile ? ", tiles " + std::to_string(p.tile_width) + " x " + std::to_string(p.tile_height) : std::string()) +
                                 ") is more than the limit of " + std::to_string(max_pixels) + " pixels");
        // A chunk's buffer: a tile, or lines_per_chunk scan lines, of every channel at 4 bytes at most.
        const std::uint64_t chunk_pixels = tile ? tile : std::uint64_t(p.width) * std::uint64_t(p.lines_per_chunk);
        if (chunk_pixels * std::max<std::uint64_t>(p.channels, 1) * 4 > kMaxChunkBufferBytes)
            throw PreflightError(path + ": part " + std::to_string(i) + " (" + std::to_string(p.width) + " x " + std::to_string(p.height) + ", " +
                                 std::to_string(p.channels) + " channels) needs a chunk buffer of more than " +
                                 std::to_string(kMaxChunkBufferBytes >> 20) + " MiB");
    }
    return summary;
}

}  // namespace ms::exr
