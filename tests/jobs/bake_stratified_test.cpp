// The azimuth-stratified bake (--azimuth-quadrature stratified). The cell point sets, the
// stratified reduction on synthetic tallies, the kernel against the oracle on the same points, the
// stratified bake against the node bake (a different estimator of the same azimuth mean), determinism
// across devices, the tolerance and double kernels.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstring>
#include <set>
#include <sstream>

#include "cli_runner.hpp"
#include "core/estimate.hpp"
#include "device/runtime.hpp"
#include "integrands/lut_slice/azimuth_quadrature.hpp"
#include "jobs/bake.hpp"
#include "jobs/verify.hpp"
#include "lut/exr_lut.hpp"
#include "sampling/point_set.hpp"

namespace {

using namespace ms;

constexpr double kFamilyAlpha = 1e-3;

double bonferroni_t(std::size_t comparisons, std::uint32_t replicates) {
    return student_t_quantile(1 - kFamilyAlpha / double(std::max<std::size_t>(1, comparisons)), int(replicates) - 1);
}

bool have_device() {
    try {
        return !ocl::select_devices("default").empty();
    } catch (const std::exception&) {
        return false;
    }
}

// ---- point sets ----------------------------------------------------------------------------------

TEST(CellPointSet, EveryCellIsANetAndTheCellsPartitionThePoints) {
    const std::uint32_t n = 1024, R = 4;
    const SamplingPlan plan{Sequence::sobol, std::uint64_t(n) * R, R, 99};
    const PointSet flat = make_point_set(plan);
    for (const std::uint32_t cells : {2u, 16u, 64u}) {
        const PointSet ps = make_cell_point_set(plan, cells);
        ASSERT_EQ(ps.total(), flat.total());
        int k = 0, m = 0;
        while ((1u << k) < cells) ++k;
        while ((1u << m) < n) ++m;
        const int mm = m - k;  // each cell: n / cells = 2^mm points
        for (std::uint32_t r = 0; r < R; ++r) {
            // Same points, reordered: the multiset of (u1, u2) of the replicate is unchanged.
            std::multiset<std::pair<float, float>> a, b;
            for (std::uint32_t i = 0; i < n; ++i) {
                a.insert({flat.u1[r * n + i], flat.u2[r * n + i]});
                b.insert({ps.u1[r * n + i], ps.u2[r * n + i]});
            }
            ASSERT_EQ(a, b);
            for (std::uint32_t c = 0; c < cells; ++c) {
                // A (0, mm, 2)-net in base 2: every elementary box of area 2^-mm holds exactly one point.
                for (int e1 = 0; e1 <= mm; ++e1) {
                    std::set<std::pair<std::uint32_t, std::uint32_t>> boxes;
                    for (std::uint32_t i = c * (n / cells); i < (c + 1) * (n / cells); ++i) {
                        const auto b1 = std::uint32_t(double(ps.u1[r * n + i]) * double(1u << e1));
                        const auto b2 = std::uint32_t(double(ps.u2[r * n + i]) * double(1u << (mm - e1)));
                        boxes.insert({b1, b2});
                    }
                    ASSERT_EQ(boxes.size(), std::size_t(n / cells)) << "cells " << cells << " cell " << c << " split " << e1;
                }
            }
        }
    }
    // Deterministic, and the seed matters.
    const PointSet again = make_cell_point_set(plan, 16);
    EXPECT_EQ(again.u1, make_cell_point_set(plan, 16).u1);
    EXPECT_NE(again.u1, make_cell_point_set({Sequence::sobol, std::uint64_t(n) * R, R, 100}, 16).u1);
    EXPECT_THROW(make_cell_point_set(plan, 3), std::invalid_argument);
    EXPECT_THROW(make_cell_point_set(plan, 128), std::invalid_argument);  // 8 points per cell < 16
    // Random points: the cells are index blocks of the unchanged set.
    const SamplingPlan rp{Sequence::random, 4096, 4, 5};
    EXPECT_EQ(make_cell_point_set(rp, 8).u1, make_point_set(rp).u1);
    EXPECT_EQ(sobol_pascal(1), 0x80000000u);
    EXPECT_EQ(sobol_pascal(2), 0xc0000000u);
    EXPECT_EQ(sobol_pascal(3), 0x40000000u);
}

// ---- the reduction -------------------------------------------------------------------------------

BakeSpec stratified_spec() {
    BakeSpec s = default_bake_spec(LutLayout::custom, 4);
    s.visibility = {"visibility", 0, 1, 5, TexelConvention::endpoints};  // 0 (exact 0) .. 1 (exact 1)
    s.n_dot_l = {"n_dot_l", 0.2, 1, 3, TexelConvention::endpoints};
    s.n_dot_v = {"n_dot_v", 0.3, 1, 2, TexelConvention::endpoints};
    s.roughness = {0.3, 0.8};
    s.azimuth_quadrature = AzimuthQuadrature::stratified;
    s.azimuth_cells = 8;
    s.samples = 4096;
    s.seed = 23;
    s.backend.threads = 2;
    return s;
}

TEST(StratifiedReduction, MeanOfCellRatiosOnSyntheticTallies) {
    BakeSpec spec = stratified_spec();
    const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(spec);
    ASSERT_EQ(plan.cells, 8u);
    ASSERT_EQ(plan.row_directions(), 8u);
    ASSERT_EQ(plan.directions(), std::size_t(plan.nl) * 8);
    for (std::uint32_t c = 0; c < 8; ++c) {
        EXPECT_DOUBLE_EQ(plan.node_degrees[c], 180.0 * (c + 0.5) / 8);
        EXPECT_EQ(plan.wo[c * 4 + 3], float(c));  // the kernel's cell index
    }
    const std::uint32_t R = plan.replicates, nv = plan.nv;
    const std::size_t stride = nv + 1;
    // Synthetic cumulative tallies: cone counts non-decreasing in j and <= the hemisphere count; cell 5 of
    // row 1 has replicates with a zero denominator (a ratio of 0/0 counts as 0).
    lut_slice::SliceTallies acc(plan.tally_size());
    std::uint64_t state = 12345;
    auto next = [&] { return (state = state * 6364136223846793005ull + 1442695040888963407ull) >> 40; };
    for (std::size_t item = 0; item < acc.size() / stride; ++item) {
        double h = double(50 + next() % 200);
        if (item / R == 1 * 8 + 5 && item % 2 == 0) h = 0;
        double running = 0;
        for (std::uint32_t j = 0; j < nv; ++j) {
            running = std::min(h, running + double(next() % 40));
            acc[item * stride + j] = running;
        }
        acc[item * stride + nv] = h;
    }
    lut_slice::SliceValues out;
    out.value.assign(std::size_t(plan.nl) * nv, -1.0f);
    out.std_error.assign(out.value.size(), -1.0f);
    const double max_se = lut_slice::reduce_slice(plan, acc, std::vector<std::uint32_t>(plan.nl, 0), out);
    double seen_max = 0;
    for (std::uint32_t il = 0; il < plan.nl; ++il)
        for (std::uint32_t iv = 0; iv < nv; ++iv) {
            const std::size_t at = std::size_t(il) * nv + iv;
            if (plan.texel(il, iv) != lut_slice::sampled) {
                EXPECT_EQ(out.value[at], plan.texel(il, iv) == lut_slice::exact_one ? 1.0f : 0.0f);
                continue;
            }
            // Independent of reduce_slice's loop: texel_mean (ReplicateRatioMean) and a direct formula.
            const Estimate ref = lut_slice::texel_mean(plan, acc, il, 0, iv);
            double value = 0;
            std::vector<double> x(R, 0.0);
            for (std::uint32_t c = 0; c < 8; ++c) {
                double cs = 0, hs = 0;
                for (std::uint32_t r = 0; r < R; ++r) {
                    const double* row = &acc[((std::size_t(il) * 8 + c) * R + r) * stride];
                    cs += row[iv], hs += row[nv];
                    x[r] += row[nv] > 0 ? row[iv] / row[nv] / 8 : 0.0;
                }
                value += hs > 0 ? cs / hs / 8 : 0.0;
            }
            double mean = 0, ss = 0;
            for (double v : x) mean += v / R;
            for (double v : x) ss += (v - mean) * (v - mean);
            const double se = std::sqrt(ss / (R * (R - 1.0)));
            EXPECT_NEAR(ref.term, value, 1e-12);
            EXPECT_NEAR(ref.std_error, se, 1e-12);
            EXPECT_EQ(out.value[at], float(ref.term)) << il << " " << iv;
            EXPECT_NEAR(out.std_error[at], ref.std_error, 1e-7 * ref.std_error + 1e-12);
            seen_max = std::max(seen_max, ref.std_error);
        }
    EXPECT_NEAR(max_se, seen_max, 1e-12 * seen_max);
    // Too few points for the cells: halved until 16 per cell and replicate (4096 / 8 = 512 -> 32 cells).
    spec.azimuth_cells = 256;
    EXPECT_EQ(effective_azimuth_cells(spec), 32u);
    spec.azimuth_intervals = 8;
    EXPECT_THROW(validate(spec), std::invalid_argument);
}

// ---- the bakes -----------------------------------------------------------------------------------

// Every sampled texel of a and b within the Bonferroni-t bound of their combined std errors; returns max z.
double expect_agree(const BakeSpec& spec, const BakeResult& a, const BakeResult& b, const char* what, double slack = 0) {
    const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(spec);
    std::size_t sampled = 0;
    for (std::size_t i = 0; i < a.value.size(); ++i) sampled += a.std_error[i] > 0;
    EXPECT_GT(sampled, 0u);
    const double t = bonferroni_t(sampled, spec.replicates);
    double worst = 0;
    for (std::size_t i = 0; i < a.value.size(); ++i) {
        const double se = std::sqrt(double(a.std_error[i]) * a.std_error[i] + double(b.std_error[i]) * b.std_error[i]);
        const double diff = std::abs(double(a.value[i]) - b.value[i]);
        if (se > 0) worst = std::max(worst, diff / se);
        EXPECT_LE(diff, t * se + slack + FLT_EPSILON) << what << " texel " << i << ": " << a.value[i] << " +- " << a.std_error[i]
                                                     << " vs " << b.value[i] << " +- " << b.std_error[i];
    }
    std::printf("[stratified] %s: %zu sampled texels, max z %.3g (bound %.3g)\n", what, sampled, worst, t);
    return worst;
}

TEST(StratifiedBake, KernelAgreesWithTheOracleOnTheSamePoints) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    BakeSpec spec = stratified_spec();
    const BakeResult cl = bake_lut(spec);
    EXPECT_EQ(cl.azimuth_cells, 8u);
    spec.backend.kind = schedule::Backend::Kind::oracle;
    const BakeResult oracle = bake_lut(spec);
    ASSERT_EQ(cl.value.size(), oracle.value.size());
    for (std::size_t i = 0; i < cl.value.size(); ++i)
        if (cl.std_error[i] == 0) EXPECT_EQ(cl.value[i], oracle.value[i]) << i;  // exact texels
    // Same points and the same estimator: the counts differ only by samples within float rounding of a
    // cone boundary, so the values agree far inside the error bars.
    const double z = expect_agree(spec, cl, oracle, "opencl vs oracle");
    EXPECT_LT(z, 0.5);
    // --verify (independent points, the oracle at the cells' midpoints) agrees too.
    spec.backend.kind = schedule::Backend::Kind::opencl;
    const BakeVerification v = verify_bake(spec, cl, 16, 4096, 2);
    EXPECT_EQ(v.failed, 0u) << v.worst_texel;
}

TEST(StratifiedBake, AgreesWithTheNodeBakeWithinCombinedErrorBars) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    // Away from the grazing corner, where both quadratures are far below the sampling error.
    BakeSpec nodes = stratified_spec();
    nodes.azimuth_quadrature = AzimuthQuadrature::nodes;
    nodes.azimuth_intervals = 16;
    nodes.samples = 65536;
    BakeSpec strat = stratified_spec();
    strat.azimuth_cells = 16;
    strat.samples = 262144;
    strat.seed = 77;
    const BakeResult a = bake_lut(nodes), b = bake_lut(strat);
    expect_agree(strat, a, b, "nodes K=16 vs stratified 16 cells");
    // Reference texels of bench/data/reference.csv live at 64^3; this layout's texels are its own, so the
    // tie to the previous LUTs is the node bake above (the default of the landed version).
}

class StratifiedBakeCli : public ms::testing::ScratchDirTest {
protected:
    StratifiedBakeCli() : ScratchDirTest("stratified") {}
};

TEST_F(StratifiedBakeCli, DeterministicOverDevicesAndFailoverAndToleranceBounded) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    const std::string args = std::string(MICROSHADOW_CLI) +
                             " bake --layout custom --size 6 --size-n-dot-v 8 --roughness 0.2,0.8 --samples 4096"
                             " --azimuth-quadrature stratified --azimuth-cells 16 -q --out ";
    auto one = ms::testing::run_shell(args + path("one.exr") + " 2>&1");
    ASSERT_EQ(one.exit_code, 0) << one.output;
    auto two = ms::testing::run_shell("POCL_DEVICES='pthread pthread' " + args + path("two.exr") + " --device all 2>&1");
    ASSERT_EQ(two.exit_code, 0) << two.output;
    auto fault = ms::testing::run_shell("POCL_DEVICES='pthread pthread' MICROSHADOW_FAIL_DEVICE=0:0 " + args +
                                        path("fault.exr") + " --device all 2>&1");
    ASSERT_EQ(fault.exit_code, 0) << fault.output;
    const LutFile a = read_lut(path("one.exr")), b = read_lut(path("two.exr")), c = read_lut(path("fault.exr"));
    ASSERT_EQ(a.data.size(), b.data.size());
    EXPECT_EQ(0, std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)));
    EXPECT_EQ(0, std::memcmp(a.data.data(), c.data.data(), a.data.size() * sizeof(float)));
    EXPECT_EQ(a.metadata.at("azimuth_cells"), 16);
    EXPECT_EQ(c.metadata.at("rerun_chunks"), 1);
    auto bad = ms::testing::run_shell(std::string(MICROSHADOW_CLI) + " bake --azimuth-quadrature stratified --azimuth-intervals 8 --out " +
                                      path("bad.exr") + " 2>&1");
    EXPECT_NE(bad.exit_code, 0);

    // Tolerance: batches are added until met; the tallies of a slice stay one fixed-size array.
    BakeSpec spec = stratified_spec();
    spec.tolerance = 1e-3;  // 4096 samples a batch
    const BakeResult r = bake_lut(spec);
    EXPECT_TRUE(r.tolerance_met);
    EXPECT_LE(r.max_std_error, 1e-3);
    EXPECT_GT(r.batches, r.slices);  // some slice needed a second batch
}

TEST(StratifiedBake, DoubleKernelsAgreeWithFloat) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    BakeSpec spec = stratified_spec();
    const BakeResult f = bake_lut(spec);
    spec.build.double_precision = true;
    BakeResult d;
    try {
        d = bake_lut(spec);
    } catch (const std::exception& e) {
        GTEST_SKIP() << "no fp64: " << e.what();
    }
    const double z = expect_agree(spec, f, d, "float vs double kernels");
    EXPECT_LT(z, 0.5);
}

}  // namespace

// The benchmarks are linked into this binary only when they are built (the sanitizer build skips them).
#if __has_include("bench.hpp")
#include "bench.hpp"

namespace {
TEST(StratifiedBenchSmoke, BakeSpeedRunsAtATinySize) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    std::ostringstream log;
    ms::bench::Options opt;
    opt.smoke = true;
    opt.log = &log;
    auto ref = ms::bench::load_reference(ms::bench::default_reference_path());
    const auto r = ms::bench::run_bake_speed(opt, ref);
    EXPECT_EQ(r.curves.rows.size(), 2u);
    EXPECT_NE(r.report.find("target 1"), std::string::npos) << r.report;
}
}  // namespace
#endif
