// One (roughness, NdotV) slice of a LUT as a work item: every NdotL row and visibility texel of the slice
// from one VNDF pass per batch (kernels/lut_slice/lut_slice.cl derives the histogram), with the adaptive
// azimuth quadrature and the tolerance-driven batches of azimuth_quadrature.hpp. The kernel routine runs
// on a device; the oracle computes the same tallies texel by texel with the scalar double oracle
// (small layouts: it does nv times the work).
//
// Per slice: batch 0 tallies every sampled row at its k_start nodes, then doubles k for the rows whose
// quadrature check is significant (new midpoint nodes only, same points) until none is; later batches
// (with a tolerance) reuse each row's final k, on new independent points, until the slice's largest
// std error is <= tolerance. A row that stops at k is bit for bit the fixed-k bake's row.
// Determinism: every count comes from (spec, slice, batch) alone and each slice is reduced in a fixed
// order, so the atlas is bit-identical whatever the places, their number or their failures.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "integrands/lut_slice/azimuth_quadrature.hpp"
#include "sampling/point_set.hpp"
#include "schedule/integrand.hpp"

namespace ms::lut_slice {

// Tallies one slice on one place. begin_batch() makes the slice's normals for a batch's points;
// add_counts() adds the counts of the given directions (indices into plan.wo) to acc.
class SliceTallier {
public:
    virtual ~SliceTallier() = default;
    virtual void begin_batch(std::uint32_t channel, std::uint32_t ivv, const PointSet& points) = 0;
    virtual void add_counts(const std::vector<std::uint32_t>& directions, SliceTallies& acc) = 0;
};

// What one slice produced (besides its texels).
struct SliceReport {
    double max_std_error = 0;
    double quadrature_error = 0;  // max over sampled rows of |T_k - T_k/2| at the row's final k
    std::uint32_t batches = 0;
    std::uint64_t histogram_updates = 0;  // samples x directions binned
    double device_seconds = 0;
    // Where the slice's wall time went (a breakdown for the benchmarks): begin_batch (point set, upload,
    // normals kernel, waited for), add_counts (histogram kernel and read-back), reduce_slice on the host.
    double normals_seconds = 0, histogram_seconds = 0, reduce_seconds = 0;
    std::vector<int> row_intervals;  // final k per row (-1 for rows without sampled texels)
    bool done = false;
};

// What a bake will allocate, before it allocates it: the host's share (the atlas and, per place, a
// slice's tallies and a point set) and each device buffer of the kernel routine, so a bake that cannot
// run is refused with the figures instead of failing with bad_alloc or CL_INVALID_BUFFER_SIZE.
struct MemoryEstimate {
    std::uint64_t host_bytes = 0;
    std::vector<std::pair<std::string, std::uint64_t>> device_buffers;  // per device
    std::uint64_t device_bytes() const;
};
MemoryEstimate memory_estimate(const SlicePlan& plan, std::size_t places);

class LutSliceIntegrand final : public schedule::Integrand {
public:
    explicit LutSliceIntegrand(const LutSliceSpec& spec);
    std::string name() const override { return "the LUT slices"; }
    std::uint64_t work_items() const override { return plan_.slices(); }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override;
    std::unique_ptr<schedule::Worker> oracle_worker() override;
    // A slice's texels (value, std error, row by row) and its report.
    bool distributable() const override { return true; }
    std::string save_item(std::uint64_t id) const override;
    void load_item(std::uint64_t id, const std::string& bytes) override;
    std::string check_item(std::uint64_t id, const std::string& bytes) const override;

    const SlicePlan& plan() const { return plan_; }
    // In the atlas layout of grid/atlas.hpp (plan().atlas()).
    const std::vector<float>& values() const { return value_; }
    const std::vector<float>& std_errors() const { return std_error_; }
    const std::vector<SliceReport>& reports() const { return reports_; }

    // Runs slice `id` on a tallier (the workers call this; null when no texel is sampled).
    void run_slice(std::uint64_t id, SliceTallier* tallier);

private:
    std::shared_ptr<const PointSet> batch_points(std::uint32_t batch) const;
    SlicePlan plan_;
    bool any_sampled_ = false;
    std::vector<float> value_, std_error_;
    std::vector<SliceReport> reports_;
};

}  // namespace ms::lut_slice
