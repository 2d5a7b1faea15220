// libFuzzer target: representation files as eval --compare and sweeps open them, OpenEXR or
// KTX2 (the first byte chooses which extension the bytes are saved under, so both readers see every
// shape; the seeds in fuzz/repr-seeds carry that byte). Contract: open_representation either refuses
// with std::runtime_error (or std::invalid_argument), or returns a representation whose texture has the
// size it claims, with texels inside their channels' ranges (at most [-2, 2]), and whose lookups are
// terms in [0, 1].
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "fuzz_common.hpp"
#include "repr/representation.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    static const std::string exr = ms::fuzz::scratch_path(".repr") + ".exr";
    static const std::string ktx2 = ms::fuzz::scratch_path(".repr") + ".ktx2";
    const std::string& path = (data[0] & 1) ? ktx2 : exr;
    ms::fuzz::write_scratch(path, data + 1, size - 1);
    try {
        const auto r = ms::repr::open_representation(path);
        const std::uint64_t texels = std::uint64_t(r->texture_width()) * r->texture_height() * r->texture_depth();
        if (r->texels().size() != texels * 4) ms::fuzz::finding("texel count differs from the texture's size");
        for (float v : r->texels())
            if (!(v >= -2 && v <= 2)) ms::fuzz::finding("a texel outside [-2, 2] accepted");
        ms::approx::Inputs in;
        for (double phi : {0.0, 1.0, 3.14159}) {
            in.visibility = 0.8;
            in.n_dot_l = 0.6;
            in.n_dot_v = 0.7;
            in.roughness = 0.5;
            in.relative_azimuth = phi;
            const double v = (*r)(in);
            // Blends of texels in [0, 1] (a0's series is clamped): a few dozen roundings of 2^-53 at most.
            if (!(v >= -1e-12 && v <= 1 + 1e-12)) ms::fuzz::finding("a lookup outside [0, 1]");
        }
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
