// GLSL/HLSL to SPIR-V through glslangValidator (Debian glslang-tools), for the shader tests that run
// generated code on a Vulkan device.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cli_runner.hpp"

namespace ms::testing {

inline bool have_glslang() { return run_shell("command -v glslangValidator >/dev/null 2>&1").exit_code == 0; }

// Writes `source` to `file`, compiles it with `flags` (e.g. "-S comp", "-D -e main -S comp" for HLSL)
// and returns the SPIR-V words; a compile error fails the calling test with the compiler's output.
inline std::vector<std::uint32_t> compile_spirv(const std::string& source, const std::string& file, const std::string& flags) {
    std::ofstream(file) << source;
    const RunResult r = run_shell("glslangValidator " + flags + " -V -o " + file + ".spv " + file + " 2>&1");
    EXPECT_EQ(r.exit_code, 0) << file << ":\n" << r.output << "\n" << source;
    std::ifstream in(file + ".spv", std::ios::binary);
    std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::vector<std::uint32_t> words(bytes.size() / 4);
    if (!words.empty()) std::memcpy(words.data(), bytes.data(), words.size() * 4);  // no memcpy from null
    return words;
}

}  // namespace ms::testing
