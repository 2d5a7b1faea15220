// LUT bakes: layout and orientation against single-query evaluate(), exact skipped texels, metadata,
// half vs float, texel conventions, device-count independence, fault injection and atomic output.
#include <gtest/gtest.h>

#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>

#include "jobs/bake.hpp"
#include "cli_runner.hpp"
#include "opencl_platform.hpp"
#include "jobs/verify.hpp"
#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "lut/exr_lut.hpp"
#include "lut/preview.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

RunResult run(const std::string& env, const std::string& args) {
    const std::string cmd = env + " " + std::string(MICROSHADOW_CLI) + " " + args + " 2>&1";
    return run_shell(cmd);
}

class BakeTest : public ScratchDirTest {
protected:
    BakeTest() : ScratchDirTest("bake") {}
};

// A small 3D LUT with every axis and channel distinguishable: 6 visibilities, 5 NdotL, 3 NdotV, 4 roughness.
BakeSpec small_spec() {
    BakeSpec s = default_bake_spec(LutLayout::custom, 4);
    s.visibility.count = 6;
    s.n_dot_l.count = 5;
    s.n_dot_v.count = 3;
    s.samples = 8192;
    s.azimuth_intervals = 2;
    s.seed = 11;
    return s;
}

void write(const std::string& file, const BakeSpec& spec, const BakeResult& r, bool half = false) {
    std::vector<LutChannel> ch;
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < spec.roughness.size(); ++c)
        ch.push_back({names[c], spec.roughness[c], spec.roughness[c] * spec.roughness[c], spec.roughness[c] * spec.roughness[c]});
    write_lut(file, {spec.visibility, spec.n_dot_l, spec.n_dot_v}, ch, r.value, bake_metadata(spec, r), half);
}

TEST(BakeSpecTest, TexelConventionsAndValidation) {
    LutAxis a{"visibility", 0, 1, 4, TexelConvention::centres};
    EXPECT_DOUBLE_EQ(a.value(0), 0.125);
    EXPECT_DOUBLE_EQ(a.value(3), 0.875);
    a.texel = TexelConvention::endpoints;
    EXPECT_DOUBLE_EQ(a.value(0), 0.0);
    EXPECT_DOUBLE_EQ(a.value(1), 1.0 / 3.0);
    EXPECT_EQ(a.value(3), 1.0);
    BakeSpec s = default_bake_spec(LutLayout::seed_3d, 8);
    EXPECT_NO_THROW(validate(s));
    s.roughness = {0.5, 1.5};
    EXPECT_THROW(validate(s), std::invalid_argument);
    s = default_bake_spec(LutLayout::seed_3d, 8);
    s.n_dot_l.count = 5000;
    EXPECT_THROW(validate(s), std::invalid_argument);
    s = default_bake_spec(LutLayout::seed_2d, 8);
    EXPECT_EQ(s.n_dot_v.count, 1u);
    EXPECT_EQ(s.n_dot_v.value(0), 1.0);
    std::vector<double> deg, w;
    s.azimuth_intervals = 4;
    azimuth_nodes(s, deg, w);
    ASSERT_EQ(deg.size(), 5u);
    EXPECT_EQ(deg.back(), 180.0);
    EXPECT_DOUBLE_EQ(w[0], 0.125);
    EXPECT_DOUBLE_EQ(w[0] + w[1] + w[2] + w[3] + w[4], 1.0);
}

// The file read back agrees with eval's estimator at the corners of the atlas (first and last
// visibility, NdotL row and NdotV slice) for every channel, within the combined error bars.
TEST_F(BakeTest, FileMatchesSingleQueryEvaluationAtCornersForEveryRoughness) {
    for (const bool mean : {false, true}) {
        BakeSpec spec = small_spec();
        spec.azimuth_mean = mean;
        spec.azimuth_degrees = 60;
        const BakeResult result = bake_lut(spec);
        write(path("lut.exr"), spec, result);
        const LutFile lut = read_lut(path("lut.exr"));
        ASSERT_EQ(lut.width, 6u);
        ASSERT_EQ(lut.height, 15u);
        ASSERT_EQ(lut.channels.size(), 4u);

        std::vector<double> deg, w;
        azimuth_nodes(spec, deg, w);
        struct Texel {
            std::uint32_t c, iv, il, ivv;
        };
        std::vector<Texel> texels;
        for (std::uint32_t c = 0; c < 4; ++c)
            for (std::uint32_t il : {0u, 4u})
                for (std::uint32_t ivv : {0u, 2u})
                    for (std::uint32_t iv : {2u, 5u}) texels.push_back({c, iv, il, ivv});
        std::vector<Query> queries;
        for (const auto& t : texels)
            for (double d : deg) queries.push_back(texel_query(spec, t.c, t.iv, t.il, t.ivv, d));
        SamplingPlan plan;
        plan.samples = 8192;
        plan.seed = 977;  // independent of the bake's points
        auto backend = make_opencl_backend(ocl::select_devices("default"));
        const auto est = evaluate(*backend, queries, spec.term, plan);
        // Bonferroni over the texels: the test fails by chance with probability <= 0.001.
        const double t_q = student_t_quantile(1 - 0.001 / double(texels.size()), int(plan.replicates) - 1);
        std::size_t sampled = 0;
        for (std::size_t i = 0; i < texels.size(); ++i) {
            const Texel& t = texels[i];
            double ref = 0, ref_se = 0;
            for (std::size_t a = 0; a < deg.size(); ++a) {
                ref += w[a] * est[i * deg.size() + a].term;
                ref_se += w[a] * est[i * deg.size() + a].std_error;  // an upper bound whatever the correlation
            }
            const std::size_t y = std::size_t(t.ivv) * 5 + t.il;
            const float stored = lut.data[(y * 6 + t.iv) * 4 + t.c];
            EXPECT_EQ(stored, lut.at(t.c, t.iv, t.il, t.ivv));
            const double se = result.std_error[(y * 6 + t.iv) * 4 + t.c];
            if (se > 0) ++sampled;
            EXPECT_LE(std::abs(stored - ref), t_q * std::sqrt(se * se + ref_se * ref_se) + 1e-6)
                << "mean " << mean << " channel " << t.c << " v " << t.iv << " l " << t.il << " nv " << t.ivv;
        }
        EXPECT_GT(sampled, texels.size() / 2);  // the comparison is not only on exact texels
        // Orientation: within a row the term grows with visibility (left to right); down a slice
        // (NdotL increasing) it grows too, for the smoothest channel.
        EXPECT_LT(lut.at(3, 2, 4, 1), lut.at(3, 4, 4, 1));
        EXPECT_LT(lut.at(3, 4, 1, 1), lut.at(3, 4, 4, 1));
    }
}

TEST_F(BakeTest, SkippedTexelsAreExactAndCounted) {
    BakeSpec spec = small_spec();
    spec.visibility.texel = spec.n_dot_l.texel = spec.n_dot_v.texel = TexelConvention::endpoints;
    spec.samples = 2048;
    const BakeResult r = bake_lut(spec);
    std::uint64_t zeros = 0, ones = 0;
    for (std::uint32_t ivv = 0; ivv < 3; ++ivv)
        for (std::uint32_t il = 0; il < 5; ++il)
            for (std::uint32_t iv = 0; iv < 6; ++iv)
                for (std::uint32_t c = 0; c < 4; ++c) {
                    // The NdotL = 0 row stores the term's limit from above (bake.cpp's kMinNdotL),
                    // so only part 2's early-out for cosine AO is exact 0 there.
                    const double v = spec.visibility.value(iv), nl = std::max(spec.n_dot_l.value(il), 1e-4);
                    if (2 * v + nl <= 1) {
                        EXPECT_EQ(r.at(c, iv, il, ivv), 0.0f);
                        ++zeros;
                    } else if (v == 1.0) {
                        EXPECT_EQ(r.at(c, iv, il, ivv), 1.0f);
                        ++ones;
                    } else {
                        // Sampled: may be 0 or 1 for the smoothest surface (the term tends to a step),
                        // strictly inside for the roughest, and always within [0, 1].
                        EXPECT_GE(r.at(c, iv, il, ivv), 0.0f);
                        EXPECT_LE(r.at(c, iv, il, ivv), 1.0f);
                        if (c == 3) EXPECT_GT(r.at(c, iv, il, ivv), 0.0f) << iv << " " << il << " " << ivv;
                    }
                }
    EXPECT_EQ(r.skipped_zero, zeros);
    EXPECT_EQ(r.skipped_one, ones);
    EXPECT_GT(zeros, 0u);
    EXPECT_GT(ones, 0u);
}

TEST_F(BakeTest, AttributesHalfAndPreview) {
    BakeSpec spec = small_spec();
    spec.roughness = {0.3, 0.9};
    spec.samples = 2048;
    spec.command_line = "microshadow bake --test";
    const BakeResult r = bake_lut(spec);
    write(path("f.exr"), spec, r, false);
    write(path("h.exr"), spec, r, true);
    const LutFile f = read_lut(path("f.exr")), h = read_lut(path("h.exr"));
    EXPECT_FALSE(f.half);
    EXPECT_TRUE(h.half);
    ASSERT_EQ(f.channels.size(), 2u);
    EXPECT_EQ(f.channels[1].name, "G");
    EXPECT_DOUBLE_EQ(f.channels[1].roughness, 0.9);
    EXPECT_DOUBLE_EQ(f.channels[1].alpha_x, 0.81);
    EXPECT_EQ(f.metadata.at("layout"), "custom");
    EXPECT_EQ(f.metadata.at("azimuth"), "mean");
    EXPECT_EQ(f.metadata.at("form"), "height-correlated");
    EXPECT_EQ(f.metadata.at("ao_weighting"), "cosine");
    EXPECT_EQ(f.metadata.at("sequence"), "sobol");
    EXPECT_EQ(f.metadata.at("seed"), 11);
    EXPECT_EQ(f.metadata.at("samples"), 2048);
    EXPECT_EQ(f.metadata.at("command_line"), "microshadow bake --test");
    EXPECT_DOUBLE_EQ(f.metadata.at("max_error").get<double>(), r.max_std_error);
    EXPECT_FALSE(f.metadata.at("device").get<std::string>().empty());
    EXPECT_FALSE(f.metadata.at("version").get<std::string>().empty());
    EXPECT_EQ(f.n_dot_l().count, 5u);
    EXPECT_EQ(f.n_dot_l().texel, TexelConvention::centres);
    EXPECT_EQ(f.data, r.value);  // float storage is exact
    for (std::size_t i = 0; i < f.data.size(); ++i)  // half keeps 11 significant bits
        ASSERT_LE(std::abs(h.data[i] - f.data[i]), std::abs(f.data[i]) * std::ldexp(1.0, -11)) << i;
    {
        Imf::InputFile in(path("f.exr").c_str());
        const auto* layout = in.header().findTypedAttribute<Imf::StringAttribute>("microshadow.layout");
        ASSERT_NE(layout, nullptr);
        EXPECT_EQ(layout->value(), "custom");
    }
    write_lut_preview(path("p.png"), {6, 5, 3, 2, r.value.data()});
    EXPECT_GT(fs::file_size(path("p.png")), 100u);
    EXPECT_EQ(preview_slices(64, 8).front(), 0u);
    EXPECT_EQ(preview_slices(64, 8).back(), 63u);
}

TEST_F(BakeTest, ToleranceAddsBatchesUntilMetAndVerifyAgreesWithOracle) {
    BakeSpec spec = small_spec();
    spec.samples = 1024;
    spec.roughness = {0.4};
    const BakeResult one = bake_lut(spec);
    spec.tolerance = one.max_std_error / 3;  // needs about 9x the samples in the worst slice
    const BakeResult more = bake_lut(spec);
    EXPECT_TRUE(more.tolerance_met);
    EXPECT_LE(more.max_std_error, spec.tolerance);
    EXPECT_GT(more.batches, one.batches);
    const BakeVerification v = verify_bake(spec, more, 12);
    EXPECT_EQ(v.checked, 12u);
    EXPECT_EQ(v.failed, 0u) << v.worst_texel;
    EXPECT_LE(v.worst_z, v.threshold);
}

// Adaptive azimuth (the default): every NdotL row of every slice equals, bit for bit, the fixed-K bake
// of the same points at the K the row ended at (nested trapezoid nodes, same reduction order); rows
// forced to refine reach the finest grid; and the recorded quadrature estimate is max |T_K - T_K/2|.
TEST_F(BakeTest, AdaptiveAzimuthRowsMatchFixedGridsBitForBit) {
    BakeSpec base = small_spec();
    base.roughness = {0.7, 1.0};
    base.n_dot_v.min = 0;
    base.n_dot_v.max = 0.3;  // near grazing, where the azimuth matters
    base.n_dot_l.max = 0.6;
    const std::uint32_t ks[] = {2, 4, 8};
    std::map<std::uint32_t, BakeResult> fixed;
    for (std::uint32_t k : ks) {
        BakeSpec s = base;
        s.azimuth_intervals = k;
        fixed[k] = bake_lut(s);
    }
    BakeSpec adaptive = base;
    adaptive.azimuth_intervals = 0;
    adaptive.azimuth_min_intervals = 2;
    adaptive.azimuth_max_intervals = 8;
    const std::uint32_t nv = 6, nl = 5, nvv = 3, ch = 2, rows = nl * nvv * ch;
    auto row_of = [&](const BakeResult& r, std::uint32_t c, std::uint32_t il, std::uint32_t ivv, bool se) {
        std::vector<float> v;
        for (std::uint32_t iv = 0; iv < nv; ++iv) {
            const std::size_t at = ((std::size_t(ivv) * nl + il) * nv + iv) * ch + c;
            v.push_back(se ? r.std_error[at] : r.value[at]);
        }
        return v;
    };
    // |T_K - T_K/2| of a row from the fixed bakes (float values: agrees with the double estimate to 1e-6).
    auto quadrature = [&](std::uint32_t k, std::uint32_t c, std::uint32_t il, std::uint32_t ivv) {
        double q = 0;
        const auto a = row_of(fixed[k], c, il, ivv, false), b = row_of(fixed[k / 2], c, il, ivv, false);
        const auto se = row_of(fixed[k], c, il, ivv, true);
        for (std::uint32_t iv = 0; iv < nv; ++iv)
            if (se[iv] > 0) q = std::max(q, std::abs(double(a[iv]) - double(b[iv])));
        return q;
    };

    // Forced: threshold 0 and no noise allowance refine every row with any difference to K = 8.
    adaptive.azimuth_refine_threshold = 0;
    adaptive.azimuth_refine_z = 0;
    const BakeResult forced = bake_lut(adaptive);
    EXPECT_EQ(forced.azimuth_rows_by_intervals.at(8), rows);
    EXPECT_EQ(0, std::memcmp(forced.value.data(), fixed[8].value.data(), forced.value.size() * sizeof(float)));
    EXPECT_EQ(0, std::memcmp(forced.std_error.data(), fixed[8].std_error.data(), forced.value.size() * sizeof(float)));
    double q8 = 0;
    for (std::uint32_t c = 0; c < ch; ++c)
        for (std::uint32_t ivv = 0; ivv < nvv; ++ivv)
            for (std::uint32_t il = 0; il < nl; ++il) q8 = std::max(q8, quadrature(8, c, il, ivv));
    EXPECT_GT(q8, 0.0);
    EXPECT_NEAR(forced.azimuth_quadrature_error, q8, 1e-6);
    EXPECT_NEAR(fixed[8].azimuth_quadrature_error, q8, 1e-6);  // fixed even K records the same estimate

    // Never: an unreachable threshold keeps every row at the start grid.
    adaptive.azimuth_refine_threshold = 10;
    const BakeResult coarse = bake_lut(adaptive);
    EXPECT_EQ(coarse.azimuth_rows_by_intervals.at(2), rows);
    EXPECT_EQ(0, std::memcmp(coarse.value.data(), fixed[2].value.data(), coarse.value.size() * sizeof(float)));

    // Mixed: a threshold between the rows' differences; each row is one of the fixed bakes' rows, and
    // the estimate is the largest |T_K - T_K/2| at the K each row stopped at.
    adaptive.azimuth_refine_threshold = 2e-3;
    adaptive.azimuth_refine_z = 1;
    const BakeResult mixed = bake_lut(adaptive);
    std::map<std::uint32_t, std::uint64_t> counts;
    double q = 0;
    for (std::uint32_t c = 0; c < ch; ++c)
        for (std::uint32_t ivv = 0; ivv < nvv; ++ivv)
            for (std::uint32_t il = 0; il < nl; ++il) {
                std::uint32_t match = 0;
                for (std::uint32_t k : ks)  // the finest fixed grid with the same values (coarser may tie)
                    if (row_of(mixed, c, il, ivv, false) == row_of(fixed[k], c, il, ivv, false) &&
                        row_of(mixed, c, il, ivv, true) == row_of(fixed[k], c, il, ivv, true))
                        match = k;
                ASSERT_NE(match, 0u) << "row c " << c << " l " << il << " nv " << ivv << " matches no fixed grid";
                ++counts[match];
                q = std::max(q, quadrature(match, c, il, ivv));
            }
    std::uint64_t total = 0;
    for (const auto& kv : mixed.azimuth_rows_by_intervals) total += kv.second;
    EXPECT_EQ(total, rows);
    EXPECT_EQ(counts, mixed.azimuth_rows_by_intervals);
    EXPECT_GT(mixed.azimuth_rows_by_intervals.size(), 1u) << "the threshold should split the rows";
    EXPECT_NEAR(mixed.azimuth_quadrature_error, q, 1e-6);
    // Refinement is decided from integer counts only, so it is deterministic.
    const BakeResult again = bake_lut(adaptive);
    EXPECT_EQ(again.value, mixed.value);
    EXPECT_EQ(again.azimuth_rows_by_intervals, mixed.azimuth_rows_by_intervals);
}

// The CLI with two PoCL devices (POCL_DEVICES must be set before the ICD loads, hence a subprocess).
TEST_F(BakeTest, TwoDevicesAndFaultInjectionGiveTheSameData) {
    MS_SKIP_UNLESS_POCL();
    const std::string args = " bake --layout custom --size 6 --size-n-dot-v 8 --roughness 0.2,0.8 --samples 2048 -q --out ";
    auto one = run("", args + path("one.exr"));
    ASSERT_EQ(one.exit_code, 0) << one.output;
    auto two = run("POCL_DEVICES='pthread pthread'", args + path("two.exr") + " --device all");
    ASSERT_EQ(two.exit_code, 0) << two.output;
    auto fault = run("POCL_DEVICES='pthread pthread' MICROSHADOW_FAIL_DEVICE=0:0", args + path("fault.exr") + " --device all");
    ASSERT_EQ(fault.exit_code, 0) << fault.output;
    const LutFile a = read_lut(path("one.exr")), b = read_lut(path("two.exr")), c = read_lut(path("fault.exr"));
    ASSERT_EQ(a.data.size(), b.data.size());
    EXPECT_EQ(0, std::memcmp(a.data.data(), b.data.data(), a.data.size() * sizeof(float)));
    EXPECT_EQ(0, std::memcmp(a.data.data(), c.data.data(), a.data.size() * sizeof(float)));
    EXPECT_NE(b.metadata.at("device").get<std::string>().find(';'), std::string::npos);  // two devices used
    EXPECT_EQ(b.metadata.at("rerun_chunks"), 0);
    EXPECT_EQ(c.metadata.at("rerun_chunks"), 1);  // device 0 failed on its first chunk, which device 1 reran

    auto dead = run("MICROSHADOW_FAIL_DEVICE=0:0", args + path("dead.exr") + " --preview " + path("dead.png"));
    EXPECT_NE(dead.exit_code, 0);
    EXPECT_NE(dead.output.find("every selected device failed"), std::string::npos) << dead.output;
    EXPECT_FALSE(fs::exists(path("dead.exr")));
    EXPECT_FALSE(fs::exists(path("dead.png")));
}

TEST_F(BakeTest, BadInputAndInterruptionLeaveNoFile) {
    for (const std::string bad : {"--size 0", "--layout custom --roughness 0.5,1.5", "--roughness 0.5",
                                  "--azimuth sideways", "--azimuth 200", "--samples 1024 --tolerance 1e-3",
                                  "--layout seed-2d --size-n-dot-v 4"}) {
        auto r = run("", "bake -q --out " + path("bad.exr") + " " + bad);
        EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.output;
        EXPECT_FALSE(fs::exists(path("bad.exr"))) << bad;
    }
    // SIGINT after a moment: the bake stops cleanly with exit 130 and writes nothing.
    auto r = run("timeout --preserve-status -s INT 1.5",
                 "bake -q --size 48 --samples 262144 --out " + path("big.exr") + " --preview " + path("big.png"));
    EXPECT_EQ(r.exit_code, 130) << r.output;
    EXPECT_FALSE(fs::exists(path("big.exr")));
    EXPECT_FALSE(fs::exists(path("big.png")));
    for (const auto& e : fs::directory_iterator(dir_)) ADD_FAILURE() << "left behind: " << e.path();
}

}  // namespace
