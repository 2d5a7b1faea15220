// The split-sum DFG integrals (scale, bias, and their sum, the single-scattering albedo E that the
// multiple-scattering energy compensation needs) as an integrand: items are runs of (NdotV, alpha)
// points; the kernel routine is kernels/dfg/dfg.cl (VNDF sampling, per-replicate sums reduced on the
// host in double, error bars from the replicates), the oracle dfg_quadrature.hpp (deterministic, its
// error estimate from two orders).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "sampling/point_set.hpp"
#include "schedule/batched_integrand.hpp"

namespace ms::dfg {

struct DfgPoint {
    double n_dot_v = 1;  // in (0, 1]
    double alpha = 0.25; // GGX alpha = roughness^2, in (0, 1]
};

// One point's values. std_error: the replicate standard error (device, a Student-t quantity with R - 1
// degrees of freedom) or the quadrature's error estimate (oracle).
struct DfgValue {
    Estimate scale, bias, albedo;  // albedo = scale + bias (E with F = 1)
    Estimate sheen;                // the cloth (Charlie) albedo; 0 where it was not asked for
};

// Which host rule the oracle worker (host threads) evaluates: the independent quadrature of
// dfg_quadrature.hpp (the check), or the exact path of exact/dfg_exact.hpp (`ibl dfg --method exact`).
enum class DfgHostRule { quadrature, exact };

struct DfgRoutineConfig {
    ocl::BuildConfig build;
    std::size_t local_size = 32;
    std::uint32_t max_points_per_work_item = 4096;  // bounds each lane's float sum (256 terms)
    int quadrature_order = 12;
    int warp = 3;  // MS_DFG_WARP of kernels/dfg/dfg.cl: 1 (none), 2 or 3
    DfgHostRule host_rule = DfgHostRule::quadrature;
    int exact_order = 16;  // Gauss-Legendre nodes per panel of the exact path
    bool sheen = false;    // host rules: also the cloth channel (the kernel computes GGX only)
};

class DfgIntegrand final : public schedule::BatchedIntegrand<DfgPoint, DfgValue> {
public:
    // points_per_item: how many points one work item holds (a LUT row).
    DfgIntegrand(std::vector<DfgPoint> points, std::size_t points_per_item, const SamplingPlan& plan,
                 DfgRoutineConfig config = {});
    std::string name() const override { return "the split-sum DFG integrals"; }

    const std::vector<DfgPoint>& points() const { return targets(); }
    const std::vector<DfgValue>& values() const { return slots(); }
    std::vector<DfgValue> take_values() { return take_slots(); }
    const SamplingPlan& plan() const { return plan_; }
    std::size_t points_per_item() const { return per_item(); }

private:
    friend class DfgKernelRoutine;
    std::unique_ptr<DeviceRoutine> make_device_routine(ocl::Device& device) override;
    void oracle(const DfgPoint& p, DfgValue* v) override;
    const PointSet& point_set();
    SamplingPlan plan_;
    DfgRoutineConfig config_;
    std::shared_ptr<const PointSet> point_set_;
    std::mutex mutex_;
};

// Checks a point (NdotV in (0, 1], alpha in (0, 1]); throws std::invalid_argument.
void validate(const DfgPoint& p);

}  // namespace ms::dfg
