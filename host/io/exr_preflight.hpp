// A structural check of an OpenEXR file's headers before OpenEXR opens it.
//
// Why: the OpenEXR 3.1 that Debian ships allocates whatever a header declares before it can know the
// file is too short to hold it. An attribute's 32-bit size is allocated as one buffer (an unknown
// attribute type: Imf::OpaqueAttribute; a string: its length), and the chunk offset table is sized
// from the data window (or a multi-part file's chunkCount). fuzz_lut_file found a 4 KB file that made
// `Imf::InputFile` ask for 1.7 GB. Every LUT, scene image and environment the project reads is a file
// on disk whose size is known, so anything a header claims to hold must fit in the bytes that follow
// it: that is what this check proves, without allocating more than the file's own size.
//
// The layout checked (OpenEXR's file layout document, "Header" and "Offset Tables"):
//   magic 20000630 (4 bytes LE), version (4 bytes: low byte 2; flag bits 0x200 single-part tiled,
//   0x400 long names, 0x800 non-image (deep) parts, 0x1000 multi-part);
//   a header = attributes { name '\0', type name '\0', int32 size, size bytes of value } ending with an
//   empty name (one 0 byte); a multi-part file has several headers ending with an empty header;
//   then, per part, an offset table of one uint64 per chunk, then the chunks (each at least a 4-byte
//   part number (multi-part), a 4-byte coordinate and a 4-byte size, or a tile's 16-byte prefix).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace ms::exr {

// A file that cannot be an OpenEXR file of this size: the message names the file, the part and the
// attribute ("PATH: part 0: attribute 'x' claims 1700986880 bytes but 3918 remain in the file").
class PreflightError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct PartSummary {
    std::string name;                // the "name" attribute (multi-part files), else ""
    std::string type;                // "scanlineimage", "tiledimage", "deepscanline", "deeptile"
    std::int64_t width = 0, height = 0;  // of the data window
    std::uint32_t channels = 0;
    int compression = 0;             // OpenEXR's Compression enum value (0 none ... 9 DWAB)
    std::uint64_t chunks = 0;        // offset-table entries the part needs (level 0 of a tiled part)
    std::int64_t tile_width = 0, tile_height = 0;  // tiled parts only
    int lines_per_chunk = 1;         // scan lines per chunk of its compression (scan-line parts)
};

struct FileSummary {
    std::uint64_t file_bytes = 0;
    bool multi_part = false;
    std::vector<PartSummary> parts;
};

// Reads at most the file's headers (bounded by its size) and checks that every attribute, every
// offset table and the smallest possible chunks fit in the file. Throws PreflightError (a malformed or
// truncated header, a claim the file cannot hold) or std::runtime_error (cannot open or read the file).
FileSummary preflight(const std::string& path);

// Images (scenes, environments) are decoded whole: 2^28 pixels a part (16384 x 16384) bounds what a
// file can make a reader allocate, whatever its compression ratio.
inline constexpr std::uint64_t kMaxImagePixels = std::uint64_t(1) << 28;
// OpenEXR also sizes one chunk's decompression buffer, width x lines per chunk x channels x 4 bytes,
// before it reads a byte of pixels (fuzz_repr_file: 1.6 GB for a 2^22-wide, 4-line image): 256 MiB.
inline constexpr std::uint64_t kMaxChunkBufferBytes = std::uint64_t(256) << 20;

// preflight(path), then every part's data window (and tile) checked against max_pixels, and its chunk
// buffer against kMaxChunkBufferBytes. Throws PreflightError naming the part and its size.
FileSummary preflight_image(const std::string& path, std::uint64_t max_pixels = kMaxImagePixels);

}  // namespace ms::exr
