// LUT bakes of the generic VNDF-based micro-shadowing term (part 2's 3D and 2D LUTs, or a custom
// layout): the spec, the result, and the library entry point ms::bake_lut that the CLI (`microshadow
// bake`) and the benchmarks call. The algorithm (shared VNDF pass per slice, visibility histogram and
// prefix sum, azimuth quadrature, batches until a tolerance is met) is derived in host/bake/bake.cpp.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "lut/exr_lut.hpp"
#include "device/runtime.hpp"

namespace ms {

enum class LutLayout { seed_3d, seed_2d, custom };
std::string to_string(LutLayout);
LutLayout parse_lut_layout(const std::string&);  // "seed-3d" | "seed-2d" | "custom"; std::invalid_argument

// Everything that decides the numbers of a bake.
struct BakeSpec {
    LutLayout layout = LutLayout::seed_3d;
    // Axes, in file order: visibility (x), n_dot_l (rows within a slice), n_dot_v (slices).
    LutAxis visibility{"visibility", 0, 1, 32, TexelConvention::centres};
    LutAxis n_dot_l{"n_dot_l", 0, 1, 32, TexelConvention::centres};
    LutAxis n_dot_v{"n_dot_v", 0, 1, 32, TexelConvention::centres};
    // Isotropic roughness of each channel (R, G, B, A in order), alpha = roughness^2; 1 to 4 values in (0, 1].
    std::vector<double> roughness{0.1, 0.4, 0.7, 1.0};

    // Relative azimuth between wi and wo: the mean of the term over [0, 180] degrees (trapezoid rule
    // with azimuth_intervals + 1 nodes), or one fixed angle in degrees.
    bool azimuth_mean = true;
    double azimuth_degrees = 0;
    // azimuth_intervals > 0: that fixed K for every texel. 0 (the default): adaptive, per (slice, NdotL
    // row): start at azimuth_min_intervals and double K (nested nodes, same points) while some sampled
    // texel of the row has |T_K - T_K/2| > azimuth_refine_threshold + azimuth_refine_z * (its replicate
    // std error), up to azimuth_max_intervals (powers of two; defaults measured, see bake.cpp).
    std::uint32_t azimuth_intervals = 0;
    std::uint32_t azimuth_min_intervals = 4, azimuth_max_intervals = 32;
    double azimuth_refine_threshold = 1e-4, azimuth_refine_z = 3;

    TermOptions term;
    Sequence sequence = Sequence::sobol;
    std::uint32_t replicates = 8;
    // Samples per batch and slice (all replicates together), rounded up like eval's --samples.
    std::uint64_t samples = 0;  // 0: the measured default (kDefaultBatchSamples)
    std::uint64_t seed = 0;
    // Error control: tolerance > 0 adds batches to a slice until every texel's std error <= tolerance
    // (or max_batches is reached); tolerance == 0 runs exactly one batch of `samples`.
    double tolerance = 0;
    std::uint32_t max_batches = 64;

    std::string device = "default";  // ocl::select_devices spec: "default|all|N|name"
    ocl::BuildConfig build;

    // Filled by callers for provenance only.
    std::string command_line;
};

// Defaults chosen by measurement (see bake.cpp for the figures).
extern const std::uint32_t kDefaultAzimuthIntervals;
extern const std::uint64_t kDefaultBatchSamples;
extern const double kDefaultTolerance;

// The spec of a layout with every axis of `size` texels (seed-2d: the NdotV = 1 slice).
BakeSpec default_bake_spec(LutLayout layout, std::uint32_t size);

// Throws std::invalid_argument naming the problem (sizes 1..4096, roughness in (0, 1], ranges, ...).
void validate(const BakeSpec& spec);

struct BakeResult {
    // Atlas of width = visibility count, height = n_dot_l count * n_dot_v count, `channels` floats
    // per texel interleaved: value[(y * width + x) * channels + c]. std_error has the same layout.
    std::uint32_t width = 0, height = 0, channels = 0;
    std::uint32_t n_dot_l_count = 0;  // rows per NdotV slice
    std::vector<float> value;
    std::vector<float> std_error;
    double max_std_error = 0;             // over sampled texels
    std::uint64_t texels = 0;             // width * height * channels
    std::uint64_t skipped_zero = 0;       // zero-region texels written as exact 0
    std::uint64_t skipped_one = 0;        // v = 1 texels written as exact 1
    std::uint64_t slices = 0;             // (roughness, NdotV) work chunks
    std::uint64_t batches = 0;            // sample batches run, over all slices
    std::uint64_t max_samples_per_slice = 0;  // samples of the most sampled slice (all replicates)
    std::uint64_t samples_per_batch = 0;
    std::uint32_t azimuth_nodes = 1;
    bool tolerance_met = true;
    std::uint64_t rerun_chunks = 0;       // chunks rerun after a device failed
    std::vector<std::string> devices;     // labels of the devices used
    std::vector<std::string> failed_devices;
    double seconds = 0;
    double device_seconds = 0;            // summed kernel time of all chunks (wall time of the waits)
    std::uint64_t sample_node_rows = 0;   // histogram updates performed: samples x rows x azimuth nodes
    // Azimuth quadrature estimate: max over sampled (slice, row) of |T_K/2 - T_K| at the K used (0 when
    // K is odd or a fixed angle), and how many (slice, row) pairs ended at each K (adaptive or fixed).
    double azimuth_quadrature_error = 0;
    std::map<std::uint32_t, std::uint64_t> azimuth_rows_by_intervals;

    float at(std::uint32_t channel, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const;
};

struct BakeCallbacks {
    std::function<void(std::size_t done, std::size_t total)> progress;  // slices done
};

// Runs the bake on the spec's devices. Throws std::invalid_argument for a bad spec, ocl::Error when
// every device failed, ms::Cancelled when ms::cancel_requested() was set.
BakeResult bake_lut(const BakeSpec& spec, const BakeCallbacks& callbacks = {});

// The metadata JSON recorded in the file for this spec and result.
nlohmann::json bake_metadata(const BakeSpec& spec, const BakeResult& result);

// The (alpha, wi, wo) query of one texel at one azimuth (degrees), as `microshadow eval` would take it.
Query texel_query(const BakeSpec& spec, std::uint32_t channel, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv,
                  double azimuth_degrees);
// The azimuth nodes (degrees) and trapezoid weights (summing to 1) a fixed-K bake uses; for the adaptive
// default (azimuth_intervals 0) the reference grid of kDefaultAzimuthIntervals, which the adaptive rows
// approximate to within the recorded quadrature estimate (verify and the benchmarks use it).
void azimuth_nodes(const BakeSpec& spec, std::vector<double>& degrees, std::vector<double>& weights);

}  // namespace ms
