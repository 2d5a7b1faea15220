// The exact (deterministic) evaluator of the term on an OpenCL device: kernels/exact/exact_term.cl, the
// same algorithm as host/exact/ (boundary integrals over cap arcs, pole-aware Gauss-Legendre), one
// work-item per query or per LUT texel.
//
// Precision. With BuildConfig::double_precision (devices with cl_khr_fp64) the kernel runs in double
// and agrees with the C++ evaluator within their error estimates. Without it the kernel runs in float,
// and float rounding, not the quadrature, limits it whatever the tolerance asked: measured worst cases
// (tests/integrands/exact_kernel_test.cpp, PoCL) 1.6e-5 absolute on stress queries, 1.2e-6 on azimuth means, and
// 2.2e-3 on azimuth means of very narrow cones (v = 1e-6) lit from within 1e-6 of the normal, where
// float's 1 - NdotL^2 keeps only a few digits of sin^2 of the light angle (there the float estimate
// is not a bound either). Parameters travel as float pairs (~48 bits).
#pragma once

#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "exact/exact_term.hpp"

namespace ms::exact {

// One LUT texel of the azimuth mean (exact_azimuth_mean's parameters).
struct ExactTexel {
    double visibility = 1, alpha = 0.5, n_dot_v = 1, n_dot_l = 1;
};

class ExactKernel {
public:
    // Builds both kernels; throws std::invalid_argument for a double build on a device without
    // cl_khr_fp64 and ocl::Error / ocl::BuildError on device failures.
    ExactKernel(ocl::Device& device, const ocl::BuildConfig& build);

    // exact_term of every query (wi, wo need not be normalised; wi above the horizon, alpha > 0, as for
    // the C++ evaluator). `out` is resized to q.size(). Throws ocl::Error on device failure.
    void terms(const std::vector<Query>& q, AoWeighting weighting, double tolerance, std::vector<ExactValue>& out);

    // exact_azimuth_mean of every texel. `out` is resized to texels.size().
    void azimuth_means(const std::vector<ExactTexel>& texels, AoWeighting weighting, double tolerance,
                       std::vector<ExactValue>& out);

    // Values whose subdivision met the kernel's stack bound in the last call (their error estimates carry
    // the pieces' whole magnitude; 0 unless a build lowered MS_EXACT_ARC_STACK / MS_EXACT_AZIMUTH_STACK).
    std::size_t stack_limited() const { return stack_limited_; }

    // Items per kernel launch: bounded by the device's largest buffer and a share of its memory.
    std::size_t batch_size(std::size_t item_bytes) const;

private:
    template <class Item>
    void run(cl::Kernel& kernel, const std::vector<Item>& items, double tolerance, double value_tolerance,
             std::vector<ExactValue>& out);

    ocl::Device& device_;
    ocl::BuildConfig build_;
    cl::Kernel term_kernel_, mean_kernel_;
    std::size_t stack_limited_ = 0;
};

}  // namespace ms::exact
