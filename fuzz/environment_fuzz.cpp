// libFuzzer target: environments as `ibl sh | prefilter | irradiance` read them, OpenEXR, Radiance
// RGBE, or a one-file cubemap (KTX2, DDS). The bytes are saved as .exr when they start with OpenEXR's
// magic number, .ktx2 / .dds after KTX2's identifier / "DDS ", else as .hdr, so the seeds
// (fuzz/env-seeds, tests/data/hostile/exr) are plain files. Contract: read_environment_image
// either refuses with env::EnvironmentError (bad input: exit status 2 in the CLI; any other exception
// is a finding), or returns an RGB image of the size it claims whose every value is finite, non-negative
// and at most kMaxRadiance; its SH projection (when it is 2:1) is then finite too. A cubemap file read
// by read_cubemap_file has levels halving from its base, each value radiance as above.
#include <cmath>
#include <cstdint>
#include <cstring>

#include "env/cubemap_file.hpp"
#include "env/image.hpp"
#include "env/sh.hpp"
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::string exr = ms::fuzz::scratch_path(".env") + ".exr";
    static const std::string hdr = ms::fuzz::scratch_path(".env") + ".hdr";
    static const std::string ktx2 = ms::fuzz::scratch_path(".env") + ".ktx2";
    static const std::string dds = ms::fuzz::scratch_path(".env") + ".dds";
    static const std::uint8_t kExrMagic[4] = {0x76, 0x2f, 0x31, 0x01};
    static const std::uint8_t kKtx2Identifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    const bool is_exr = size >= 4 && std::memcmp(data, kExrMagic, 4) == 0;
    const bool is_ktx2 = size >= 12 && std::memcmp(data, kKtx2Identifier, 12) == 0;
    const bool is_dds = size >= 4 && std::memcmp(data, "DDS ", 4) == 0;
    const std::string& path = is_exr ? exr : is_ktx2 ? ktx2 : is_dds ? dds : hdr;
    ms::fuzz::write_scratch(path, data, size);
    try {
        const ms::env::Image image = ms::env::read_environment_image(path);
        if (image.width == 0 || image.height == 0) ms::fuzz::finding("an empty image accepted");
        if (image.channels != 3 || image.channel_names.size() != 3) ms::fuzz::finding("an environment without three channels");
        if (image.data.size() != std::size_t(image.width) * image.height * 3) ms::fuzz::finding("data size differs from the image's");
        for (float v : image.data)
            if (!(v >= 0 && v <= ms::env::kMaxRadiance)) ms::fuzz::finding("a value that is not radiance accepted");
        if (image.width == 2 * image.height && image.width <= 512) {
            const ms::env::Sh9 sh = ms::env::sh_project_equirect(image);
            for (const auto& k : sh)
                for (double c : k)
                    if (!std::isfinite(c)) ms::fuzz::finding("a non-finite SH coefficient");
        }
    } catch (const ms::env::EnvironmentError&) {
    }
    if (is_ktx2 || is_dds) try {
            const ms::env::CubemapFile cube = ms::env::read_cubemap_file(path);
            if (cube.levels.empty() || cube.levels[0].size == 0) ms::fuzz::finding("an empty cubemap accepted");
            for (std::size_t p = 0; p < cube.levels.size(); ++p) {
                const std::uint32_t n = cube.levels[0].size >> p ? cube.levels[0].size >> p : 1;
                if (cube.levels[p].size != n) ms::fuzz::finding("a cubemap level that is not half the one above");
                for (const auto& face : cube.levels[p].faces) {
                    if (face.data.size() != std::size_t(n) * n * 3) ms::fuzz::finding("a face's data size differs from its level's");
                    for (float v : face.data)
                        if (!(v >= 0 && v <= ms::env::kMaxRadiance)) ms::fuzz::finding("a cubemap value that is not radiance accepted");
                }
            }
        } catch (const ms::env::EnvironmentError&) {
        }
    return 0;
}
