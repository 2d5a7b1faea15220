// A tiny run of every benchmark (bench/), so the benchmark code cannot rot, and checks of the cached
// reference data set. No timing is asserted: the smoke sizes measure nothing.
#if __has_include("bench.hpp")  // bench/CMakeLists.txt links the benchmarks into this test binary
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <sstream>

#include "bench.hpp"
#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "device/runtime.hpp"

namespace {

using namespace ms::bench;

ReferenceConfig tiny_reference_config() {
    ReferenceConfig cfg;
    cfg.query_samples = 256;
    cfg.node_samples = 128;
    cfg.replicates = 4;
    cfg.azimuth_intervals = 2;
    cfg.texels = 2;
    cfg.lut_size = 4;
    return cfg;
}

TEST(BenchSmoke, ReferenceRoundTripsThroughItsCsv) {
    std::ostringstream log;
    const auto cfg = tiny_reference_config();
    const auto ref = make_reference(cfg, log);
    ASSERT_EQ(ref.size(), 48u + 2u);
    const auto dir = std::filesystem::temp_directory_path() / ("ms-bench-ref-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    write_reference((dir / "ref.csv").string(), ref, cfg, "test", 0.0);
    const auto back = load_reference((dir / "ref.csv").string());
    std::filesystem::remove_all(dir);
    ASSERT_EQ(back.size(), ref.size());
    for (std::size_t i = 0; i < ref.size(); ++i) {
        EXPECT_EQ(back[i].value, ref[i].value);  // shortest round-trip text: exact
        EXPECT_EQ(back[i].lut_x, ref[i].lut_x);
        EXPECT_GE(ref[i].value, 0.0);
        EXPECT_LE(ref[i].value, 1.0);
    }
}

// The committed data set: loads, covers what it must (isotropic, anisotropic, grazing view and
// light, LUT texels), and its values agree with the OpenCL kernel on independent points within the
// combined error bars (99.9 % Student-t on the kernel's replicates plus the reference's own bound).
TEST(BenchSmoke, CachedReferenceAgreesWithTheKernel) {
    const auto ref = load_reference(default_reference_path());
    bool aniso = false, grazing_v = false, grazing_l = false;
    std::vector<ms::Query> queries;
    std::vector<const RefEntry*> checked;
    for (const auto& e : ref) {
        EXPECT_LT(e.error_bound, 1e-3) << "a reference must be finer than the 1e-3 target it scores";
        aniso |= e.query.alpha_x != e.query.alpha_y;
        grazing_v |= e.query.wi.z < 0.1;
        grazing_l |= e.query.wo.z < 0.1;
        if (e.kind == 0 && queries.size() < 12) queries.push_back(e.query), checked.push_back(&e);
    }
    EXPECT_TRUE(aniso && grazing_v && grazing_l);
    ms::SamplingPlan plan;
    plan.samples = 1 << 16;
    plan.seed = 424242;
    auto backend = ms::make_opencl_backend({ms::ocl::select_devices("default").front()});
    const auto est = ms::evaluate(*backend, queries, ms::TermOptions{}, plan);
    const double t = ms::student_t_quantile(0.999, int(plan.replicates) - 1);
    for (std::size_t i = 0; i < queries.size(); ++i)  // queries only: texels are azimuth means
        EXPECT_LE(std::fabs(est[i].term - checked[i]->value), t * est[i].std_error + checked[i]->error_bound)
                << "reference row " << i;
}

TEST(BenchSmoke, EveryBenchmarkRunsAtATinySize) {
    std::ostringstream log;
    const auto ref = make_reference(tiny_reference_config(), log);
    Options opt;
    opt.smoke = true;
    opt.log = &log;

    const auto bt = run_build_time(opt, "");
    EXPECT_GT(bt.cold_build, 0.0);
    EXPECT_GT(bt.cached_first_launch, 0.0);

    const auto tp = run_throughput(opt, ref);
    EXPECT_TRUE(tp.tallies_agree) << log.str();  // baseline and kernel count the same samples
    for (double rate : {tp.kernel_direct, tp.kernel_evaluate, tp.naive_kernel, tp.oracle_1t, tp.baseline_omp})
        EXPECT_TRUE(std::isfinite(rate) && rate > 0);

    auto points = run_error_vs_time(opt, ref);
    ASSERT_FALSE(points.empty());
    const auto bake = run_bake(opt, ref, &points);
    EXPECT_TRUE(bake.available);
    EXPECT_GT(bake.naive_extrapolated, 0.0);
    for (const auto& p : points) {
        EXPECT_GT(p.seconds, 0.0) << p.method;
        EXPECT_TRUE(std::isfinite(p.max_error) && p.max_error <= 1.0) << p.method;
        EXPECT_LE(p.rms_error, p.max_error + 1e-15) << p.method;
    }
}

}  // namespace
#endif
