// FNV-1a, the 64-bit digest the tool's caches, manifests and item stores record: not cryptographic, a
// check that bytes came back as they were written and a key that changes with any byte of a definition.
#pragma once

#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <string>

namespace ms {

// FNV-1a 64's offset basis and prime (Fowler, Noll, Vo: 14695981039346656037 = 0xcbf29ce484222325).
inline constexpr std::uint64_t kFnv1aOffset = 14695981039346656037ULL;
inline constexpr std::uint64_t kFnv1aPrime = 1099511628211ULL;

// The digest of `bytes`, continued from `h` (so several strings digest as their concatenation).
inline std::uint64_t fnv1a(const std::string& bytes, std::uint64_t h = kFnv1aOffset) {
    for (unsigned char c : bytes) h = (h ^ c) * kFnv1aPrime;
    return h;
}

// As manifests write it: 16 lower-case hex digits.
inline std::string hex16(std::uint64_t v) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016" PRIx64, v);
    return buf;
}

}  // namespace ms
