// libFuzzer target: LUT files as sweeps read them for comparators, in every format read_lut takes
// (OpenEXR, KTX2, PNG, C header, .inc: told apart by content; seeds of each in fuzz/lut-seeds). Contract:
// read_lut either refuses with std::runtime_error (or std::invalid_argument), or returns a LUT a lookup
// can use: three axes whose counts multiply to the image size without wrapping, 1 to 4 channels with
// roughness in (0, 1], and every texel finite and in [0, 1]. An input holding the line "==sidecar==" is
// split there: the bytes before it are the file, those after it its DDS metadata sidecar (<file>.json),
// so a DDS's metadata is fuzzed with its texels. read_file_metadata (what `lut info` and the
// representation readers ask first) must refuse or answer for every input too: metadata nested
// 100,000 deep once crashed both (fuzz/lut-seeds/deep-*).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "fuzz_common.hpp"
#include "lut/exr_lut.hpp"
#include "lut/formats/lut_reader.hpp"
#include "lut/lookup.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string& path = ms::fuzz::scratch_path(".exr");
    static const char kMarker[] = "\n==sidecar==\n";
    const std::string input(reinterpret_cast<const char*>(data), size);
    const std::size_t split = input.find(kMarker);
    const std::string sidecar = path + ".json";
    if (split == std::string::npos) {
        ms::fuzz::write_scratch(path, data, size);
        std::remove(sidecar.c_str());
    } else {
        ms::fuzz::write_scratch(path, data, split);
        const std::size_t rest = split + sizeof kMarker - 1;
        ms::fuzz::write_scratch(sidecar, data + rest, size - rest);
    }
    try {
        ms::lutfmt::read_file_metadata(path);
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
    try {
        const ms::LutFile lut = ms::read_lut(path);
        if (lut.axes.size() != 3) ms::fuzz::finding("a LUT without three axes accepted");
        const std::uint64_t texels = std::uint64_t(lut.visibility().count) * lut.n_dot_l().count * lut.n_dot_v().count;
        if (texels != std::uint64_t(lut.width) * lut.height) ms::fuzz::finding("axis counts that do not make the image accepted");
        if (lut.data.size() != texels * lut.channels.size()) ms::fuzz::finding("data size differs from the axes");
        if (lut.channels.empty() || lut.channels.size() > 4) ms::fuzz::finding("channel count outside 1..4 accepted");
        for (const auto& c : lut.channels)
            if (!(c.roughness > 0 && c.roughness <= 1)) ms::fuzz::finding("roughness outside (0, 1] accepted");
        for (float v : lut.data)
            if (!(v >= 0 && v <= 1)) ms::fuzz::finding("a texel outside [0, 1] (or NaN) accepted");
        const ms::LutLookup lookup(lut);
        const double v = lookup(0.5, 0.5, 0.5, 0.5);
        if (!(v >= 0 && v <= 1)) ms::fuzz::finding("a lookup outside [0, 1]");
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
