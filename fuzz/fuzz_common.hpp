// Helpers shared by the libFuzzer targets.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace ms::fuzz {

// The readers take a path (they report file:line:column), so each input is written to one scratch
// file per process and read back. The file lives in $TMPDIR and is overwritten by every input.
inline const std::string& scratch_path(const char* suffix) {
    static const std::string path = [suffix] {
        const char* dir = std::getenv("TMPDIR");
        return std::string(dir && *dir ? dir : "/tmp") + "/microshadow_fuzz_" + std::to_string(::getpid()) + suffix;
    }();
    return path;
}

inline void write_scratch(const std::string& path, const std::uint8_t* data, std::size_t size) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();  // the harness itself failed: not a finding in the code under test
    if (size && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
}

// A violated invariant of the code under test: abort so libFuzzer records the input as a crash.
[[noreturn]] inline void finding(const char* what) {
    std::fprintf(stderr, "fuzz finding: %s\n", what);
    std::abort();
}

}  // namespace ms::fuzz
