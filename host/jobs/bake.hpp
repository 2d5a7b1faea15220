// LUT bakes of the generic VNDF-based micro-shadowing term (part 2's 3D and 2D LUTs, or a custom
// layout) as a job: the layouts, the result, the file metadata, and ms::bake_lut that the CLI
// (`microshadow bake`) and the benchmarks call. What is integrated, and how (shared VNDF pass per
// slice, visibility histogram and prefix sum, azimuth quadrature, batches until a tolerance is met), is
// the LUT slice integrand: host/integrands/lut_slice/.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "integrands/lut_slice/lut_slice_spec.hpp"
#include "lut/exr_lut.hpp"
#include "schedule/cache_key.hpp"
#include "schedule/distributed.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

enum class LutLayout { seed_3d, seed_2d, custom };
std::string to_string(LutLayout);
LutLayout parse_lut_layout(const std::string&);  // "seed-3d" | "seed-2d" | "custom"; std::invalid_argument

// Everything that decides the numbers of a bake (LutSliceSpec), and where it runs.
struct BakeSpec : LutSliceSpec {
    LutLayout layout = LutLayout::seed_3d;
    // OpenCL devices ("default|all|N|name") or the scalar double oracle's threads (small layouts; nv
    // times the work; the exact method's C++ evaluator).
    schedule::BackendSpec backend;
    // Filled by callers for provenance only.
    std::string command_line;
};

// The spec of a layout with every axis of `size` texels (seed-2d: the NdotV = 1 slice).
BakeSpec default_bake_spec(LutLayout layout, std::uint32_t size);

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
    std::uint32_t azimuth_cells = 0;      // stratified azimuth: cells per row (0: nodes or a fixed angle)
    bool tolerance_met = true;
    std::uint64_t rerun_chunks = 0;       // chunks rerun after a device failed
    std::vector<std::string> devices;     // labels of the devices used
    std::vector<std::string> failed_devices;
    double seconds = 0;
    double device_seconds = 0;            // summed kernel time of all chunks (wall time of the waits)
    // The same split by stage, summed over slices (integrands/lut_slice SliceReport): point sets and
    // normals kernel, histogram kernel and read-back, host reduction of the tallies.
    double normals_seconds = 0, histogram_seconds = 0, reduce_seconds = 0;
    std::uint64_t sample_node_rows = 0;   // histogram updates performed: samples x rows x azimuth nodes
    // Azimuth quadrature estimate: max over sampled (slice, row) of |T_K/2 - T_K| at the K used (0 when
    // K is odd or a fixed angle), and how many (slice, row) pairs ended at each K (adaptive or fixed).
    double azimuth_quadrature_error = 0;
    std::map<std::uint32_t, std::uint64_t> azimuth_rows_by_intervals;
    // Exact method: the tolerance asked of each texel and the Gauss pieces used over all texels.
    double exact_tolerance = 0;
    std::uint64_t exact_quadrature_pieces = 0;
    // A distributed run (schedule/distributed.hpp): false when this process holds only some slices (a
    // shard, or an MPI rank other than 0), which then writes nothing.
    bool complete = true;
    std::uint64_t loaded_slices = 0;      // slices taken from the chunk store (resumed or merged)
    std::uint64_t computed_slices = 0;    // slices this process computed (or, MPI rank 0, gathered)

    float at(std::uint32_t channel, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const;
};

struct BakeCallbacks {
    std::function<void(std::size_t done, std::size_t total)> progress;  // slices done
};

// The host memory a bake of this spec will need on `places` places (before anything is allocated).
std::uint64_t bake_host_memory(const BakeSpec& spec, std::size_t places);


// Runs the bake on the scheduler (the LUT slice integrand, one work item per slice). Throws
// std::invalid_argument for a bad spec, ocl::Error when every device failed, ms::Cancelled when
// ms::cancel_requested() was set.
BakeResult bake_lut(const BakeSpec& spec, schedule::Scheduler& scheduler, const BakeCallbacks& callbacks = {},
                    const schedule::ItemPlan& items = {});
// The same on a scheduler made from spec.backend.
BakeResult bake_lut(const BakeSpec& spec, const BakeCallbacks& callbacks = {});

// The cache key of a bake (schedule/cache_key.hpp): every field of the spec that decides its slices'
// bits, the kind of place of `scheduler` and the version; the fields left out, each with the reason:
// bake_cache_key_exclusions(). bake_store_key: its chunk store's key.
schedule::CacheKey bake_cache_key(const BakeSpec& spec, const schedule::Scheduler& scheduler);
const std::vector<std::string>& bake_cache_key_exclusions();
schedule::StoreKey bake_store_key(const BakeSpec& spec, const schedule::Scheduler& scheduler);

// The metadata JSON recorded in the file for this spec and result.
nlohmann::json bake_metadata(const BakeSpec& spec, const BakeResult& result);

// The channels a bake writes: R, G, B, A by increasing roughness index, each isotropic
// (alpha_x = alpha_y = roughness^2).
std::vector<LutChannel> bake_channels(const BakeSpec& spec);
// The LUT file of a finished bake: its three axes, bake_channels, the texels and `metadata`
// (bake_metadata, with whatever the caller adds).
LutFile bake_lut_file(const BakeSpec& spec, const BakeResult& result, nlohmann::json metadata);


}  // namespace ms
