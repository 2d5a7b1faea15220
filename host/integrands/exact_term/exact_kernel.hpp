// The exact (deterministic) evaluator of the term on an OpenCL device: kernels/exact/exact_term.cl, the
// same algorithm as host/exact/ (boundary integrals over cap arcs, each arc in closed form by partial
// fractions where that form's error bound allows, pole-aware Gauss-Legendre elsewhere), one work-item
// per query or per LUT texel. ExactValue::quadrature_pieces counts the Gauss pieces of the arcs that
// did not take the closed form (for azimuth means: the azimuth pieces).
//
// Precision. With BuildConfig::double_precision (devices with cl_khr_fp64) the kernel runs in double
// and agrees with the C++ evaluator within their error estimates. Without it the kernel runs in float,
// and float rounding, not the quadrature, limits it whatever the tolerance asked. Its error estimate
// then carries float's rounding as first-order bounds (kernels/exact/exact_term.cl): the arc ends'
// rounding amplified by acos near tangency (narrow cones seen at grazing angles, where the ends of the
// view's great circle inside the cone are ill-conditioned) times the integrand there, and the
// integrand's parameters rounded relative to the products they are made of. A float arc takes the
// closed form only where its bound is no larger than what the quadrature reports at its own rounding
// floor: the quartic's coefficients carry float's rounding of the mean of |v|^2 (~1 / alpha^2), against
// |v|^2 >= 1 near the poles, so in practice on rough surfaces only. Checked value by value
// against the C++ evaluator on stress sets (tests/integrands/exact_kernel_test.cpp). Two kinds of
// query float cannot resolve go to the C++ evaluator on the host instead, in double: a hemisphere
// probability that rounds to 0 (views within ~1e-6 of the horizon; the kernel flags them) and
// anisotropy beyond kFloatAnisotropyLimit, where the estimate fell short of the error by up to 2x;
// and texels lit or seen within kFloatNearNormal of the normal.
// Parameters travel as float pairs (~48 bits).
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

// Beyond alpha_x : alpha_y = 1000 : 1 (either way) a float build's queries are computed on the host.
inline constexpr double kFloatAnisotropyLimit = 1000;
// A float build's texels with NdotL or NdotV in (1 - kFloatNearNormal, 1) are computed on the host:
// a texel carries only the cosines, and float's 1 - NdotL^2 resolves the sine to ~6e-8 / (1 - NdotL),
// which moves a narrow cone's term by more than the kernel's estimate (2e-3 at v = 1e-6, NdotL
// 1 - 1e-6). Queries carry the directions' components and need no such rule.
inline constexpr double kFloatNearNormal = 1e-4;

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

    // Values of the last call computed by the C++ evaluator instead (float builds: what float cannot
    // resolve, above), by index.
    const std::vector<std::size_t>& recomputed() const { return unresolved_; }

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
    std::vector<std::size_t> unresolved_;
};

}  // namespace ms::exact
