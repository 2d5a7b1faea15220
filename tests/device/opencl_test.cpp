// The OpenCL kernels against the scalar double oracle, device handling and error reporting.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "oracle/oracle.hpp"
#include "device/runtime.hpp"
#include "test_queries.hpp"
#include "platform/process.hpp"

namespace ms {
namespace {

std::unique_ptr<TermBackend> opencl() { return make_opencl_backend(ocl::select_devices("default")); }

// Bonferroni: the whole comparison fails with probability <= 1e-3 if the estimator is right.
double bound_quantile(std::size_t comparisons, std::uint32_t replicates) {
    return student_t_quantile(1 - 1e-3 / double(comparisons), int(replicates) - 1);
}

void expect_kernel_matches_oracle_on_independent_points(bool anisotropic, unsigned seed) {
    const auto queries = testing::random_queries(60, anisotropic, seed);
    const SamplingPlan plan_cl{Sequence::sobol, 1 << 15, 8, 11};
    const SamplingPlan plan_or{Sequence::sobol, 1 << 15, 8, 12345};  // independent randomisation
    auto cl = opencl();
    auto oracle = make_oracle_backend();
    for (Form form : {Form::height_correlated, Form::uncorrelated})
        for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
            const TermOptions opt{form, ao};
            const auto a = evaluate(*cl, queries, opt, plan_cl);
            const auto b = evaluate(*oracle, queries, opt, plan_or);
            const double k = bound_quantile(queries.size() * 4, plan_cl.replicates);
            for (std::size_t i = 0; i < queries.size(); ++i) {
                const double bound = k * std::hypot(a[i].std_error, b[i].std_error);
                EXPECT_LE(std::abs(a[i].term - b[i].term), bound)
                    << "query " << i << " form " << to_string(form) << " ao " << to_string(ao) << ": opencl "
                    << a[i].term << " +- " << a[i].std_error << ", oracle " << b[i].term << " +- " << b[i].std_error;
            }
        }
}

TEST(OpenClKernel, MatchesOracleOnIsotropicQueries) { expect_kernel_matches_oracle_on_independent_points(false, 1); }
TEST(OpenClKernel, MatchesOracleOnAnisotropicQueries) { expect_kernel_matches_oracle_on_independent_points(true, 2); }

// On the same points, the kernel's pooled ratio and the weighted double oracle's may differ only by
// `flips` samples moved across a boundary by rounding: |difference| <= flips / hemisphere count.
void expect_same_points_agreement(TermBackend& cl, const std::vector<Query>& queries, const TermOptions& opt,
                                  const PointSet& points, double flips) {
    const std::uint32_t R = points.replicates;
    const Tallies counts = cl.tally(queries, opt, points);
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const Estimate a = reduce_replicates(&counts.cone[i * R], &counts.hemisphere[i * R], R);
        const Estimate b = oracle::generic_m_g(queries[i], opt, points);
        double hemisphere = 0;
        for (std::uint32_t r = 0; r < R; ++r) hemisphere += counts.hemisphere[i * R + r];
        ASSERT_GT(hemisphere, 0) << "query " << i;
        EXPECT_LE(std::abs(a.term - b.term), flips / hemisphere) << "query " << i << " form " << to_string(opt.form);
    }
}

TEST(OpenClKernel, MatchesWeightedOracleOnTheSamePoints) {
    // Same points: the float kernel's integer counts and the double oracle's Smith-weighted sums give
    // the same ratio except where float rounding moves a sample across a cone boundary. A sample
    // within ~1e-6 of a boundary is needed for that, so the expected number of such flips among
    // 2^17 samples is below one; we allow 8 flips, i.e. |difference| <= 8 / hemisphere count.
    // This is the test that licenses the kernel's dropping of the weight (generic_term.cl's header).
    const auto queries = testing::random_queries(80, true, 3);
    const SamplingPlan plan{Sequence::sobol, 1 << 17, 8, 5};
    const PointSet points = make_point_set(plan);
    auto cl = opencl();
    for (Form form : {Form::height_correlated, Form::uncorrelated})
        expect_same_points_agreement(*cl, queries, {form, AoWeighting::cosine}, points, 8);
}

TEST(OpenClKernel, DoublePrecisionBuildFollowsTheOracleOnTheSamePoints) {
    // MS_REAL_IS_DOUBLE runs the kernel's algorithm in double: on the same points it must agree with
    // the oracle's weighted double sums to within the odd sample within 1e-11 of a boundary (the
    // polynomial sincos error), i.e. at most a flip or two per query.
    const auto devices = ocl::select_devices("default");
    if (!devices.front().fp64) GTEST_SKIP() << "device has no cl_khr_fp64";
    OpenClBackendConfig config;
    config.build.double_precision = true;
    auto cl = make_opencl_backend(devices, config);
    const auto queries = testing::random_queries(40, true, 8);
    const SamplingPlan plan{Sequence::sobol, 1 << 15, 8, 9};
    const PointSet points = make_point_set(plan);
    expect_same_points_agreement(*cl, queries, {}, points, 2);
}

TEST(OpenClKernel, SameSeedSameBitsAcrossBatchAndWorkGroupSizes) {
    const auto queries = testing::random_queries(50, true, 4);
    const SamplingPlan plan{Sequence::sobol, 1 << 13, 8, 99};
    auto a = evaluate(*opencl(), queries, {}, plan);
    OpenClBackendConfig small_batches;
    small_batches.max_batch_queries = 7;
    auto b = evaluate(*make_opencl_backend(ocl::select_devices("default"), small_batches), queries, {}, plan);
    for (std::size_t i = 0; i < queries.size(); ++i) {
        EXPECT_EQ(std::memcmp(&a[i], &b[i], sizeof(Estimate)), 0) << "query " << i;
    }
    // Work-group sizes: 1, one that divides nothing, and one larger than some batches.
    for (std::size_t local : {1, 7, 256}) {
        OpenClBackendConfig config;
        config.local_size = local;
        auto d = evaluate(*make_opencl_backend(ocl::select_devices("default"), config), queries, {}, plan);
        for (std::size_t i = 0; i < queries.size(); ++i)
            EXPECT_EQ(std::memcmp(&a[i], &d[i], sizeof(Estimate)), 0) << "local size " << local << ", query " << i;
    }
    SamplingPlan other = plan;
    other.seed = 100;
    auto c = evaluate(*opencl(), queries, {}, other);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) differ += a[i].term != c[i].term;
    EXPECT_GT(differ, queries.size() / 2);
}

TEST(OpenClKernel, RandomSequenceAgreesWithNets) {
    const auto queries = testing::random_queries(30, false, 6);
    auto cl = opencl();
    const auto a = evaluate(*cl, queries, {}, {Sequence::random, 1 << 15, 8, 1});
    const auto b = evaluate(*cl, queries, {}, {Sequence::sobol, 1 << 15, 8, 2});
    const double k = bound_quantile(queries.size(), 8);
    for (std::size_t i = 0; i < queries.size(); ++i)
        EXPECT_LE(std::abs(a[i].term - b[i].term), k * std::hypot(a[i].std_error, b[i].std_error)) << i;
}

TEST(OpenClKernel, ExactValuesNeedNoSampling) {
    std::vector<Query> qs(3);
    qs[0].visibility = 1;
    qs[0].wo = testing::direction(0.3, 1.0);
    qs[1].visibility = 0.2;
    qs[1].wo = testing::direction(0.5, 0.0);  // 2 v + NdotL = 0.9 <= 1
    qs[2].visibility = 0.9;
    qs[2].wo = {1, 0, -0.1};  // light below the horizon
    EvalStats stats;
    const auto r = evaluate(*opencl(), qs, {}, {}, &stats);
    EXPECT_EQ(r[0].term, 1.0);
    EXPECT_EQ(r[1].term, 0.0);
    EXPECT_EQ(r[2].term, 0.0);
    EXPECT_EQ(stats.sampled, 0u);
    EXPECT_EQ(stats.exact_zero, 2u);
    EXPECT_EQ(stats.exact_one, 1u);
}

TEST(OpenClRuntime, DeviceSelectionErrorsListTheDevices) {
    EXPECT_FALSE(ocl::enumerate_devices().empty());
    try {
        ocl::select_devices("no-such-device-xyz");
        FAIL() << "expected NoDeviceError";
    } catch (const ocl::NoDeviceError& e) {
        EXPECT_NE(std::string(e.what()).find("0: "), std::string::npos) << e.what();
    }
    EXPECT_THROW(ocl::select_devices("999"), ocl::NoDeviceError);
    EXPECT_EQ(ocl::select_devices("0").size(), 1u);
}

TEST(OpenClRuntime, ErrorsNameTheCallAndTheSymbolicCode) {
    EXPECT_EQ(ocl::error_name(CL_OUT_OF_RESOURCES), "CL_OUT_OF_RESOURCES");
    EXPECT_EQ(ocl::error_name(-12345), "CL_UNKNOWN_ERROR(-12345)");
    const ocl::Error e("clEnqueueNDRangeKernel", CL_INVALID_WORK_GROUP_SIZE);
    EXPECT_NE(std::string(e.what()).find("clEnqueueNDRangeKernel"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("CL_INVALID_WORK_GROUP_SIZE"), std::string::npos);
}

TEST(OpenClRuntime, FailedBuildCarriesTheBuildLog) {
    // The development switch loads kernels from a directory; a broken kernel there must surface
    // as a BuildError with the compiler's log.
    const auto dir = std::filesystem::temp_directory_path() / "microshadow_broken_kernel";
    std::filesystem::create_directories(dir / "common");
    std::filesystem::create_directories(dir / "term");
    for (const auto& name : ocl::preamble_files()) std::ofstream(dir / name) << "\n";
    std::ofstream(dir / "term/generic_term.cl") << "__kernel void f(__global int* x) { x[0] = undefined_symbol; }\n";
    ms::platform::set_environment("MICROSHADOW_KERNEL_DIR", dir.string());
    ocl::Device device(ocl::select_devices("default").front());
    try {
        device.program("term/generic_term.cl", {});
        ms::platform::set_environment("MICROSHADOW_KERNEL_DIR", "");  // empty: the embedded kernels
        FAIL() << "expected BuildError";
    } catch (const ocl::BuildError& e) {
        ms::platform::set_environment("MICROSHADOW_KERNEL_DIR", "");  // empty: the embedded kernels
        EXPECT_NE(e.log().find("undefined_symbol"), std::string::npos) << e.log();
        EXPECT_NE(std::string(e.what()).find("clBuildProgram"), std::string::npos);
    }
    std::filesystem::remove_all(dir);
}

TEST(OpenClRuntime, BuildOptionsAreStrictUnlessAsked) {
    ocl::BuildConfig strict;
    EXPECT_EQ(ocl::build_options(strict).find("fast"), std::string::npos);
    ocl::BuildConfig fast;
    fast.fast_math = true;
    EXPECT_NE(ocl::build_options(fast).find("-cl-fast-relaxed-math"), std::string::npos);
}

}  // namespace
}  // namespace ms
