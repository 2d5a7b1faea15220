// Little-endian byte assembly for the binary LUT formats (KTX2, DDS), and an atomic whole-file write.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ms::lutfmt {

struct ByteWriter {
    std::vector<std::uint8_t> bytes;
    void u8(std::uint32_t v) { bytes.push_back(std::uint8_t(v)); }
    void u16(std::uint32_t v) { u8(v), u8(v >> 8); }
    void u32(std::uint32_t v) { u16(v), u16(v >> 16); }
    void u64(std::uint64_t v) { u32(std::uint32_t(v)), u32(std::uint32_t(v >> 32)); }
    void raw(const void* p, std::size_t n) {
        const auto* b = static_cast<const std::uint8_t*>(p);
        bytes.insert(bytes.end(), b, b + n);
    }
    void pad_to(std::size_t alignment) {
        while (bytes.size() % alignment) bytes.push_back(0);
    }
    // Overwrites a little-endian value written earlier (offsets known only later).
    void patch_u32(std::size_t at, std::uint32_t v) {
        for (int b = 0; b < 4; ++b) bytes.at(at + b) = std::uint8_t(v >> (8 * b));
    }
    void patch_u64(std::size_t at, std::uint64_t v) {
        patch_u32(at, std::uint32_t(v)), patch_u32(at + 4, std::uint32_t(v >> 32));
    }
    std::size_t size() const { return bytes.size(); }
};

// Writes `bytes` to `path` atomically (io/atomic_file.hpp). Throws std::runtime_error naming the file.
void write_file_atomically(const std::string& path, const std::vector<std::uint8_t>& bytes);
void write_text_atomically(const std::string& path, const std::string& text);

}  // namespace ms::lutfmt
