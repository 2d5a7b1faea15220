// The irradiance cubemap by direct convolution (`microshadow ibl irradiance`): every output texel's
// E(n) = integral L(l) max(0, n.l) dl, summed texel by texel over the source reduced to --source-size
// (solid-angle means) by the kernel kernels/irradiance/irradiance.cl through the scheduler, each value with a
// bound on its difference from the exact convolution of the full-resolution source (host/env/irradiance.hpp);
// the oracle backend computes that exact convolution in double. Files hold E / pi (a constant environment L
// gives back L, as the SH irradiance cross of `ibl sh`), and the job compares the map with order-2 SH.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/irradiance.hpp"
#include "lut/formats/texture_writer.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

class OutputSet;

namespace irradiance { struct Source; }

struct IrradianceMapSpec {
    std::uint32_t face_size = 32;     // output faces
    std::uint32_t source_size = 128;  // the reduced source the kernel convolves (clamped to the source's size)
    // OpenCL devices for the kernel, or the oracle: the exact convolution of the full-resolution source
    // on its threads (0: all).
    schedule::BackendSpec backend;
    std::string source, command_line;
};

struct IrradianceMapResult {
    env::Cubemap map;    // E / pi
    env::Cubemap bound;  // bound on |map - exact E / pi of the full-resolution source|
    std::uint32_t source_size = 0, convolution_size = 0;
    double seconds = 0;
    std::string backend;
    // Failover (schedule/scheduler.hpp): items rerun after a device failed, and the failures.
    std::uint64_t rerun_items = 0;
    std::vector<std::string> failed_devices;
    double max_relative_bound = 0;  // max over texels and channels of bound / value
    // Against order-2 SH of the same source (env/sh.hpp) at the output texels, E / pi units:
    double sh_max_abs = 0, sh_max_relative = 0, sh_rms_relative = 0;  // relative to the map's largest value
    // The clamped cosine's order-2 truncation K2(x) = 1/4 + x/2 + (15 x^2 - 5)/32 differs from max(0, x) by at
    // most 3/32 (at x = 0), so |E_sh - E| <= 3/32 * integral L dl for every n: that bound, in E / pi units.
    double sh_truncation_bound = 0;
};

// The reduced source packed for the kernel (Lambert's vector solid angle per texel, in double, rounded).
irradiance::Source pack_irradiance_source(const env::ReducedCubemap& reduced);

IrradianceMapResult compute_irradiance_map(const env::Cubemap& source, const IrradianceMapSpec& spec,
                                           const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

// K random output texels against the exact convolution of the full-resolution source: a texel fails when
// |map - oracle| > bound (the bound is a bound, not a statistical error bar).
struct IrradianceVerification {
    std::uint32_t checked = 0, failed = 0;
    double worst_ratio = 0;  // max |map - oracle| / bound
    double max_abs = 0;      // max |map - oracle| (E / pi)
    std::string worst_texel;
};
IrradianceVerification verify_irradiance_map(const env::Cubemap& source, const IrradianceMapResult& result, std::uint32_t k,
                                             std::uint64_t seed = 1);

nlohmann::json irradiance_map_metadata(const IrradianceMapSpec& spec, const IrradianceMapResult& result);
// The irradiance map E / pi in DIR as the one texture writer writes it (lut/formats/texture_writer.hpp),
// the format a cubemap --format name (lut/formats/texture_format.hpp: exr, ktx2 or dds): DIR/irradiance.exr
// (a horizontal cross) or DIR/irradiance.ktx2 / .dds (one cubemap level, RGBA, A = 1, faces +X -X +Y -Y +Z
// -Z, float16 or float32; .dds with its "<file>.json"). `ibl irradiance` and `ibl prefilter` write their
// irradiance with these. std::invalid_argument for another format or encoding.
lutfmt::TextureFiles add_irradiance_map(OutputSet& outputs, const std::string& dir, const std::string& format,
                                        const std::string& encoding);
void write_irradiance_map(OutputSet& outputs, const lutfmt::TextureFiles& files, const env::Image& cross, const std::string& encoding,
                          const nlohmann::json& metadata);
// The files of `ibl irradiance` in DIR, as entries of one output set (io/atomic_file.hpp), added before
// any work so a bad or colliding destination is refused first: the map above, DIR/irradiance.json and
// DIR/irradiance_preview.png.
struct IrradianceFiles {
    std::string encoding;
    lutfmt::TextureFiles map;
    std::size_t json = 0, preview = 0;
};
IrradianceFiles add_irradiance_files(OutputSet& outputs, const std::string& dir, const std::string& format,
                                     const std::string& encoding = "float16");
// Writes them into the set's temporaries (the caller commits the set). `exposure`: the preview's.
void write_irradiance_files(OutputSet& outputs, const IrradianceFiles& files, const IrradianceMapResult& result,
                            const nlohmann::json& metadata, double exposure = 1.0);
// An earlier run's irradiance.<format> (and irradiance.dds.json) of another format than this run's.
std::vector<std::string> stale_irradiance_files(const std::string& dir, const std::set<std::string>& written);

}  // namespace ms
