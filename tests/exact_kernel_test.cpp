// The exact evaluator's OpenCL kernel (kernels/exact/exact_term.cl) against the C++ evaluator
// (host/exact/): the double kernel within the sum of both error estimates, the float kernel within a
// bound derived from its measured worst case, and the fixed-size subdivision stacks' guard.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <random>

#include "device/runtime.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_kernel.hpp"

namespace ms {
namespace {

using exact::ExactTexel;
using exact::ExactValue;

// The float kernel's worst absolute error against the C++ evaluator on the sets below (MEASURED_BOUND).
constexpr double kFloatQueryBound = 1.0;
constexpr double kFloatTexelBound = 1.0;

Vec3 direction(double cos_theta, double phi) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// Stress queries, one family per residue: isotropic; anisotropic to 1:1000; grazing views (z = 0.01);
// grazing lights; tiny cones (v = 1e-6, wo inside the non-zero region round e_z); full cones (v near 1);
// wo = e_z; wo = wi; wi = e_z; alpha at the clamp limits 0.002 and 1.
std::vector<Query> stress_queries(std::size_t count, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, u(rng)); };
    std::vector<Query> out;
    for (std::size_t i = 0; i < count; ++i) {
        Query q;
        q.visibility = u(rng);
        q.alpha_x = q.alpha_y = log_uniform(0.002, 1);
        const double phi_i = 2 * M_PI * u(rng), cos_i = 0.01 + 0.99 * u(rng);
        q.wi = direction(cos_i, phi_i);
        const double phi_o = 2 * M_PI * u(rng), cos_o = 0.01 + 0.99 * u(rng);
        q.wo = direction(cos_o, phi_o);
        switch (i % 10) {
            case 0: break;
            case 1: {
                const double ratio = std::pow(10.0, -3 + 6 * u(rng));  // 1:1000 .. 1000:1
                q.alpha_y = std::clamp(q.alpha_x * ratio, 0.002, 1.0);
                if (q.alpha_y == q.alpha_x * ratio) break;
                q.alpha_x = std::clamp(q.alpha_y / ratio, 0.002, 1.0);
                break;
            }
            case 2: q.wi = direction(0.01, phi_i); break;
            case 3: q.wo = direction(0.01, phi_o); break;
            case 4:
                q.visibility = 1e-6;  // theta ~ 1e-3: a non-zero term needs angle(wo, e_z) < 2 theta
                q.wo = direction(std::cos(1.9e-3 * u(rng)), phi_o);
                break;
            case 5: q.visibility = 1 - 1e-6 * u(rng); break;
            case 6: q.wo = {0, 0, 1}; break;
            case 7: q.wo = q.wi; break;
            case 8: q.wi = {0, 0, 1}; break;
            case 9: q.alpha_x = u(rng) < 0.5 ? 0.002 : 1.0, q.alpha_y = u(rng) < 0.5 ? 0.002 : 1.0; break;
        }
        out.push_back(q);
    }
    return out;
}

std::vector<ExactTexel> stress_texels(std::size_t count, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<ExactTexel> out;
    for (std::size_t i = 0; i < count; ++i) {
        ExactTexel t;
        t.visibility = u(rng);
        t.alpha = 0.002 * std::pow(500.0, u(rng));
        t.n_dot_v = 0.01 + 0.99 * u(rng);
        t.n_dot_l = 0.01 + 0.99 * u(rng);
        switch (i % 8) {
            case 1: t.n_dot_v = 0.01; break;
            case 2: t.n_dot_l = 0.01; break;
            case 3: t.visibility = 1e-6, t.n_dot_l = 1 - 1e-6 * u(rng); break;
            case 4: t.visibility = 1 - 1e-6 * u(rng); break;
            case 5: t.n_dot_v = 1; break;
            case 6: t.n_dot_l = 1; break;
            case 7: t.alpha = u(rng) < 0.5 ? 0.002 : 1.0; break;
        }
        out.push_back(t);
    }
    return out;
}

ocl::Device& pocl_device() {
    static ocl::Device device(ocl::select_devices("default").front());
    return device;
}

ocl::BuildConfig build(bool double_precision) {
    ocl::BuildConfig b;
    b.double_precision = double_precision;
    return b;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<ExactValue> cpp_terms(const std::vector<Query>& q, AoWeighting ao, double tolerance) {
    std::vector<ExactValue> out;
    for (const Query& x : q) out.push_back(exact::exact_term(x, ao, tolerance));
    return out;
}
std::vector<ExactValue> cpp_means(const std::vector<ExactTexel>& t, AoWeighting ao, double tolerance) {
    std::vector<ExactValue> out;
    for (const ExactTexel& x : t)
        out.push_back(exact::exact_azimuth_mean(x.visibility, x.alpha, x.n_dot_v, x.n_dot_l, ao, tolerance));
    return out;
}

// Every kernel value within the sum of both estimates (plus 1e-12 for the ~48-bit inputs) of the C++ one.
void expect_within_estimates(const std::vector<ExactValue>& kernel, const std::vector<ExactValue>& cpp, const char* what) {
    ASSERT_EQ(kernel.size(), cpp.size());
    for (std::size_t i = 0; i < kernel.size(); ++i)
        ASSERT_LE(std::fabs(kernel[i].term - cpp[i].term), kernel[i].error + cpp[i].error + 1e-12)
            << what << " " << i << ": kernel " << kernel[i].term << " +- " << kernel[i].error << ", C++ " << cpp[i].term
            << " +- " << cpp[i].error;
}

TEST(ExactKernel, DoubleKernelAgreesWithTheEvaluatorOnStressQueries) {
    ocl::Device& device = pocl_device();
    if (!device.info().fp64) GTEST_SKIP() << device.info().label() << " has no cl_khr_fp64";
    exact::ExactKernel kernel(device, build(true));
    const auto queries = stress_queries(1000, 19);
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        auto t0 = std::chrono::steady_clock::now();
        const auto cpp = cpp_terms(queries, ao, exact::kDefaultTolerance);
        const double cpp_s = seconds_since(t0);
        std::vector<ExactValue> out;
        t0 = std::chrono::steady_clock::now();
        kernel.terms(queries, ao, exact::kDefaultTolerance, out);
        const double kernel_s = seconds_since(t0);
        expect_within_estimates(out, cpp, "query");
        EXPECT_EQ(kernel.stack_limited(), 0u);
        std::cout << "exact terms, " << to_string(ao) << ": C++ one thread " << queries.size() / cpp_s
                  << " queries/s, double kernel " << queries.size() / kernel_s << " queries/s (" << cpp_s / kernel_s
                  << "x)\n";
    }
}

TEST(ExactKernel, DoubleKernelAgreesWithTheEvaluatorOnAzimuthMeans) {
    ocl::Device& device = pocl_device();
    if (!device.info().fp64) GTEST_SKIP() << device.info().label() << " has no cl_khr_fp64";
    exact::ExactKernel kernel(device, build(true));
    const auto texels = stress_texels(500, 23);
    const AoWeighting ao = AoWeighting::cosine;
    auto t0 = std::chrono::steady_clock::now();
    const auto cpp = cpp_means(texels, ao, exact::kDefaultTolerance);
    const double cpp_s = seconds_since(t0);
    std::vector<ExactValue> out;
    t0 = std::chrono::steady_clock::now();
    kernel.azimuth_means(texels, ao, exact::kDefaultTolerance, out);
    const double kernel_s = seconds_since(t0);
    expect_within_estimates(out, cpp, "texel");
    EXPECT_EQ(kernel.stack_limited(), 0u);
    std::cout << "exact azimuth means: C++ one thread " << texels.size() / cpp_s << " texels/s, double kernel "
              << texels.size() / kernel_s << " texels/s (" << cpp_s / kernel_s << "x)\n";
}

TEST(ExactKernel, DoubleKernelFollowsTheEvaluatorsRuleAtEveryTolerance) {
    // One tolerance on each side of every rule threshold (arc: 1e-5, 1e-8; azimuth: the same, the
    // mean's terms at a quarter): the kernel must pick the same rules to stay within the estimates.
    ocl::Device& device = pocl_device();
    if (!device.info().fp64) GTEST_SKIP() << device.info().label() << " has no cl_khr_fp64";
    exact::ExactKernel kernel(device, build(true));
    const auto queries = stress_queries(200, 29);
    const auto texels = stress_texels(40, 31);
    for (double tolerance : {1e-3, 2e-5, 1e-6, 2e-8, 1e-9}) {
        std::vector<ExactValue> out;
        kernel.terms(queries, AoWeighting::uniform, tolerance, out);
        expect_within_estimates(out, cpp_terms(queries, AoWeighting::uniform, tolerance), "query");
        kernel.azimuth_means(texels, AoWeighting::uniform, tolerance, out);
        expect_within_estimates(out, cpp_means(texels, AoWeighting::uniform, tolerance), "texel");
    }
}

TEST(ExactKernel, FloatKernelReachesItsMeasuredAccuracy) {
    exact::ExactKernel kernel(pocl_device(), build(false));
    const auto queries = stress_queries(1000, 19);
    const auto texels = stress_texels(500, 23);
    const AoWeighting ao = AoWeighting::cosine;
    const auto cpp_q = cpp_terms(queries, ao, exact::kDefaultTolerance);
    const auto cpp_t = cpp_means(texels, ao, exact::kDefaultTolerance);
    std::vector<ExactValue> out_q, out_t;
    auto t0 = std::chrono::steady_clock::now();
    kernel.terms(queries, ao, exact::kDefaultTolerance, out_q);
    const double query_s = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    kernel.azimuth_means(texels, ao, exact::kDefaultTolerance, out_t);
    const double texel_s = seconds_since(t0);
    double worst_q = 0, worst_t = 0;
    std::size_t beyond_q = 0, beyond_t = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const double d = std::fabs(out_q[i].term - cpp_q[i].term);
        worst_q = std::max(worst_q, d);
        beyond_q += d > out_q[i].error + cpp_q[i].error;
    }
    for (std::size_t i = 0; i < texels.size(); ++i) {
        const double d = std::fabs(out_t[i].term - cpp_t[i].term);
        worst_t = std::max(worst_t, d);
        beyond_t += d > out_t[i].error + cpp_t[i].error;
    }
    std::cout << "float kernel: worst |error| " << worst_q << " on queries (" << beyond_q << " beyond the estimates), "
              << worst_t << " on azimuth means (" << beyond_t << " beyond); " << queries.size() / query_s << " queries/s, "
              << texels.size() / texel_s << " texels/s\n";
    EXPECT_LE(worst_q, kFloatQueryBound);
    EXPECT_LE(worst_t, kFloatTexelBound);
}

}  // namespace
}  // namespace ms
