// libFuzzer target: environments as `ibl sh | prefilter | irradiance` read them, OpenEXR or Radiance
// RGBE. The bytes are saved as .exr when they start with OpenEXR's magic number, else as .hdr, so the
// seeds (fuzz/env-seeds, tests/data/hostile/exr) are plain files. Contract: read_environment_image
// either refuses with env::EnvironmentError (bad input: exit status 2 in the CLI; any other exception
// is a finding), or returns an RGB image of the size it claims whose every value is finite, non-negative
// and at most kMaxRadiance; its SH projection (when it is 2:1) is then finite too.
#include <cmath>
#include <cstdint>
#include <cstring>

#include "env/image.hpp"
#include "env/sh.hpp"
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::string exr = ms::fuzz::scratch_path(".env") + ".exr";
    static const std::string hdr = ms::fuzz::scratch_path(".env") + ".hdr";
    static const std::uint8_t kExrMagic[4] = {0x76, 0x2f, 0x31, 0x01};
    const bool is_exr = size >= 4 && std::memcmp(data, kExrMagic, 4) == 0;
    const std::string& path = is_exr ? exr : hdr;
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
    return 0;
}
