// LUT bakes: spec handling, the per-slice engine and the multi-device scheduler.
//
// Algorithm. A LUT texel is GenericM_g(v, alpha, wi, wo) with wi = (sqrt(1 - NdotV^2), 0, NdotV) and
// wo = (sin_l cos phi, sin_l sin phi, NdotL) for a relative azimuth phi. One chunk of work is a slice:
// one roughness (alpha) and one NdotV (wi). For a slice the engine
//   1. turns every point of a batch's point set into a visible normal once (ms_bake_normals);
//   2. for every wo (each NdotL row x each azimuth node) and every replicate, bins the normals by the
//      first visibility texel they pass and prefix-sums (ms_bake_histogram, derivation in
//      kernels/bake_lut.cl): this yields the integer cone count of every visibility texel and the
//      hemisphere count of the row, i.e. a whole LUT row per (wo, replicate) from one pass;
//   3. reduces on the host: per azimuth node the pooled ratio sum_r cone / sum_r hemisphere (exactly
//      eval's estimator); for --azimuth mean the value is the trapezoid-weighted mean over the nodes of
//      those ratios (the mean of the term, not a ratio of means). The nodes are chosen per NdotL row
//      (adaptive, the default): a row starts at K = 4 intervals (5 nodes) and, while some sampled texel
//      has |T_K - T_K/2| > threshold + z * se(T_K - T_K/2) (se from the replicates' own differences;
//      the trapezoid nodes are nested, so T_K/2 costs nothing), gets the K midpoint nodes of 2K, up to
//      K = 32. Decided on batch 0's integer counts, kept for later batches; a row that stops at K is
//      bit for bit the fixed-K bake's row. The file records max |T_K - T_K/2| at the rows' final K. Its standard error comes from the
//      replicates: per replicate r the node-weighted mean x_r of its own ratios, then
//      se = sqrt(sum_r (x_r - mean x)^2 / (R (R - 1))) - this accounts for the correlation between
//      nodes (they share the points) because each x_r already combines them.
//   4. with a tolerance, adds batches (new independent point sets, seeds derived from the seed and the
//      batch index) to the slice until its largest texel std error is <= tolerance. Counts of replicate
//      r are summed over batches, so each replicate stays an independent randomisation.
// Exact texels: the zero region (NdotL <= 2 cos_t^2 - 1, core/cone.hpp) is written as 0 and v = 1 as 1;
// the kernel still bins them (a row is one pass), but their values come from the rule, not the counts.
// Determinism: every count is an integer computed from (spec, slice, batch) alone, and each slice is
// reduced in a fixed order, so the file is bit-identical whatever the devices or their number.
#include "jobs/bake.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "core/cancel.hpp"
#include "core/cone.hpp"
#include "microshadow_shared.h"
#include "device/error.hpp"
#include "sampling/point_set.hpp"

namespace ms {

static_assert(sizeof(ms_bake_slice) == 64, "ms_bake_slice layout must match the OpenCL C struct");

// Defaults, chosen by measurement on the seed-3d layout:
// - Azimuth: trapezoid intervals K. 32^3 bakes at 262144 samples (same points), max |T_K - T_2K| over
//   all texels: K=4 vs 8: 1.4e-2, K=8 vs 16: 2.7e-3, K=16 vs 32: 6.6e-4 (rms 1.1e-5); the large
//   differences sit only at the grazing corner (NdotV, NdotL < 0.05, roughness 1), where the term
//   changes fast with azimuth. Fixed K = 16 was the default until the adaptive rule replaced it; it
//   stays the reference grid of azimuth_nodes() (verify, benchmarks) and --azimuth-intervals 16.
// - Adaptive azimuth (default; BakeSpec::azimuth_*: K 4..32, threshold 1e-4, z = 3). 64^3 default bake,
//   per-row |T_K - T_K/2| at batch 0: its replicate std error is 5e-5..1e-4 (median), so a bare 1e-4
//   threshold on the row max of 64 texels refines on noise (52% of rows went to K = 32: 2.5x slower
//   than fixed 16); with the z = 3 noise allowance rows end at K = 4/8/16/32: 7267/5425/3018/674 of
//   16384 (mean 9.7 nodes vs 17). Accuracy (seed 0 bakes vs `eval --samples 1048576 --seed 7` averaged
//   with K = 64 trapezoid weights; |T32 - T64| of the reference <= 4.5e-5 there): 300 random sampled
//   texels: adaptive max 3.0e-4 rms 9.8e-5, fixed 16 max 3.4e-4 rms 9.2e-5, fixed 32 max 3.3e-4;
//   72 grazing-corner texels (roughness 0.7/1, NdotV, NdotL <= 0.1): adaptive 6.1e-4, fixed 16 6.1e-4;
//   the 12 texels where fixed 16 and fixed 32 differ most (roughness 1, v = 0.99, NdotV, NdotL < 0.05):
//   fixed 16 max 2.6e-3 (rms 2.1e-3, fails 1e-3), adaptive and fixed 32 max 8.8e-4 (adaptive refines
//   those rows to 32). Against fixed 32 on the same points the adaptive bake differs by max 6.5e-4,
//   rms 4.2e-5 (fixed 16: max 2.0e-3, rms 2.6e-5): rows kept at K = 4 average fewer rotated copies of
//   the same points, slightly more noise (rms +7% vs the reference), not a measurable bias.
//   Speed, 64^3 default bake, old fixed-16 binary and this one back to back x3 on the shared 2-core
//   machine (load average 2.4..3.8 from other jobs): wall 24.5/17.3, 23.7/15.4, 24.9/11.9 s (ratio
//   1.4..2.1, median 1.5), CPU (user) 22.9/13.8, 22.2/13.4, 22.6/14.1 s (1.63x, steady): the histogram
//   work falls with the nodes (9.7 vs 17), the per-slice normals pass does not. --azimuth-intervals 16
//   gives the old file bit for bit.
// - Samples: a single batch of 65536 (8 replicates x 8192) per slice. 64^3 bake vs a reference of
//   2^20 samples per node at 1000 random sampled texels: max |error| 7.3e-4, rms 1.1e-4 (K = 8);
//   32768 samples gave max 1.1e-3 at 300 texels, failing the 1e-3 goal. A tolerance is not the
//   default because the 8-replicate std error is itself noisy (+-27%) and would add batches to most
//   slices of the smooth channels without need.
const std::uint32_t kDefaultAzimuthIntervals = 16;
const std::uint64_t kDefaultBatchSamples = 65536;
const double kDefaultTolerance = 0;

namespace {

constexpr double kPi = 3.14159265358979323846;
// NdotV = 0 (the endpoint convention's first slice) has wi on the horizon, where the VNDF sampler and
// eval's input check (wi_z > 0) are undefined; such texels are evaluated at this NdotV instead.
constexpr double kMinNdotV = 1e-4;
// NdotL = 0 (the endpoints convention's first row) is a light exactly on the horizon, where the term
// is 0 by definition, but its limit from above is not (0.50 at v = 0.89 for roughness 1): a row of
// zeros would drag the whole first NdotL interval of a bilinear lookup towards a wrong 0 (measured in
// docs/study.md, section 3). The row stores the limit instead, evaluated at this NdotL.
constexpr double kMinNdotL = 1e-4;

std::uint64_t mix64(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

void check_axis(const LutAxis& a, double lo, double hi) {
    if (a.count < 1 || a.count > 4096)
        throw std::invalid_argument(a.name + " size must be in 1..4096, not " + std::to_string(a.count));
    if (!std::isfinite(a.min) || !std::isfinite(a.max) || a.min < lo || a.max > hi || a.min > a.max)
        throw std::invalid_argument(a.name + " range must satisfy " + std::to_string(lo) + " <= min <= max <= " +
                                    std::to_string(hi));
    if (a.min == a.max && a.count > 1) throw std::invalid_argument(a.name + " range is empty but has several texels");
}

}  // namespace

std::string to_string(LutLayout l) {
    switch (l) {
        case LutLayout::seed_3d: return "seed-3d";
        case LutLayout::seed_2d: return "seed-2d";
        case LutLayout::custom: return "custom";
    }
    return "?";
}

LutLayout parse_lut_layout(const std::string& s) {
    if (s == "seed-3d") return LutLayout::seed_3d;
    if (s == "seed-2d") return LutLayout::seed_2d;
    if (s == "custom") return LutLayout::custom;
    throw std::invalid_argument("layout must be seed-3d, seed-2d or custom, not '" + s + "'");
}

BakeSpec default_bake_spec(LutLayout layout, std::uint32_t size) {
    BakeSpec s;
    s.layout = layout;
    s.visibility.count = s.n_dot_l.count = s.n_dot_v.count = size;
    if (layout == LutLayout::seed_2d) s.n_dot_v = LutAxis{"n_dot_v", 1, 1, 1, TexelConvention::centres};
    return s;
}

void validate(const BakeSpec& s) {
    check_axis(s.visibility, 0, 1);
    check_axis(s.n_dot_l, 0, 1);
    check_axis(s.n_dot_v, 0, 1);
    if (s.visibility.min == s.visibility.max)
        throw std::invalid_argument("visibility range must not be empty (min < max)");
    if (s.visibility.name != "visibility" || s.n_dot_l.name != "n_dot_l" || s.n_dot_v.name != "n_dot_v")
        throw std::invalid_argument("axes must be named visibility, n_dot_l, n_dot_v");
    if (std::uint64_t(s.n_dot_l.count) * s.n_dot_v.count > 1u << 24)
        throw std::invalid_argument("n_dot_l count x n_dot_v count is too large for one image");
    if (s.roughness.empty() || s.roughness.size() > 4)
        throw std::invalid_argument("1 to 4 roughness values are needed (channels R, G, B, A)");
    for (double r : s.roughness)
        if (!std::isfinite(r) || !(r > 0) || r > 1)
            throw std::invalid_argument("roughness must be in (0, 1], not " + std::to_string(r));
    if (!s.azimuth_mean && (!std::isfinite(s.azimuth_degrees) || s.azimuth_degrees < 0 || s.azimuth_degrees > 180))
        throw std::invalid_argument("azimuth must be 'mean' or a number of degrees in [0, 180]");
    if (s.azimuth_intervals > 256) throw std::invalid_argument("azimuth intervals must be in 1..256");
    auto pow2 = [](std::uint32_t k) { return k >= 2 && k <= 256 && (k & (k - 1)) == 0; };
    if (!pow2(s.azimuth_min_intervals) || !pow2(s.azimuth_max_intervals) || s.azimuth_min_intervals > s.azimuth_max_intervals)
        throw std::invalid_argument("adaptive azimuth intervals must be powers of two with 2 <= min <= max <= 256");
    if (!std::isfinite(s.azimuth_refine_threshold) || s.azimuth_refine_threshold < 0 || !std::isfinite(s.azimuth_refine_z) ||
        s.azimuth_refine_z < 0)
        throw std::invalid_argument("azimuth refine threshold and z must be >= 0");
    if (s.replicates < 2 || s.replicates > 1024) throw std::invalid_argument("replicates must be in 2..1024");
    if (s.samples != 0 && (s.samples < 16 || s.samples > (std::uint64_t(1) << 30)))
        throw std::invalid_argument("samples must be in 16..2^30");
    if (!std::isfinite(s.tolerance) || s.tolerance < 0) throw std::invalid_argument("tolerance must be >= 0");
    if (s.tolerance > 0 && s.tolerance < 1e-7) throw std::invalid_argument("tolerance below 1e-7 is below float resolution");
    if (s.max_batches < 1 || s.max_batches > 4096) throw std::invalid_argument("max batches must be in 1..4096");
}

void azimuth_nodes(const BakeSpec& spec, std::vector<double>& degrees, std::vector<double>& weights) {
    degrees.clear();
    weights.clear();
    if (!spec.azimuth_mean) {
        degrees.push_back(spec.azimuth_degrees);
        weights.push_back(1.0);
        return;
    }
    // The term is an even, 360-periodic, smooth function of the relative azimuth, so its mean over
    // [0, 180] by the trapezoid rule (half-weight end points) is the rectangle rule over the full circle,
    // which converges geometrically for smooth periodic integrands.
    const std::uint32_t k = spec.azimuth_intervals ? spec.azimuth_intervals : kDefaultAzimuthIntervals;
    for (std::uint32_t i = 0; i <= k; ++i) {
        degrees.push_back(180.0 * double(i) / double(k));
        weights.push_back((i == 0 || i == k ? 0.5 : 1.0) / double(k));
    }
}

Query texel_query(const BakeSpec& spec, std::uint32_t channel, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv,
                  double azimuth_degrees) {
    Query q;
    q.visibility = spec.visibility.value(iv);
    const double r = spec.roughness.at(channel);
    q.alpha_x = q.alpha_y = r * r;
    const double nv = std::max(spec.n_dot_v.value(ivv), kMinNdotV);
    q.wi = {std::sqrt(std::max(0.0, 1 - nv * nv)), 0, nv};
    const double nl = std::max(spec.n_dot_l.value(il), kMinNdotL);
    const double sl = std::sqrt(std::max(0.0, 1 - nl * nl));
    const double phi = azimuth_degrees * kPi / 180.0;
    q.wo = {sl * std::cos(phi), sl * std::sin(phi), nl};
    return q;
}

float BakeResult::at(std::uint32_t c, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const {
    const std::size_t y = std::size_t(ivv) * n_dot_l_count + il;
    return value.at((y * width + iv) * channels + c);
}

namespace {

// Shared, immutable description of the bake as the workers see it.
struct Plan {
    BakeSpec spec;
    std::uint32_t nv = 0, nl = 0, nvv = 0, channels = 0, replicates = 0, points = 0;
    std::uint64_t batch_samples = 0;
    // Azimuth: a grid of `grid` trapezoid intervals (grid + 1 nodes; grid 0: the one fixed angle). A
    // row uses the nested sub-grid of k intervals (nodes i * grid / k), k from k_start, doubled while
    // the row's |T_k/2 - T_k| exceeds refine_threshold and k < grid (adaptive), or k = grid (fixed).
    std::uint32_t grid = 0, k_start = 0;
    double refine_threshold = 0, refine_z = 0;
    std::vector<double> node_degrees;
    std::vector<float> wo;  // float4 per direction, direction = row * (grid + 1) + node
    ms_bake_slice base{};   // fields common to every slice
    // Texel status per (row, visibility): 0 sampled, 1 exact zero, 2 exact one (same in every slice).
    std::vector<std::uint8_t> status;
};

// Point sets by batch index, generated once and shared by all workers.
class PointSets {
public:
    explicit PointSets(const Plan& plan) : plan_(plan) {}
    std::shared_ptr<const PointSet> get(std::uint32_t batch) {
        std::lock_guard<std::mutex> lock(mutex_);
        auto& slot = sets_[batch];
        if (!slot) {
            SamplingPlan p;
            p.sequence = plan_.spec.sequence;
            p.samples = plan_.batch_samples;
            p.replicates = plan_.replicates;
            // Batch 0 uses the seed itself (the same points as `eval --seed`); later batches derive
            // independent seeds from (seed, batch).
            p.seed = batch == 0 ? plan_.spec.seed : mix64(plan_.spec.seed ^ mix64(0xba7c4ull + batch));
            slot = std::make_shared<PointSet>(make_point_set(p));
        }
        return slot;
    }

private:
    const Plan& plan_;
    std::mutex mutex_;
    std::map<std::uint32_t, std::shared_ptr<const PointSet>> sets_;
};

// Fault injection for tests: MICROSHADOW_FAIL_DEVICE=<index>:<n> makes the worker of the index-th
// selected device throw an ms::ocl::Error when it starts its (n+1)-th chunk.
struct FaultInjection {
    long device = -1;
    long after = 0;
};
FaultInjection fault_injection() {
    FaultInjection f;
    const char* env = std::getenv("MICROSHADOW_FAIL_DEVICE");
    if (!env || !*env) return f;
    const std::string s(env);
    const auto colon = s.find(':');
    try {
        std::size_t used = 0;
        f.device = std::stol(s.substr(0, colon), &used);
        f.after = colon == std::string::npos ? 0 : std::stol(s.substr(colon + 1));
    } catch (const std::exception&) {
        throw std::invalid_argument("MICROSHADOW_FAIL_DEVICE must be <device index>:<chunks>, not '" + s + "'");
    }
    return f;
}

// Local sizes of the bake kernels, fixed instead of left to the runtime (NullRange): given NullRange,
// PoCL 3.1 chose a new local size for every new global size (the adaptive azimuth makes many) and
// compiled a work-group function for each: 84 compilations, +10 s in a cold-cache 64^3 bake (16.9 s
// vs 4.5 s at 4096 samples). 8, 16, 32 measured alike on PoCL (64^3, 65536 samples: 11.9 / - / 11.3 s);
// 32 is also a warp on NVIDIA. Kernels check their range, so the global size is rounded up.
constexpr std::size_t kNormalsLocalSize = 32, kHistogramLocalSize = 32;

// One device's buffers and kernels, reused across the slices it runs.
class SliceRunner {
public:
    SliceRunner(const ocl::DeviceInfo& info, const Plan& plan) : device_(info), plan_(plan) {
        ocl::checked([&] {
            normals_ = device_.kernel("lut_slice/lut_slice.cl", "ms_bake_normals", plan.spec.build);
            histogram_ = device_.kernel("lut_slice/lut_slice.cl", "ms_bake_histogram", plan.spec.build);
            const std::size_t total = std::size_t(plan.points) * plan.replicates;
            normals_local_ = local_size(normals_, kNormalsLocalSize);
            histogram_local_ = local_size(histogram_, kHistogramLocalSize);
            const std::size_t items = round_up(plan.wo.size() / 4 * plan.replicates, histogram_local_);
            wo_ = cl::Buffer(device_.context(), CL_MEM_READ_ONLY, plan.wo.size() * sizeof(float));
            for (auto* b : {&nx_, &ny_, &nz_}) *b = cl::Buffer(device_.context(), CL_MEM_READ_WRITE, total * sizeof(float));
            scratch_ = cl::Buffer(device_.context(), CL_MEM_READ_WRITE,
                                  items * MS_BAKE_SUBHISTOGRAMS * (plan.nv + 2) * sizeof(cl_uint));
            counts_ = cl::Buffer(device_.context(), CL_MEM_WRITE_ONLY, items * (plan.nv + 1) * sizeof(cl_uint));
            return 0;
        });
    }
    const ocl::DeviceInfo& info() const { return device_.info(); }

    // Turns one batch's points into the slice's normals (kept on the device for histogram()).
    void normals(const ms_bake_slice& slice, const PointSet& points, std::uint32_t batch) {
        ocl::checked([&] {
            auto& uploaded = points_[batch];
            if (!uploaded.first()) {
                uploaded.first = cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                            points.u1.size() * sizeof(float), const_cast<float*>(points.u1.data()));
                uploaded.second = cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                                             points.u2.size() * sizeof(float), const_cast<float*>(points.u2.data()));
            }
            normals_.setArg(0, slice);
            normals_.setArg(1, uploaded.first);
            normals_.setArg(2, uploaded.second);
            normals_.setArg(3, nx_);
            normals_.setArg(4, ny_);
            normals_.setArg(5, nz_);
            const std::size_t blocks = std::size_t(plan_.points) / MS_LANES * plan_.replicates;
            device_.queue().enqueueNDRangeKernel(normals_, cl::NullRange, cl::NDRange(round_up(blocks, normals_local_)),
                                                 cl::NDRange(normals_local_));
            return 0;
        });
    }

    // Bins the current normals for the given directions (indices into plan.wo) and adds the counts
    // of direction dirs[d], replicate r to acc[(dirs[d] * R + r) * (nv + 1) ...]. Returns the seconds.
    double histogram(ms_bake_slice slice, const std::vector<std::uint32_t>& dirs, std::vector<std::uint64_t>& acc) {
        const auto start = std::chrono::steady_clock::now();
        const std::size_t R = plan_.replicates, stride = plan_.nv + 1;
        const std::size_t items = dirs.size() * R;
        std::vector<float> wo(dirs.size() * 4);
        for (std::size_t d = 0; d < dirs.size(); ++d)
            std::copy_n(&plan_.wo[std::size_t(dirs[d]) * 4], 4, &wo[d * 4]);
        std::vector<cl_uint> counts(items * stride);
        slice.directions = std::uint32_t(dirs.size());
        ocl::checked([&] {
            device_.queue().enqueueWriteBuffer(wo_, CL_FALSE, 0, wo.size() * sizeof(float), wo.data());
            histogram_.setArg(0, slice);
            histogram_.setArg(1, wo_);
            histogram_.setArg(2, nx_);
            histogram_.setArg(3, ny_);
            histogram_.setArg(4, nz_);
            histogram_.setArg(5, scratch_);
            histogram_.setArg(6, counts_);
            device_.queue().enqueueNDRangeKernel(histogram_, cl::NullRange, cl::NDRange(round_up(items, histogram_local_)),
                                                 cl::NDRange(histogram_local_));
            device_.queue().enqueueReadBuffer(counts_, CL_TRUE, 0, counts.size() * sizeof(cl_uint), counts.data());
            return 0;
        });
        for (std::size_t d = 0; d < dirs.size(); ++d) {
            const cl_uint* from = &counts[d * R * stride];
            std::uint64_t* to = &acc[std::size_t(dirs[d]) * R * stride];
            for (std::size_t i = 0; i < R * stride; ++i) to[i] += from[i];
        }
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

private:
    static std::size_t round_up(std::size_t n, std::size_t multiple) { return (n + multiple - 1) / multiple * multiple; }
    // The wanted local size, or the kernel's limit on this device if that is smaller.
    std::size_t local_size(const cl::Kernel& kernel, std::size_t wanted) const {
        const auto limit = kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device_.info().device);
        return std::max<std::size_t>(1, std::min(wanted, limit));
    }

    ocl::Device device_;
    std::size_t normals_local_ = 1, histogram_local_ = 1;
    const Plan& plan_;
    cl::Kernel normals_, histogram_;
    cl::Buffer wo_, nx_, ny_, nz_, scratch_, counts_;
    std::map<std::uint32_t, std::pair<cl::Buffer, cl::Buffer>> points_;
};

// Node index (in the plan's grid) and trapezoid weight of node i of a row with k intervals; k = 0 is
// the one fixed angle. The weights are azimuth_nodes()'s for k, so a row at k reduces exactly like a
// fixed-k bake.
std::uint32_t row_node(const Plan& plan, std::uint32_t k, std::uint32_t i) { return k ? i * (plan.grid / k) : 0; }
double row_weight(std::uint32_t k, std::uint32_t i) { return k ? (i == 0 || i == k ? 0.5 : 1.0) / double(k) : 1.0; }

// The pooled-ratio trapezoid mean of texel iv of row il over the row's nodes at k intervals.
double row_mean(const Plan& plan, const std::vector<std::uint64_t>& acc, std::uint32_t il, std::uint32_t k, std::uint32_t iv) {
    const std::uint32_t nv = plan.nv, R = plan.replicates;
    const std::size_t stride = nv + 1;
    double value = 0;
    for (std::uint32_t i = 0; i <= k; ++i) {
        const std::size_t item0 = (std::size_t(il) * (plan.grid + 1) + row_node(plan, k, i)) * R;
        std::uint64_t cone = 0, hemi = 0;
        for (std::uint32_t r = 0; r < R; ++r) {
            const std::uint64_t* row = &acc[(item0 + r) * stride];
            cone += row[iv];
            hemi += row[nv];
        }
        if (hemi) value += row_weight(k, i) * (double(cone) / double(hemi));
    }
    return value;
}

// Quadrature check of row il at k intervals (k even; 0 otherwise or without sampled texels): per
// sampled texel d = T_k - T_k/2 (pooled ratios, the same counts) and its std error se_d from the
// replicates (per replicate r the same difference of its own ratios). Returns max |d| over the row;
// `significant` is set when some texel has |d| > threshold + z * se_d, i.e. a difference above the
// threshold that the sampling noise of d does not explain.
double row_quadrature(const Plan& plan, const std::vector<std::uint64_t>& acc, std::uint32_t il, std::uint32_t k,
                      double threshold = 0, double z = 0, bool* significant = nullptr) {
    if (significant) *significant = false;
    if (k < 2 || k % 2) return 0;
    const std::uint32_t nv = plan.nv, R = plan.replicates;
    const std::size_t stride = nv + 1;
    std::vector<double> dr(R);
    double worst = 0;
    for (std::uint32_t iv = 0; iv < nv; ++iv) {
        if (plan.status[std::size_t(il) * nv + iv] != 0) continue;
        const double d = row_mean(plan, acc, il, k, iv) - row_mean(plan, acc, il, k / 2, iv);
        worst = std::max(worst, std::abs(d));
        if (!significant || *significant || std::abs(d) <= threshold) continue;
        std::fill(dr.begin(), dr.end(), 0.0);
        for (std::uint32_t kk : {k, k / 2})
            for (std::uint32_t i = 0; i <= kk; ++i) {
                const double w = (kk == k ? 1.0 : -1.0) * row_weight(kk, i);
                const std::size_t item0 = (std::size_t(il) * (plan.grid + 1) + row_node(plan, kk, i)) * R;
                for (std::uint32_t r = 0; r < R; ++r) {
                    const std::uint64_t* row = &acc[(item0 + r) * stride];
                    dr[r] += w * (row[nv] ? double(row[iv]) / double(row[nv]) : 0.0);
                }
            }
        double mean = 0, ss = 0;
        for (double x : dr) mean += x;
        mean /= R;
        for (double x : dr) ss += (x - mean) * (x - mean);
        const double se = std::sqrt(ss / (double(R) * double(R - 1)));
        if (std::abs(d) > threshold + z * se) *significant = true;
    }
    return worst;
}

// One slice's texels, row-major (il * nv + iv): per slice, not atlas-sized, since a full-LUT buffer
// zeroed per slice cost 2.4 s of page faults in a 64^3 bake (8 MB x 256 slices).
struct SliceValues {
    std::vector<float> value, std_error;
};

// Reduces a slice's accumulated counts into values and std errors of its rows (see the header comment,
// step 3), row il over its k[il] intervals. Returns the largest std error of a sampled texel.
double reduce_slice(const Plan& plan, const std::vector<std::uint64_t>& acc, const std::vector<std::uint32_t>& k,
                    SliceValues& out) {
    const std::uint32_t nv = plan.nv, R = plan.replicates;
    const std::size_t stride = nv + 1;
    std::vector<double> x(R);
    double max_se = 0;
    for (std::uint32_t il = 0; il < plan.nl; ++il) {
        for (std::uint32_t iv = 0; iv < nv; ++iv) {
            const std::size_t at = std::size_t(il) * nv + iv;
            const std::uint8_t status = plan.status[std::size_t(il) * nv + iv];
            if (status != 0) {
                out.value[at] = status == 2 ? 1.0f : 0.0f;
                out.std_error[at] = 0.0f;
                continue;
            }
            double value = 0;
            std::fill(x.begin(), x.end(), 0.0);
            for (std::uint32_t a = 0; a <= k[il]; ++a) {
                const double weight = row_weight(k[il], a);
                const std::size_t item0 = (std::size_t(il) * (plan.grid + 1) + row_node(plan, k[il], a)) * R;
                std::uint64_t cone = 0, hemi = 0;
                for (std::uint32_t r = 0; r < R; ++r) {
                    const std::uint64_t* row = &acc[(item0 + r) * stride];
                    cone += row[iv];
                    hemi += row[nv];
                    // A replicate with no hemisphere sample counts as ratio 0 (the term's definition).
                    x[r] += weight * (row[nv] ? double(row[iv]) / double(row[nv]) : 0.0);
                }
                if (hemi) value += weight * (double(cone) / double(hemi));
            }
            double mean = 0;
            for (double xr : x) mean += xr;
            mean /= R;
            double ss = 0;
            for (double xr : x) ss += (xr - mean) * (xr - mean);
            const double se = std::sqrt(ss / (double(R) * double(R - 1)));
            out.value[at] = float(value);
            out.std_error[at] = float(se);
            max_se = std::max(max_se, se);
        }
    }
    return max_se;
}

Plan make_plan(const BakeSpec& spec) {
    Plan p;
    p.spec = spec;
    p.nv = spec.visibility.count;
    p.nl = spec.n_dot_l.count;
    p.nvv = spec.n_dot_v.count;
    p.channels = std::uint32_t(spec.roughness.size());
    p.replicates = spec.replicates;
    p.batch_samples = round_up_samples(spec.samples ? spec.samples : kDefaultBatchSamples, spec.replicates);
    p.points = std::uint32_t(p.batch_samples / spec.replicates);
    if (!spec.azimuth_mean) {
        p.grid = p.k_start = 0;
    } else if (spec.azimuth_intervals) {
        p.grid = p.k_start = spec.azimuth_intervals;
    } else {
        p.grid = spec.azimuth_max_intervals;
        p.k_start = spec.azimuth_min_intervals;
        p.refine_threshold = spec.azimuth_refine_threshold;
        p.refine_z = spec.azimuth_refine_z;
    }
    if (p.grid == 0) {
        p.node_degrees = {spec.azimuth_mean ? 0.0 : spec.azimuth_degrees};
    } else {
        // As azimuth_nodes(): 180 i / grid; node i * (grid / k) of the grid is bit for bit node i of k.
        for (std::uint32_t i = 0; i <= p.grid; ++i) p.node_degrees.push_back(180.0 * double(i) / double(p.grid));
    }
    for (std::uint32_t il = 0; il < p.nl; ++il)
        for (double deg : p.node_degrees) {
            const Query q = texel_query(spec, 0, 0, il, 0, deg);
            p.wo.insert(p.wo.end(), {float(q.wo.x), float(q.wo.y), float(q.wo.z), 0.0f});
        }
    p.status.resize(std::size_t(p.nl) * p.nv);
    for (std::uint32_t il = 0; il < p.nl; ++il)
        for (std::uint32_t iv = 0; iv < p.nv; ++iv) {
            const double v = spec.visibility.value(iv);
            const double nl = std::max(spec.n_dot_l.value(il), kMinNdotL);
            p.status[std::size_t(il) * p.nv + iv] =
                in_zero_region(cone_cos_theta(v, spec.term.ao_weighting), nl) ? 1 : v == 1.0 ? 2 : 0;
        }
    ms_bake_slice& b = p.base;
    b.vis_min = float(spec.visibility.min);
    const double range = spec.visibility.max - spec.visibility.min;
    // v_j = vis_min + (j + offset) / scale for both conventions (and a lone endpoint texel at min).
    if (spec.visibility.texel == TexelConvention::centres) {
        b.bin_scale = float(p.nv / range);
        b.bin_offset = 0.5f;
    } else {
        b.bin_scale = p.nv > 1 ? float((p.nv - 1) / range) : 1.0f;
        b.bin_offset = 0.0f;
    }
    b.points = p.points;
    b.replicates = p.replicates;
    b.directions = std::uint32_t(p.wo.size() / 4);
    b.texels = p.nv;
    b.ao_weighting = spec.term.ao_weighting == AoWeighting::cosine ? MS_AO_COSINE : MS_AO_UNIFORM;
    return p;
}

}  // namespace

BakeResult bake_lut(const BakeSpec& spec, const BakeCallbacks& callbacks) {
    validate(spec);
    const auto start = std::chrono::steady_clock::now();
    const Plan plan = make_plan(spec);
    const FaultInjection fault = fault_injection();
    const std::vector<ocl::DeviceInfo> infos = ocl::select_devices(spec.device);

    BakeResult result;
    result.width = plan.nv;
    result.height = plan.nl * plan.nvv;
    result.n_dot_l_count = plan.nl;
    result.channels = plan.channels;
    result.texels = std::uint64_t(result.width) * result.height * result.channels;
    result.value.assign(result.texels, 0.0f);
    result.std_error.assign(result.texels, 0.0f);
    result.slices = std::uint64_t(plan.channels) * plan.nvv;
    result.samples_per_batch = plan.batch_samples;
    result.azimuth_nodes = std::uint32_t(plan.node_degrees.size());
    for (std::uint32_t il = 0; il < plan.nl; ++il)
        for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
            const std::uint8_t s = plan.status[std::size_t(il) * plan.nv + iv];
            result.skipped_zero += (s == 1) * std::uint64_t(result.slices);
            result.skipped_one += (s == 2) * std::uint64_t(result.slices);
        }
    for (const auto& d : infos) result.devices.push_back(d.label());
    const bool any_sampled = std::find(plan.status.begin(), plan.status.end(), 0) != plan.status.end();

    PointSets point_sets(plan);
    std::mutex mutex;
    std::condition_variable changed;
    std::deque<std::uint64_t> queue;
    for (std::uint64_t s = 0; s < result.slices; ++s) queue.push_back(s);
    std::size_t done = 0, alive = infos.size();
    std::exception_ptr fatal;
    std::vector<std::string> failures;
    std::atomic<bool> stop{false};
    double max_se = 0, device_seconds = 0, quadrature = 0;
    std::map<std::uint32_t, std::uint64_t> rows_by_intervals;
    std::uint64_t batches = 0, max_batches_used = 0, rerun = 0, updates = 0;
    bool tolerance_met = true;

    auto worker = [&](std::size_t index) {
        std::unique_ptr<SliceRunner> runner;
        long chunks_started = 0;
        for (;;) {
            std::uint64_t slice;
            {
                std::unique_lock<std::mutex> lock(mutex);
                if (stop || queue.empty()) break;
                slice = queue.front();
                queue.pop_front();
            }
            try {
                if (long(index) == fault.device && chunks_started >= fault.after)
                    throw ocl::Error("injected failure (MICROSHADOW_FAIL_DEVICE)", CL_DEVICE_NOT_AVAILABLE);
                ++chunks_started;
                if (!runner && any_sampled) runner = std::make_unique<SliceRunner>(infos[index], plan);
                // Slice order: roughness-major is irrelevant for the result; channel = slice % channels.
                const std::uint32_t channel = std::uint32_t(slice % plan.channels);
                const std::uint32_t ivv = std::uint32_t(slice / plan.channels);
                std::vector<std::uint64_t> acc(std::size_t(plan.wo.size() / 4) * plan.replicates * (plan.nv + 1), 0);
                // Intervals per NdotL row: every row starts at k_start; rows with no sampled texel need
                // no tallies at all (their values come from the exact rule).
                std::vector<std::uint32_t> k(plan.nl, plan.k_start);
                std::vector<std::uint8_t> row_sampled(plan.nl, 0);
                for (std::uint32_t il = 0; il < plan.nl; ++il)
                    for (std::uint32_t iv = 0; iv < plan.nv; ++iv)
                        if (plan.status[std::size_t(il) * plan.nv + iv] == 0) row_sampled[il] = 1;
                // The slice's own texels; merged into the atlas under the lock at the end.
                SliceValues local;
                local.value.assign(std::size_t(plan.nl) * plan.nv, 0.0f);
                local.std_error.assign(local.value.size(), 0.0f);
                double slice_se = 0, seconds = 0, slice_quadrature = 0;
                std::uint64_t slice_updates = 0;
                std::uint32_t batch = 0;
                if (any_sampled) {
                    const Query q = texel_query(spec, channel, 0, 0, ivv, 0);
                    ms_bake_slice params = plan.base;
                    params.alpha_x = params.alpha_y = float(q.alpha_x);
                    params.wi_x = float(q.wi.x), params.wi_y = float(q.wi.y), params.wi_z = float(q.wi.z);
                    auto run = [&](const std::vector<std::uint32_t>& dirs) {
                        if (dirs.empty()) return;
                        seconds += runner->histogram(params, dirs, acc);
                        slice_updates += std::uint64_t(dirs.size()) * plan.batch_samples;
                    };
                    std::vector<std::uint32_t> dirs;
                    for (;;) {
                        throw_if_cancelled();
                        if (stop) return;
                        runner->normals(params, *point_sets.get(batch), batch);
                        // Every row's current nodes (batch 0: the k_start grid).
                        dirs.clear();
                        for (std::uint32_t il = 0; il < plan.nl; ++il)
                            if (row_sampled[il])
                                for (std::uint32_t i = 0; i <= k[il]; ++i)
                                    dirs.push_back(il * (plan.grid + 1) + row_node(plan, k[il], i));
                        run(dirs);
                        // Adaptive azimuth (batch 0 only; later batches keep the rows' nodes): a row whose
                        // |T_k/2 - T_k| exceeds the threshold gets the k new midpoint nodes of 2k.
                        if (batch == 0 && plan.k_start < plan.grid) {
                            std::vector<std::uint8_t> open = row_sampled;
                            for (;;) {
                                dirs.clear();
                                for (std::uint32_t il = 0; il < plan.nl; ++il) {
                                    if (!open[il]) continue;
                                    bool refine = false;
                                    if (k[il] < plan.grid) row_quadrature(plan, acc, il, k[il], plan.refine_threshold, plan.refine_z, &refine);
                                    if (!refine) {
                                        open[il] = 0;
                                        continue;
                                    }
                                    k[il] *= 2;
                                    for (std::uint32_t i = 1; i < k[il]; i += 2)
                                        dirs.push_back(il * (plan.grid + 1) + row_node(plan, k[il], i));
                                }
                                if (dirs.empty()) break;
                                run(dirs);
                            }
                        }
                        ++batch;
                        slice_se = reduce_slice(plan, acc, k, local);
                        if (spec.tolerance <= 0 || slice_se <= spec.tolerance || batch >= spec.max_batches) break;
                    }
                    for (std::uint32_t il = 0; il < plan.nl; ++il)
                        if (row_sampled[il]) slice_quadrature = std::max(slice_quadrature, row_quadrature(plan, acc, il, k[il]));
                } else {
                    reduce_slice(plan, acc, k, local);
                }
                std::lock_guard<std::mutex> lock(mutex);
                for (std::uint32_t il = 0; il < plan.nl; ++il)
                    for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
                        const std::size_t at = ((std::size_t(ivv) * plan.nl + il) * plan.nv + iv) * plan.channels + channel;
                        result.value[at] = local.value[std::size_t(il) * plan.nv + iv];
                        result.std_error[at] = local.std_error[std::size_t(il) * plan.nv + iv];
                    }
                max_se = std::max(max_se, slice_se);
                device_seconds += seconds;
                batches += batch;
                max_batches_used = std::max<std::uint64_t>(max_batches_used, batch);
                updates += slice_updates;
                quadrature = std::max(quadrature, slice_quadrature);
                for (std::uint32_t il = 0; il < plan.nl; ++il)
                    if (row_sampled[il]) ++rows_by_intervals[k[il]];
                if (spec.tolerance > 0 && slice_se > spec.tolerance) tolerance_met = false;
                ++done;
                changed.notify_all();
            } catch (const ocl::Error& e) {
                // The device failed: give the chunk back and retire this worker; the others rerun it.
                std::lock_guard<std::mutex> lock(mutex);
                queue.push_front(slice);
                ++rerun;
                failures.push_back(infos[index].label() + " (device " + std::to_string(index) + "): " + e.what());
                --alive;
                changed.notify_all();
                return;
            } catch (...) {
                std::lock_guard<std::mutex> lock(mutex);
                if (!fatal) fatal = std::current_exception();
                stop = true;
                changed.notify_all();
                return;
            }
        }
    };

    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < infos.size(); ++i) threads.emplace_back(worker, i);
    {
        // The calling thread reports progress, watches for Ctrl-C, and notices when no device is left.
        std::unique_lock<std::mutex> lock(mutex);
        for (;;) {
            if (callbacks.progress) {
                const std::size_t d = done;
                lock.unlock();
                callbacks.progress(d, result.slices);
                lock.lock();
            }
            if (done == result.slices || fatal || alive == 0) break;
            if (cancel_requested()) {
                stop = true;
                break;
            }
            changed.wait_for(lock, std::chrono::milliseconds(100));
        }
        stop = true;
    }
    for (auto& t : threads) t.join();
    if (fatal) std::rethrow_exception(fatal);
    throw_if_cancelled();
    if (done != result.slices) {
        std::string msg = "every selected device failed; " + std::to_string(result.slices - done) + " of " +
                          std::to_string(result.slices) + " slices are missing, nothing was written:";
        for (const auto& f : failures) msg += "\n  " + f;
        throw ocl::Error("bake", CL_DEVICE_NOT_AVAILABLE, msg);
    }
    result.failed_devices = failures;
    result.rerun_chunks = rerun;
    result.max_std_error = max_se;
    result.batches = batches;
    result.max_samples_per_slice = max_batches_used * plan.batch_samples;
    result.tolerance_met = tolerance_met;
    result.device_seconds = device_seconds;
    result.sample_node_rows = updates;
    result.azimuth_quadrature_error = quadrature;
    result.azimuth_rows_by_intervals = rows_by_intervals;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

nlohmann::json bake_metadata(const BakeSpec& spec, const BakeResult& r) {
    nlohmann::json m;
    m["layout"] = to_string(spec.layout);
    if (spec.azimuth_mean) {
        m["azimuth"] = "mean";
        if (spec.azimuth_intervals) {
            m["azimuth_nodes"] = spec.azimuth_intervals + 1;
            m["azimuth_quadrature"] = "trapezoid on [0, 180] degrees";
        } else {
            m["azimuth_nodes"] = r.azimuth_nodes;  // the finest grid a row may use
            m["azimuth_quadrature"] = "adaptive nested trapezoid on [0, 180] degrees, per (slice, NdotL row)";
            m["azimuth_intervals_min"] = spec.azimuth_min_intervals;
            m["azimuth_intervals_max"] = spec.azimuth_max_intervals;
            m["azimuth_refine_threshold"] = spec.azimuth_refine_threshold;
            m["azimuth_refine_z"] = spec.azimuth_refine_z;
            nlohmann::json rows = nlohmann::json::object();
            for (const auto& [k, n] : r.azimuth_rows_by_intervals) rows[std::to_string(k)] = n;
            m["azimuth_rows_by_intervals"] = rows;
        }
        // max over sampled rows of |T_k/2 - T_k| (same points) at the intervals k the row used.
        m["azimuth_quadrature_error"] = r.azimuth_quadrature_error;
    } else {
        m["azimuth"] = spec.azimuth_degrees;
    }
    m["form"] = to_string(spec.term.form);
    m["ao_weighting"] = to_string(spec.term.ao_weighting);
    m["sequence"] = to_string(spec.sequence);
    m["seed"] = spec.seed;
    m["replicates"] = spec.replicates;
    m["samples"] = r.samples_per_batch;  // per batch and slice, all replicates
    m["max_samples_per_slice"] = r.max_samples_per_slice;
    m["batches"] = r.batches;
    m["tolerance"] = spec.tolerance;
    m["tolerance_met"] = r.tolerance_met;
    m["max_error"] = r.max_std_error;
    m["max_error_kind"] = "largest per-texel standard error (replicate spread)";
    m["skipped_zero"] = r.skipped_zero;
    m["skipped_one"] = r.skipped_one;
    m["n_dot_v_clamp_min"] = kMinNdotV;
    m["n_dot_l_clamp_min"] = kMinNdotL;
    m["rerun_chunks"] = r.rerun_chunks;  // chunks rerun after a device failed (the data do not depend on it)
    std::string devices;
    for (std::size_t i = 0; i < r.devices.size(); ++i) devices += (i ? "; " : "") + r.devices[i];
    m["device"] = devices;
    m["fast_math"] = spec.build.fast_math;
    m["version"] = MICROSHADOW_VERSION;
    m["program"] = "microshadow " MICROSHADOW_VERSION;
    m["command_line"] = spec.command_line;
    return m;
}

}  // namespace ms
