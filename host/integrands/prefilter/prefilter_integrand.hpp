// The GGX prefilter (split-sum, N = V = R) as an integrand: items are runs of output directions, each
// with its roughness; the kernel routine is kernels/prefilter/prefilter.cl (per-replicate sums, reduced on
// the host with ms::reduce_replicates). The integrand sees the source only as packed arrays, so it needs
// no image types; its "oracle" worker is a callback the job supplies (host/env/prefilter.hpp's scalar
// double estimator on the same points, or the brute-force oracle).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "sampling/point_set.hpp"
#include "schedule/integrand.hpp"

namespace ms::prefilter {

struct Target {
    double x = 0, y = 0, z = 1;  // unit direction
    double roughness = 0.5;      // perceptual, > 0 (alpha = roughness^2)
};

struct Value {
    std::array<double, 3> value{}, std_error{};
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

class PrefilterIntegrand final : public schedule::Integrand {
public:
    using CpuEstimate = std::function<Value(const Target&)>;  // thread-safe
    PrefilterIntegrand(const SourceChain& chain, std::vector<Target> targets, std::size_t per_item, const PointSet& points,
                       RoutineConfig config, CpuEstimate cpu);
    std::string name() const override { return "GGX prefiltering"; }
    std::uint64_t work_items() const override { return (targets_.size() + per_item_ - 1) / per_item_; }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override;
    std::unique_ptr<schedule::Worker> oracle_worker() override;
    const std::vector<Value>& values() const { return values_; }

private:
    friend class PrefilterDeviceWorker;
    friend class PrefilterCpuWorker;
    const SourceChain& chain_;
    std::vector<Target> targets_;
    std::size_t per_item_;
    const PointSet& points_;
    RoutineConfig config_;
    CpuEstimate cpu_;
    std::vector<Value> values_;
};

}  // namespace ms::prefilter
