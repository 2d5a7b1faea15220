// `ibl prefilter` to a tolerance: sample rounds until every texel's relative 95% bar (t over the replicates
// plus the explicit part's bound) meets it, the bright split chosen automatically, on the C++ threads and the
// OpenCL kernel; --verify passes a clean run and fails a corrupted estimator (exit 1, nothing written).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/prefilter.hpp"
#include "jobs/ibl_prefilter.hpp"

namespace {

using namespace ms;

// Every texel of mips >= 1 meets `tolerance` with its own bar, t se + b (relative to the mean of RGB), except
// those whose explicit bound b alone is above it (a sun texel the horizon cuts on a coarse source: the centre
// rule's error, which more samples cannot reduce): returns how many of those there are.
std::uint64_t check_every_bar(const PrefilterResult& r, double tolerance) {
    std::uint64_t explicit_limited = 0;
    for (std::size_t m = 1; m < r.mips.size(); ++m)
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < r.mips[m].size; ++y)
                for (std::uint32_t x = 0; x < r.mips[m].size; ++x) {
                    const float* v = r.mips[m].texel(f, x, y);
                    const float* se = r.std_error[m].texel(f, x, y);
                    const float* b = r.explicit_bound[m].texel(f, x, y);
                    const double scale = (std::abs(v[0]) + std::abs(v[1]) + std::abs(v[2])) / 3.0;
                    double bar = 0, bound = 0;
                    for (int c = 0; c < 3; ++c) {
                        bar = std::max(bar, (r.t_multiplier * se[c] + b[c]) / scale);
                        bound = std::max(bound, b[c] / scale);
                    }
                    if (bound > tolerance) {
                        ++explicit_limited;
                        continue;
                    }
                    EXPECT_LE(bar, tolerance * (1 + 1e-5)) << "mip " << m << " face " << f << " (" << x << ", " << y << ")";
                }
    return explicit_limited;
}

// An n^2-face sky with a small sun ~2000x brighter than it: the scene where replicate bars lied (a rare event).
env::Cubemap sun_sky(std::uint32_t n) {
    const env::Dir sun{0.3, 0.5, std::sqrt(1 - 0.34)};
    env::Cubemap c(n);
    for (int face = 0; face < 6; ++face)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const env::Dir d = env::cube_direction(face, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                const double cs = d.x * sun.x + d.y * sun.y + d.z * sun.z;
                const bool in_sun = cs > std::cos(0.12);
                float* t = c.texel(face, x, y);
                t[0] = float(in_sun ? 2000.0 : 0.4 + 0.3 * d.y);
                t[1] = float(in_sun ? 1800.0 : 0.5 + 0.2 * d.y);
                t[2] = float(in_sun ? 1500.0 : 0.8 + 0.1 * d.x);
            }
    return c;
}

TEST(IblPrefilterTolerance, EveryTexelMeetsItsBarAndTheOracleAgrees) {
    const env::Cubemap src = sun_sky(16);
    PrefilterSpec spec;
    spec.backend.threads = 2;
    spec.tolerance = 0.05;
    const PrefilterResult r = prefilter_cubemap(src, spec);
    EXPECT_GT(r.bright_texels, 0u);  // the sun, chosen automatically
    EXPECT_GT(r.bright_power_fraction, 0.5);
    EXPECT_EQ(r.unconverged, check_every_bar(r, spec.tolerance));
    EXPECT_LT(r.unconverged, 8u);  // of 480 texels
    // The explicit part has a bar of its own (not 0) wherever it contributes.
    double largest_bound = 0;
    for (std::size_t m = 1; m < r.mips.size(); ++m)
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < r.mips[m].size; ++y)
                for (std::uint32_t x = 0; x < r.mips[m].size; ++x)
                    largest_bound = std::max(largest_bound, double(r.explicit_bound[m].texel(f, x, y)[0]));
    EXPECT_GT(largest_bound, 0);
    // Against the oracle on 200 random texels (600 channels): within the Bonferroni bound.
    const PrefilterVerification v = verify_prefilter(src, r, 200, 3);
    EXPECT_TRUE(v.passed) << v.worst_z << " > " << v.z_bound << ": " << v.worst_z_texel;
    EXPECT_LT(v.rms_relative, spec.tolerance);
    // A tighter tolerance costs more samples and gives smaller bars.
    spec.tolerance = 0.02;
    const PrefilterResult tight = prefilter_cubemap(src, spec);
    EXPECT_GT(tight.samples, r.samples);
    EXPECT_EQ(tight.unconverged, check_every_bar(tight, 0.02));
    // A fixed sample count (tolerance 0) is one round.
    spec.tolerance = 0;
    spec.plan.samples = 256;
    const PrefilterResult fixed = prefilter_cubemap(src, spec);
    EXPECT_EQ(fixed.rounds, 1u);
    EXPECT_EQ(fixed.samples, fixed.texels * 256);
}

// A corrupted estimator (every value 10% high, bars unchanged) fails verification; the clean one passes.
TEST(IblPrefilterTolerance, VerifyCatchesABiasedEstimator) {
    const env::Cubemap src = sun_sky(8);
    PrefilterSpec spec;
    spec.backend.threads = 2;
    spec.tolerance = 0.05;
    const PrefilterResult clean = prefilter_cubemap(src, spec);
    const PrefilterVerification ok = verify_prefilter(src, clean, 32);
    EXPECT_TRUE(ok.passed) << ok.worst_z << " > " << ok.z_bound << ": " << ok.worst_z_texel;
    spec.test_bias = 0.1;
    const PrefilterResult biased = prefilter_cubemap(src, spec);
    const PrefilterVerification v = verify_prefilter(src, biased, 32);
    EXPECT_FALSE(v.passed);
    EXPECT_GT(v.worst_z, v.z_bound);
}

// The verification's summary is the RMS and maximum of the relative errors, over all checks and per mip:
// a grey source (whose prefiltered value the oracle gives exactly) against mips d_m too high, with replicate
// errors s_m, gives RMS d_m and s_m in each drawn mip and the largest drawn d_m as the maximum.
TEST(IblPrefilterTolerance, TheSummaryIsTheRmsAndMaximumOfTheRelativeErrorsPerMip) {
    const std::uint32_t n = 8;
    const float grey = 0.5f;
    env::Cubemap src(n);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x)
                for (int c = 0; c < 3; ++c) src.texel(f, x, y)[c] = grey;
    const double too_high[4] = {0, 0.01, 0.02, 0.04}, std_error[4] = {0, 0.001, 0.002, 0.003};
    PrefilterResult r;
    r.replicates = 8;
    for (std::uint32_t m = 0; m < 4; ++m) {
        const std::uint32_t size = n >> m;
        env::Cubemap value(size), se(size), bound(size);
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < size; ++y)
                for (std::uint32_t x = 0; x < size; ++x)
                    for (int c = 0; c < 3; ++c) {
                        value.texel(f, x, y)[c] = float(grey * (1 + too_high[m]));
                        se.texel(f, x, y)[c] = float(grey * std_error[m]);
                        bound.texel(f, x, y)[c] = 0;
                    }
        r.mips.push_back(std::move(value));
        r.std_error.push_back(std::move(se));
        r.explicit_bound.push_back(std::move(bound));
        r.roughness.push_back(m / 3.0);
    }
    const PrefilterVerification v = verify_prefilter(src, r, 60, 7);
    ASSERT_EQ(v.checked, 60u);
    ASSERT_EQ(v.rms_relative_by_mip.size(), 4u);
    EXPECT_EQ(v.rms_relative_by_mip[0], 0.0);  // mip 0 is the source: never drawn
    // Float storage of the texels: within 2^-23 relative of d_m and s_m.
    double largest = 0, smallest = 1;
    for (std::uint32_t m = 1; m < 4; ++m) {
        ASSERT_GT(v.rms_relative_by_mip[m], 0) << "mip " << m << " never drawn in 60 checks";
        EXPECT_NEAR(v.rms_relative_by_mip[m], too_high[m], 1e-6) << "mip " << m;
        EXPECT_NEAR(v.rms_std_error_by_mip[m], std_error[m], 1e-6) << "mip " << m;
        largest = std::max(largest, too_high[m]);
        smallest = std::min(smallest, too_high[m]);
    }
    EXPECT_NEAR(v.max_relative, largest, 1e-6);
    // Over all checks: a mean of the mips' squares, so between the smallest and the largest.
    EXPECT_GT(v.rms_relative, smallest);
    EXPECT_LT(v.rms_relative, largest);
    EXPECT_NE(v.worst_texel.find("mip 3"), std::string::npos) << v.worst_texel;
}

// The OpenCL kernel path: the same rounds, the same split (its explicit part on the host), the oracle within the bars.
TEST(IblPrefilterTolerance, KernelPathMeetsTheToleranceToo) {
    const env::Cubemap src = sun_sky(8);
    PrefilterSpec spec;
    spec.tolerance = 0.05;
    spec.backend.kind = schedule::Backend::Kind::opencl;  // the kernel on the default device
    const PrefilterResult r = prefilter_cubemap(src, spec);
    EXPECT_GT(r.bright_texels, 0u);
    EXPECT_EQ(r.unconverged, check_every_bar(r, spec.tolerance));
    EXPECT_LT(r.unconverged, 8u);  // of 96 texels
    const PrefilterVerification v = verify_prefilter(src, r, 48, 5);
    EXPECT_TRUE(v.passed) << v.worst_z << " > " << v.z_bound << ": " << v.worst_z_texel;
}

class IblPrefilterToleranceCli : public ms::testing::ScratchDirTest {
protected:
    IblPrefilterToleranceCli() : ScratchDirTest("ibl_prefilter_tolerance") {}
};

TEST_F(IblPrefilterToleranceCli, VerifyFailsACorruptedEstimatorAndWritesNothing) {
    env::write_exr(path("sun.exr"), env::cross_image(sun_sky(8)), {{"note", "test"}});
    const std::string args = " ibl prefilter " + path("sun.exr") + " --tolerance 0.05 --verify 16 --irradiance-size 4 --threads 2 -q";
    const auto clean = ms::testing::run_shell(std::string(MICROSHADOW_CLI) + args + " --out " + path("clean") + " 2>&1");
    ASSERT_EQ(clean.exit_code, 0) << clean.output;
    std::ifstream in(path("clean/ibl.json"));
    const auto meta = nlohmann::json::parse(in).at("specular");
    EXPECT_TRUE(meta.at("verify").at("passed").get<bool>());
    EXPECT_EQ(meta.at("tolerance").get<double>(), 0.05);
    EXPECT_GT(meta.at("bright_texels").at("count").get<int>(), 0);
    const auto bad = ms::testing::run_shell("MICROSHADOW_TEST_PREFILTER_BIAS=0.2 " + std::string(MICROSHADOW_CLI) + args + " --out " +
                                            path("bad") + " 2>&1");
    EXPECT_EQ(bad.exit_code, 1) << bad.output;
    EXPECT_NE(bad.output.find("verification failed"), std::string::npos) << bad.output;
    EXPECT_NE(bad.output.find("nothing was written"), std::string::npos) << bad.output;
    EXPECT_FALSE(std::filesystem::exists(path("bad/ibl.json")));
    EXPECT_FALSE(std::filesystem::exists(path("bad/specular_m1.exr")));
    const auto nonsense = ms::testing::run_shell("MICROSHADOW_TEST_PREFILTER_BIAS=x " + std::string(MICROSHADOW_CLI) + args + " --out " +
                                                 path("bad") + " 2>&1");
    EXPECT_EQ(nonsense.exit_code, 2) << nonsense.output;
}

}  // namespace
