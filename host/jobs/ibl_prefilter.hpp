// The GGX-prefiltered specular cubemap (split-sum's radiance half): a mip chain whose mip m holds the
// environment prefiltered at roughness mip_roughness(m) (cmgen's mapping by default), by filtered
// importance sampling (host/env/prefilter.hpp) on CPU threads, with --verify against the brute-force
// oracle on random texels, and the files of `microshadow ibl prefilter`.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "env/cubemap.hpp"
#include "env/prefilter.hpp"
#include "lut/formats/texture_writer.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

class OutputSet;

struct PrefilterSpec {
    std::uint32_t levels = 0;  // 0: down to 4 x 4 faces (log2(size) - 1 levels)
    env::RoughnessMapping mapping = env::RoughnessMapping::cmgen;
    // samples: per texel, all replicates: the first round's with a tolerance, else the only one.
    SamplingPlan plan{Sequence::sobol, 256, 16, 0};
    env::PrefilterOptions options;
    // Sample rounds until every texel's relative error bar (below) is at most `tolerance`; 0: one round of
    // plan.samples. A texel's bar on channel c is t_{0.975, R-1} se_c + b_c: the two-sided 95% Student-t
    // interval of the sampled part over the R replicates plus the explicit part's bound b_c (bright texels);
    // relative to max(mean of RGB, 1e-4 x the environment's mean radiance). No texel takes more than
    // max_samples; those that would are counted (PrefilterResult::unconverged).
    double tolerance = 0.02;
    std::uint64_t max_samples = 1u << 16;
    // Bright texels summed explicitly (env/prefilter.hpp, BrightSplit): bright_threshold > 0 takes the texels
    // above that many times the mean radiance; else bright_auto chooses them (choose_bright_split, for
    // `tolerance`, 0.01 when it is 0); at most bright_max_texels.
    double bright_threshold = 0;
    bool bright_auto = true;
    std::size_t bright_max_texels = 4096;
    // One explicit texel's cost against one sample (choose_bright_split): measured 0.25 on CPU threads (40 ns a
    // bright texel against 160 ns a filtered sample, forest.exr at 64 px; docs/ibl.md).
    double bright_cost_ratio = 0.25;
    // ... on mips of at least this roughness (0: every mip, measured best at 64^2 faces; the explicit sum costs
    // bright texels x the mip's texels, so large chains may keep it to the wide lobes, e.g. 0.2).
    double bright_min_roughness = 0;
    // The first round's samples per texel on those wide-lobe mips (roughness >= bright_min_roughness)
    // multiplied by this factor (a power of two): with a fixed sample count (tolerance 0) they hold 6% of an
    // 8-mip chain's texels and most of its variance.
    std::uint32_t wide_samples_factor = 1;
    // The oracle kind (the default): the C++ estimator on CPU threads (backend.threads, 0: every
    // hardware thread; they also sum the explicit bright texels); opencl: the kernel on those devices.
    schedule::BackendSpec backend = schedule::BackendSpec::oracle();
    std::string source, command_line;  // provenance
    // Test hook, set by the CLI from MICROSHADOW_TEST_PREFILTER_BIAS: every value is multiplied by
    // (1 + test_bias) and its bars are left alone, a corrupted estimator that --verify must catch.
    double test_bias = 0;
};

struct PrefilterResult {
    std::vector<env::Cubemap> mips;  // mip 0 = the source (roughness 0)
    std::vector<double> roughness;
    // Per texel and channel of mips >= 1: the sampled part's replicate standard error se_c and the explicit
    // part's bound b_c (0 where no bright texel is summed); mip 0 empty.
    std::vector<env::Cubemap> std_error, explicit_bound;
    std::uint32_t replicates = 0;
    double t_multiplier = 0;            // t_{0.975, R-1}: bar = t se + b
    double max_relative_std_error = 0;  // over texels with a non-zero value, the largest se / value
    double max_relative_bar = 0;        // the largest relative bar (t se + b) / scale over every texel
    std::uint64_t unconverged = 0;      // texels whose bar is above the tolerance after max_samples
    std::uint32_t rounds = 0;           // sample rounds of the mip that took the most
    std::vector<double> mean_samples_by_mip;  // [mip] samples per texel, 0 for mip 0
    double seconds = 0;
    double cpu_seconds = 0;  // CPU time of the process over the run (every thread)
    std::uint64_t texels = 0, samples = 0;
    // Failover on OpenCL devices (schedule/scheduler.hpp): items rerun after a device failed, and the failures.
    std::uint64_t rerun_items = 0;
    std::vector<std::string> failed_devices;
    std::size_t bright_texels = 0;       // summed explicitly
    double bright_power_fraction = 0;    // their share of the environment's power (mean of RGB)
    double bright_threshold = 0;         // the chosen split's threshold, times the mean radiance
};

struct PrefilterCallbacks {
    std::function<void(std::uint64_t done, std::uint64_t total)> progress;
};

std::uint32_t default_levels(std::uint32_t size);
// The chain packed for the kernel routine (level-major, faces, rows, RGB).
namespace prefilter { struct SourceChain; }
prefilter::SourceChain pack_chain(const std::vector<env::Cubemap>& chain);
PrefilterResult prefilter_cubemap(const env::Cubemap& source, const PrefilterSpec& spec, const PrefilterCallbacks& cb = {});

// K random texels of mips >= 1 against the oracle: relative RMS and max error over texels and channels
// (relative to the oracle's mean of the three channels), and each channel's
//     z = max(0, |value - oracle| - b - rounding) / se
// with the run's own bars (PrefilterResult::std_error, explicit_bound; rounding: the float the file stores,
// 2^-23 |value|). `passed` is false when some z exceeds the Bonferroni bound t_{1 - alpha / (2 M), R - 1} for
// the M = 3 K channels checked at family-wise level alpha = 0.01 (or when se = 0 and the difference exceeds
// b + rounding): a texel outside its bars. The bars hold for the estimate's variance only, so filtering's blur
// (filtered importance sampling is biased, less as samples grow) counts as a disagreement.
struct PrefilterVerification {
    std::uint32_t checked = 0;
    double rms_relative = 0, max_relative = 0, worst_z = 0;
    double z_bound = 0;   // the Bonferroni bound
    bool passed = true;
    // RMS of the replicate std errors relative to the same scale: the variance part of rms_relative (what is left,
    // sqrt(rms_relative^2 - rms_relative_std_error^2), is bias: filtering's blur, or a rare bright texel no replicate saw).
    double rms_relative_std_error = 0;
    std::vector<double> rms_relative_by_mip, rms_std_error_by_mip;  // [mip], 0 where no texel of it was drawn (mip 0 never)
    std::string worst_texel, worst_z_texel;
};
PrefilterVerification verify_prefilter(const env::Cubemap& source, const PrefilterResult& result, std::uint32_t k,
                                       std::uint64_t seed = 1);
nlohmann::json verification_json(const PrefilterVerification& check);

nlohmann::json prefilter_metadata(const PrefilterSpec& spec, const PrefilterResult& result);

// The specular files of `ibl prefilter` in DIR, as entries of one output set (io/atomic_file.hpp), added
// before any work so a bad or colliding destination is refused first:
//   format "exr": DIR/specular_m<m>.exr, one horizontal cross per mip, metadata with the mip's roughness;
//   format "ktx2" / "dds": DIR/specular.<format>, the whole chain as one cubemap (KTX2 faceCount 6,
//     levelCount = mips; DDS DDSCAPS2_CUBEMAP_ALLFACES, dwMipMapCount = mips, metadata in "<file>.json"),
//     RGBA with A = 1, float16 or float32; the metadata gains "mip_roughness", "encoding" and
//     "quantisation" (the measured max absolute and relative rounding error over the RGB data);
//   DIR/specular_preview.png: the chain unfolded (crosses side by side, each mip magnified to the base size).
struct PrefilterFiles {
    lutfmt::TextureFormat format = lutfmt::TextureFormat::exr;
    std::string encoding;
    std::vector<lutfmt::TextureFiles> mips;      // exr: a cross per mip
    std::optional<lutfmt::TextureFiles> cubemap;  // ktx2 / dds: the chain (and a DDS's sidecar)
    std::size_t preview = 0;
};
// format: exr, ktx2 or dds; encoding (ktx2 / dds): float16 or float32; else std::invalid_argument.
PrefilterFiles add_prefilter_files(OutputSet& outputs, const std::string& dir, std::uint32_t levels, const std::string& format,
                                   const std::string& encoding = "float16");
// Writes them into the set's temporaries (the caller commits the set). `exposure`: the preview's.
void write_prefilter_files(OutputSet& outputs, const PrefilterFiles& files, const PrefilterResult& result,
                           const nlohmann::json& metadata, double exposure = 1.0);
// The files of an earlier run into DIR that this run does not write (their names are in `written`):
// specular_m<m>.exr of mips this run does not have, specular.ktx2 / .dds (+ .json) of another format,
// dfg.<format>, dfg.dds.json and dfg_preview.png when this run writes no DFG LUT there.
std::vector<std::string> stale_prefilter_files(const std::string& dir, const std::set<std::string>& written);

}  // namespace ms
