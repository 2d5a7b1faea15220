// The DFG LUT bake (split-sum scale and bias, and the single-scattering albedo E = scale + bias that
// the multiple-scattering energy compensation 1 + F0 (1/E - 1) needs) as a job over the DFG integrand
// (host/integrands/dfg/) and the scheduler, its file metadata, and its verification against the oracle.
//
// Layout (the conventions of the micro-shadowing LUTs): width = NdotV (x, left to right), height =
// roughness (y, increasing downwards), texel centres (i + 0.5) / n by default, endpoints i / (n - 1) on
// request (NdotV = 0 is then evaluated at kMinNdotV, roughness 0 by its exact limit: no microfacets,
// scale = 1 - (1 - v)^5, bias = (1 - v)^5). alpha = roughness^2. Channels R = scale, G = bias, B = E.
// three.js's DFGLUTData.js stores the transpose (x = roughness, y = NdotV) with two channels.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "grid/axis.hpp"
#include "integrands/dfg/dfg_integrand.hpp"
#include "integrands/lut_slice/lut_slice_spec.hpp"
#include "lut/formats/texture_writer.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

class OutputSet;

// kMinNdotV, the grazing clamp of NdotV, is the one every LUT bake shares (integrands/lut_slice/lut_slice_spec.hpp).

// How the texels are computed: `exact` (exact/dfg_exact.hpp: Gauss-Legendre to ~1e-12, host threads),
// `sampled` (the VNDF kernel with replicate error bars) or `quadrature` (the independent quadrature that
// checks both, integrands/dfg/dfg_quadrature.hpp).
enum class DfgMethod { exact, sampled, quadrature };
const char* to_string(DfgMethod m);
DfgMethod parse_dfg_method(const std::string& s);  // throws std::invalid_argument naming the value

// What a file's channels hold, in order (1 to 4 of them): scale and bias of the split sum
// (integral f F NdotL dL = F0 scale + bias), E = scale + bias (the single-scattering albedo, for
// Filament's and Turquin's multiple-scattering compensation 1 + F0 (1/E - 1)) and sheen (the cloth
// Charlie albedo). Filament's cmgen layout with multiscatter and cloth is bias, E, sheen.
enum class DfgChannel { scale, bias, albedo, sheen };
const char* to_string(DfgChannel c);
// "scale,bias,E,sheen" (names case-insensitive; "albedo" = "E"); throws std::invalid_argument.
std::vector<DfgChannel> parse_dfg_channels(const std::string& s);
std::string channels_string(const std::vector<DfgChannel>& channels);
bool has_sheen(const std::vector<DfgChannel>& channels);

// The x axis: NdotV itself (`linear`) or sqrt(NdotV) (HDRP's FGD tables: x = sqrt(NdotV), so texel
// coordinate a holds NdotV = a^2, denser at grazing views).
enum class DfgParameterization { linear, sqrt_n_dot_v };
const char* to_string(DfgParameterization p);
DfgParameterization parse_dfg_parameterization(const std::string& s);

struct DfgBakeSpec {
    Axis n_dot_v{"n_dot_v", 0, 1, 64};
    Axis roughness{"roughness", 0, 1, 64};
    SamplingPlan plan{Sequence::sobol, 65536, 8, 0};
    dfg::DfgRoutineConfig routine;
    // The devices of the sampled method's kernel (and of the exact method's check against it) and the
    // host threads of the other methods (0: all); the method decides which runs the bake (dfg_backend).
    schedule::BackendSpec backend;
    DfgMethod method = DfgMethod::sampled;
    std::vector<DfgChannel> channels{DfgChannel::scale, DfgChannel::bias, DfgChannel::albedo};
    DfgParameterization parameterization = DfgParameterization::linear;
    std::string command_line;  // provenance
};

struct DfgBakeResult {
    std::uint32_t width = 0, height = 0;  // NdotV count, roughness count
    std::vector<dfg::DfgValue> values;    // values[y * width + x]
    std::vector<DfgChannel> channels;     // what the files hold (the spec's)
    double max_exact_error = 0;           // exact / quadrature: the largest error estimate over texels and channels
    std::vector<std::uint8_t> exact;      // 1 where the texel is an exact limit (roughness 0)
    double max_std_error = 0;             // over sampled texels and the three channels
    double seconds = 0;
    std::string backend;
    // Failover (schedule/scheduler.hpp): items rerun on another device after one failed, and the failures.
    std::uint64_t rerun_items = 0;
    std::vector<std::string> failed_devices;
    const dfg::DfgValue& at(std::uint32_t x, std::uint32_t y) const { return values[std::size_t(y) * width + x]; }
    // Channel c of texel (x, y).
    double channel(std::uint32_t x, std::uint32_t y, DfgChannel c) const;
};

struct DfgBakeCallbacks {
    std::function<void(std::uint64_t done, std::uint64_t total)> progress;
};

void validate(const DfgBakeSpec& spec);
// Where the bake runs: the spec's backend, of the kind its method needs (sampled: OpenCL devices; the
// others: host threads).
schedule::BackendSpec dfg_backend(const DfgBakeSpec& spec);
// The texel's parameters after the clamps above.
dfg::DfgPoint dfg_texel_point(const DfgBakeSpec& spec, std::uint32_t x, std::uint32_t y);

DfgBakeResult bake_dfg(const DfgBakeSpec& spec, schedule::Scheduler& scheduler, const DfgBakeCallbacks& callbacks = {});
DfgBakeResult bake_dfg(const DfgBakeSpec& spec, const DfgBakeCallbacks& callbacks = {});

nlohmann::json dfg_metadata(const DfgBakeSpec& spec, const DfgBakeResult& result);

// Writes the LUT, the format by the extension (lut/formats/texture_format.hpp, any case; others are
// refused), through the one texture writer (lut/formats/texture_writer.hpp), the channels in the
// result's order (R G B A; default scale, bias, E): OpenEXR (".exr"; FLOAT or HALF), KTX2 (".ktx2") or
// DDS (".dds", metadata in "<file>.json"): a 2D texture, x = NdotV, y = roughness, RG for two channels
// (RG16F / RG32F), else RGBA with the last channel repeated, float32 or float16 with `half` (the
// metadata gains the error budget with the float16 rounding); a 16-bit PNG (".png", RGB or RGBA,
// metadata in iTXt "microshadow"); C source in the one convention of every texture (".h" / ".hpp":
// SYMBOL_WIDTH, _HEIGHT, _DEPTH (1), _COMPONENTS, `symbol`_metadata and the flat array
// `symbol`_data[(y * width + x) * components + c], floats, or uint16_t half bits with `half`; ".inc":
// the values alone, the metadata on a comment line). Every file's "max_error_bound_99.9" bounds the
// values it stores: the computed values' bound (kept as "computed_error_bound_99.9") plus their
// rounding to the stored encoding ("storage_rounding": float32, float16 with `half`, unorm16 in a PNG).
void check_dfg_lut_format(const std::string& path);  // throws std::invalid_argument before any work
// The format and what it can hold (a PNG cannot hold sheen, which exceeds 1), and the C symbol.
void check_dfg_lut_output(const std::string& path, const std::vector<DfgChannel>& channels, const std::string& symbol);
// The LUT's files as entries of an output set (io/atomic_file.hpp), added before any work so a bad or
// colliding destination is refused first: the file, and for DDS its "<file>.json".
using DfgLutFiles = lutfmt::TextureFiles;
DfgLutFiles add_dfg_lut_files(OutputSet& outputs, const std::string& path);
// Writes the LUT into those entries' temporaries (the caller commits the set).
// `symbol` names the C source's identifiers (SYMBOL_WIDTH ..., symbol_data, symbol_metadata).
void write_dfg_lut(OutputSet& outputs, const DfgLutFiles& files, const DfgBakeResult& result, const nlohmann::json& metadata,
                   bool half = false, const std::string& symbol = "microshadow_dfg");
// One LUT on its own, committed at once.
void write_dfg_lut(const std::string& path, const DfgBakeResult& result, const nlohmann::json& metadata, bool half = false,
                   const std::string& symbol = "microshadow_dfg");

// Re-checks k random integrated texels with methods that share no formula code with the bake's:
// - sampled: against the quadrature oracle; a texel fails when |lut - oracle| > t * std_error +
//   oracle error + 1e-6 (float rounding) in any GGX channel, t the Student-t quantile at
//   1 - 0.001 / (3k) (Bonferroni over texels and channels); sheen (from the exact path) as for exact.
// - exact: against the quadrature oracle at order 20, failing beyond kDfgExactTolerance in any
//   channel, and against the VNDF kernel (spec.plan, spec.device) within its Bonferroni-t bars as above.
// - quadrature: against the exact path, failing beyond kDfgExactTolerance.
constexpr double kDfgExactTolerance = 1e-10;
struct DfgVerification {
    std::uint32_t checked = 0, failed = 0;
    double worst_z = 0, threshold = 0, worst_abs_diff = 0;
    std::string worst_texel;
    // The deterministic comparison (exact against quadrature): largest |difference| and its tolerance.
    double worst_deterministic_diff = 0, deterministic_tolerance = 0;
    std::string worst_deterministic_texel;  // where that difference is (worst_texel: the largest z)
    std::string reference;  // what the texels were compared with, in words
};
DfgVerification verify_dfg(const DfgBakeSpec& spec, const DfgBakeResult& result, std::uint32_t k, std::uint64_t seed = 1);

}  // namespace ms

namespace ms {
// Differences from a reference LUT of the same size (e.g. the quadrature's, --backend oracle): max and
// RMS |result - reference| over all texels, per channel (scale, bias, E), and where the worst one is.
struct DfgComparison {
    double max_abs[3] = {0, 0, 0}, rms[3] = {0, 0, 0};
    double max_all = 0;
    std::uint32_t worst_x = 0, worst_y = 0;
};
DfgComparison compare_dfg(const DfgBakeResult& result, const std::string& reference_exr);

// A PNG of the three channels (scale, bias, E) with axes (NdotV across, roughness down) and titles.
void write_dfg_preview(const std::string& path, const DfgBakeResult& result, const DfgBakeSpec& spec);
// The same PNG written to `file` as it is (an OutputSet's temporary).
void write_dfg_preview_file(const std::string& file, const DfgBakeResult& result, const DfgBakeSpec& spec);
}  // namespace ms
