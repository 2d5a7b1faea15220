// The GGX prefilter (split-sum, N = V = R) as an integrand: items are runs of output directions, each
// with its roughness; the kernel routine is kernels/prefilter/prefilter.cl. Each target's result is its
// per-replicate tallies on the integrand's point set, sums()[(k R + r) 4 + c]: c < 3 the numerators
// sum L_c (n.l), c = 3 the denominator sum (n.l), so a job can add rounds of samples on independent point
// sets replicate by replicate and reduce them with ms::reduce_replicates when it likes. The integrand sees
// the source only as packed arrays, so it needs no image types; its "oracle" worker is a callback the job
// supplies (host/env/prefilter.hpp's scalar double estimator on the same points).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "sampling/point_set.hpp"
#include "schedule/batched_integrand.hpp"

namespace ms::prefilter {

struct Target {
    double x = 0, y = 0, z = 1;  // unit direction
    double roughness = 0.5;      // perceptual, > 0 (alpha = roughness^2)
};

struct SourceChain {
    std::vector<float> rgb;             // level-major, each level face-major, rows, RGB texels
    std::vector<std::uint32_t> offset;  // texel offset of each level
    std::uint32_t size0 = 0;            // level 0 face size
};

struct RoutineConfig {
    ocl::BuildConfig build;
    std::size_t local_size = 32;
    bool filtered = true;
    double lod_bias = 0.0;
};

// Slots: per target, its 4 R tallies (double).
class PrefilterIntegrand final : public schedule::BatchedIntegrand<Target, double> {
public:
    // Adds one target's tallies on `points` into sums[4 R] (zeroed by the caller); thread-safe.
    using CpuSums = std::function<void(const Target&, const PointSet& points, double* sums)>;
    PrefilterIntegrand(const SourceChain& chain, std::vector<Target> targets, std::size_t per_item, const PointSet& points,
                       RoutineConfig config, CpuSums cpu);
    std::string name() const override { return "GGX prefiltering"; }
    std::uint32_t replicates() const { return points_.replicates; }
    const std::vector<double>& sums() const { return slots(); }  // [(k R + r) 4 + c]

private:
    friend class PrefilterKernelRoutine;
    std::unique_ptr<DeviceRoutine> make_device_routine(ocl::Device& device) override;
    void oracle(const Target& target, double* sums) override { cpu_(target, points_, sums); }
    void check_oracle() const override;
    const SourceChain& chain_;
    const PointSet& points_;
    RoutineConfig config_;
    CpuSums cpu_;
};

}  // namespace ms::prefilter
