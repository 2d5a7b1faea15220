// The irradiance cubemap by direct convolution as an integrand: items are runs of output directions; the
// kernel routine (kernels/irradiance/irradiance.cl) sums, for its direction n, every texel T of a reduced
// source with its exact integral of max(0, n.l) (the texel's vector solid angle W_T = integral_T l dl for
// texels wholly above the horizon, Lambert's formula on the texel clipped by the horizon otherwise), and the
// bound of what the reduction costs (env/irradiance.hpp). Like the prefilter, it sees the source only as
// packed arrays; its oracle worker is a callback the job supplies (the exact convolution of the
// full-resolution source in double, host/env/irradiance.cpp).
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <vector>

#include "device/runtime.hpp"
#include "schedule/batched_integrand.hpp"

namespace ms::irradiance {

struct Target {
    double x = 0, y = 0, z = 1;  // unit direction
};

struct Value {
    std::array<double, 3> irradiance{};  // E(n), not E / pi
    // A bound on |E - E_exact(full-resolution source)|: the reduction's bound plus float rounding.
    std::array<double, 3> error_bound{};
};

// Per texel of the reduced source (face-major, rows, then columns; face size `size`), four floats each:
//   vector:  W_T.x, W_T.y, W_T.z, |W_T| sin(rho_T)  (rho_T: a cap radius around W_T holding the texel)
//   radiance: R, G, B, 0                            (solid-angle-weighted means)
//   spread:  diameter_T * deviation_T (R, G, B), diameter_T
struct Source {
    std::uint32_t size = 0;
    std::vector<float> vector, radiance, spread;
};

struct RoutineConfig {
    ocl::BuildConfig build;
    std::size_t local_size = 32;
};

// The kernel's float rounding, as a multiple of its rounding scale (sum of L_T |n.W_T| over whole texels plus
// L_T diameter_T over clipped ones): float storage of W and L (2 u), the dot product (3 u), compensated
// summation (2 u), and Lambert's formula on a clipped texel, whose five edge terms of size <= diameter_T
// cancel to the result (about 10 u of diameter_T each); u = 2^-24. 32 u leaves a margin of about 2 (the test
// IblIrradianceKernel measures it).
constexpr double kRoundingUnits = 32;

class IrradianceIntegrand final : public schedule::BatchedIntegrand<Target, Value> {
public:
    using CpuEstimate = std::function<Value(const Target&)>;  // thread-safe
    IrradianceIntegrand(const Source& source, std::vector<Target> targets, std::size_t per_item, RoutineConfig config, CpuEstimate oracle);
    std::string name() const override { return "irradiance convolution"; }
    const std::vector<Value>& values() const { return slots(); }

private:
    friend class IrradianceKernelRoutine;
    std::unique_ptr<DeviceRoutine> make_device_routine(ocl::Device& device) override;
    void oracle(const Target& target, Value* value) override { *value = oracle_(target); }
    void check_oracle() const override;
    const Source& source_;
    RoutineConfig config_;
    CpuEstimate oracle_;
};

}  // namespace ms::irradiance
