// The GGX prefilter: a constant environment stays constant at every roughness, a small
// bright disc gives the GGX lobe the oracle predicts (and the analytic point-light lobe), a linear
// environment stays linear across face seams, the roughness mapping, and the CLI's files.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "core/estimate.hpp"
#include "env/cubemap.hpp"
#include "env/prefilter.hpp"
#include "integrands/prefilter/prefilter_integrand.hpp"
#include "jobs/ibl_prefilter.hpp"
#include "scene/image_io.hpp"
#include "schedule/scheduler.hpp"

namespace {

using namespace ms;
using ms::kPi;

env::Cubemap make_prefilter_cube(std::uint32_t n, const std::function<std::array<double, 3>(const env::Dir&)>& f) {
    env::Cubemap c(n);
    for (int face = 0; face < 6; ++face)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const auto v = f(env::cube_direction(face, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1));
                for (int k = 0; k < 3; ++k) c.texel(face, x, y)[k] = float(v[k]);
            }
    return c;
}

// One target's per-replicate tallies from the integrand ([r 4 + c]) as a value with its std error.
env::PrefilterValue reduce_sums(const double* sums, std::uint32_t replicates) {
    env::PrefilterSums s(replicates);
    for (std::uint32_t r = 0; r < replicates; ++r) {
        for (int c = 0; c < 3; ++c) s.num[3 * r + c] = sums[4 * r + c];
        s.den[r] = sums[4 * r + 3];
    }
    return env::prefilter_value(s);
}

TEST(IblPrefilter, RoughnessMappings) {
    EXPECT_EQ(env::mip_roughness(0, 6, env::RoughnessMapping::cmgen), 0);
    EXPECT_DOUBLE_EQ(env::mip_roughness(5, 6, env::RoughnessMapping::cmgen), 1);
    for (std::uint32_t m = 0; m < 6; ++m) {
        const double r = env::mip_roughness(m, 6, env::RoughnessMapping::cmgen);
        EXPECT_NEAR(r * (2 - r), m / 5.0, 1e-12);  // Filament: lod / (levels - 1) = r (2 - r)
        EXPECT_NEAR(env::mip_roughness(m, 6, env::RoughnessMapping::linear), m / 5.0, 1e-12);
    }
}

TEST(IblPrefilter, ConstantEnvironmentStaysConstant) {
    const env::Cubemap src = make_prefilter_cube(32, [](const env::Dir&) { return std::array<double, 3>{0.5, 2.0, 7.0}; });
    PrefilterSpec spec;
    spec.backend.threads = 2;
    const PrefilterResult r = prefilter_cubemap(src, spec);
    ASSERT_EQ(r.mips.size(), 4u);  // 32, 16, 8, 4
    for (std::size_t m = 0; m < r.mips.size(); ++m)
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < r.mips[m].size; ++y)
                for (std::uint32_t x = 0; x < r.mips[m].size; ++x) {
                    EXPECT_NEAR(r.mips[m].texel(f, x, y)[0], 0.5, 1e-6);
                    EXPECT_NEAR(r.mips[m].texel(f, x, y)[2], 7.0, 1e-5);
                }
    // The oracle too, at any roughness.
    for (double rough : {0.1, 0.5, 1.0}) EXPECT_NEAR(env::prefilter_oracle(src, {0.6, 0, 0.8}, rough)[1], 2.0, 1e-9);
    // With the bright-texel split asked for (none is brighter than the mean) and 4x samples on the wide mips: still exact.
    spec.bright_threshold = 8;
    spec.wide_samples_factor = 4;
    spec.bright_min_roughness = 0.2;
    const PrefilterResult w = prefilter_cubemap(src, spec);
    EXPECT_EQ(w.bright_texels, 0u);
    EXPECT_EQ(w.samples, 6ull * 16 * 16 * 256 + 6ull * (8 * 8 + 4 * 4) * 1024);  // mips 2, 3 have roughness >= 0.2
    for (std::size_t m = 1; m < w.mips.size(); ++m) EXPECT_NEAR(w.mips[m].texel(2, 1, 1)[2], 7.0, 1e-5);
    spec.wide_samples_factor = 3;
    EXPECT_THROW(prefilter_cubemap(src, spec), std::invalid_argument);
}

// A linear environment L = 1 + d.x: the lobe is symmetric about n, so P(n) = 1 + c(r) n.x exactly, on
// every face alike; texels next to seams read across them, so a seam error would break the fit.
TEST(IblPrefilter, LinearEnvironmentAcrossSeams) {
    const env::Cubemap src = make_prefilter_cube(32, [](const env::Dir& d) { return std::array<double, 3>{1 + d.x, 1, 1}; });
    const std::vector<env::Cubemap> chain = env::mip_chain(src);
    const PointSet pts = make_point_set({Sequence::sobol, 4096, 8, 1});
    env::PrefilterOptions unfiltered;
    unfiltered.filtered = false;
    const double rough = 0.6;
    const env::Dir probe{1, 0, 0};
    const double c = env::prefilter_oracle(src, probe, rough)[0] - 1;
    EXPECT_GT(c, 0.3);
    EXPECT_LT(c, 1.0);
    const double t = student_t_quantile(1 - 0.001 / 24, 7);
    for (int face = 0; face < 6; ++face)
        for (double s : {-0.97, 0.97})
            for (double tt : {-0.97, 0.2}) {
                const env::Dir n = env::cube_direction(face, s, tt);  // next to the face's edges
                const auto v = env::prefilter_direction(chain, n, rough, pts, unfiltered);
                EXPECT_NEAR(v.value[0], 1 + c * n.x, t * v.std_error[0] + 2e-3) << face << " " << s << " " << tt;
                const auto o = env::prefilter_oracle(src, n, rough);
                EXPECT_NEAR(o[0], 1 + c * n.x, 1e-3) << face;
            }
}

// A small bright disc: the prefiltered lobe against the oracle, and the oracle against the analytic lobe
// of a point light of the disc's power Phi: P(n) = Phi (n.d0) D(h) / Z, Z = int (n.l) D(h) dl.
TEST(IblPrefilter, BrightDiscGivesTheGgxLobe) {
    const env::Dir d0{0.2, 0.1, std::sqrt(1 - 0.05)};
    const double cos_disc = std::cos(1.5 * kPi / 180);
    const std::uint32_t n = 64;
    const env::Cubemap src = make_prefilter_cube(n, [&](const env::Dir& d) {
        const double c = d.x * d0.x + d.y * d0.y + d.z * d0.z;
        return std::array<double, 3>{c > cos_disc ? 1000.0 : 0.0, 1, 0};
    });
    double phi = 0;  // the disc's power as the source holds it
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) phi += src.texel(f, x, y)[0] * env::cube_texel_solid_angle(x, y, n);
    const double rough = 0.5, alpha = rough * rough;
    // Z by quadrature over the half-vector angle (l = reflect(n, h), dl = 4 (n.h) dw_h, n.l = 2 c^2 - 1).
    double z = 0;
    const int steps = 200000;
    for (int i = 0; i < steps; ++i) {
        const double th = (i + 0.5) / steps * (kPi / 4), c = std::cos(th);
        z += (2 * c * c - 1) * env::ggx_d(c, alpha) * 4 * c * 2 * kPi * std::sin(th) * (kPi / 4 / steps);
    }
    const std::vector<env::Cubemap> chain = env::mip_chain(src);
    const PointSet pts = make_point_set({Sequence::sobol, 16384, 8, 2});
    env::PrefilterOptions unfiltered;
    unfiltered.filtered = false;
    env::PrefilterOptions filtered;
    const double t = student_t_quantile(1 - 0.001 / 5, 7);
    for (double angle_deg : {0.0, 8.0, 16.0, 25.0, 35.0}) {
        // n rotated away from d0 about an axis perpendicular to it.
        const double a = angle_deg * kPi / 180;
        const env::Dir axis{0, 1, 0};
        const env::Dir perp{axis.y * d0.z - axis.z * d0.y, axis.z * d0.x - axis.x * d0.z, axis.x * d0.y - axis.y * d0.x};
        const double pl = std::sqrt(perp.x * perp.x + perp.y * perp.y + perp.z * perp.z);
        const env::Dir nn{std::cos(a) * d0.x + std::sin(a) * perp.x / pl, std::cos(a) * d0.y + std::sin(a) * perp.y / pl,
                          std::cos(a) * d0.z + std::sin(a) * perp.z / pl};
        const double nl = nn.x * d0.x + nn.y * d0.y + nn.z * d0.z;
        const double hx = nn.x + d0.x, hy = nn.y + d0.y, hz = nn.z + d0.z;
        const double nh = (nn.x * hx + nn.y * hy + nn.z * hz) / std::sqrt(hx * hx + hy * hy + hz * hz);
        const double predicted = phi * nl * env::ggx_d(nh, alpha) / z;
        const auto oracle = env::prefilter_oracle(src, nn, rough);
        EXPECT_NEAR(oracle[0], predicted, 0.02 * predicted) << angle_deg;  // the disc is not a point: 2%
        EXPECT_NEAR(oracle[1], 1.0, 1e-9);
        const auto is = env::prefilter_direction(chain, nn, rough, pts, unfiltered);
        EXPECT_NEAR(is.value[0], oracle[0], t * is.std_error[0] + 0.01 * oracle[0]) << angle_deg;
        const auto fis = env::prefilter_direction(chain, nn, rough, pts, filtered);
        // Filtering trades variance for a bias (reads of blurred mips): within its error bars and 5%.
        EXPECT_NEAR(fis.value[0], oracle[0], t * fis.std_error[0] + 0.05 * oracle[0]) << angle_deg;
        std::printf("[ disc ] %4.1f deg: point-light lobe %.4f, oracle %.4f, IS %.4f +- %.4f, FIS %.4f\n", angle_deg, predicted,
                    oracle[0], is.value[0], is.std_error[0], fis.value[0]);
    }
}

// The bright-texel split (env/prefilter.hpp, BrightSplit): Z in closed form against quadrature; on a scene with
// a small disc 1000x brighter than the rest, the split estimator agrees with the oracle within its (much
// smaller) error bars, filtered and not, and a constant environment has no bright texels and stays exact.
TEST(IblPrefilter, BrightTexelsSummedExplicitly) {
    for (double alpha : {0.003, 0.05, 0.3, 0.7, 0.9995, 1.0}) {
        double z = 0;  // midpoint rule over the half-vector angle, l = reflect(n, h), dl = 4 (n.h) dw_h
        const int steps = 400000;
        for (int i = 0; i < steps; ++i) {
            const double th = (i + 0.5) / steps * (kPi / 4), c = std::cos(th);
            z += (2 * c * c - 1) * env::ggx_d(c, alpha) * 4 * c * 2 * kPi * std::sin(th) * (kPi / 4 / steps);
        }
        EXPECT_NEAR(env::ggx_prefilter_normalisation(alpha), z, 2e-6 * z) << alpha;
    }
    EXPECT_NEAR(env::ggx_prefilter_normalisation(1.0), 1.0, 1e-12);

    const env::Dir d0{0.2, 0.1, std::sqrt(1 - 0.05)};
    const std::uint32_t n = 32;
    const env::Cubemap src = make_prefilter_cube(n, [&](const env::Dir& d) {
        const double c = d.x * d0.x + d.y * d0.y + d.z * d0.z;
        return std::array<double, 3>{c > std::cos(3 * kPi / 180) ? 1000.0 : 0.5 + 0.3 * d.y, 1, 0.2};
    });
    const env::BrightSplit split = env::split_bright_texels(src, 50, 1024);
    EXPECT_GT(split.texels.size(), 0u);
    EXPECT_GT(split.bright_power_fraction, 0.2);  // two 1000x texels hold a quarter of the power
    const std::vector<env::Cubemap> chain = env::mip_chain(src);
    const PointSet pts = make_point_set({Sequence::sobol, 1024, 8, 3});
    const double t = student_t_quantile(1 - 0.001 / 12, 7);
    double se_plain = 0, se_split = 0;
    for (bool filtered : {false, true}) {
        env::PrefilterOptions options;
        options.filtered = filtered;
        for (double rough : {0.4, 0.8})
            for (double angle_deg : {0.0, 20.0, 60.0}) {
                const double a = angle_deg * kPi / 180;
                const env::Dir nn{std::cos(a) * d0.x + std::sin(a), std::cos(a) * d0.y, std::cos(a) * d0.z};
                const double len = std::sqrt(nn.x * nn.x + nn.y * nn.y + nn.z * nn.z);
                const env::Dir u{nn.x / len, nn.y / len, nn.z / len};
                const auto oracle = env::prefilter_oracle(src, u, rough);
                const auto v = env::prefilter_direction_split(split, u, rough, pts, options);
                // Filtering's blur of the (dim) rest: 2% of the value, as for the plain estimator above.
                EXPECT_NEAR(v.value[0], oracle[0], t * v.std_error[0] + (filtered ? 0.02 : 0.005) * oracle[0])
                    << rough << " " << angle_deg << " filtered " << filtered;
                // G is 1 everywhere, but the split is by luminance: the disc's G is summed explicitly, the rest sampled.
                EXPECT_NEAR(v.value[1], 1.0, t * v.std_error[1] + (filtered ? 0.02 : 0.005));
                if (!filtered) {
                    se_split += v.std_error[0] / oracle[0];
                    se_plain += env::prefilter_direction(chain, u, rough, pts, options).std_error[0] / oracle[0];
                }
            }
    }
    std::printf("[ bright ] %zu texels, %.3f of the power; mean relative std error %.4f plain, %.4f split\n", split.texels.size(),
                split.bright_power_fraction, se_plain / 6, se_split / 6);
    EXPECT_LT(se_split, 0.2 * se_plain);
    const env::Cubemap flat = make_prefilter_cube(8, [](const env::Dir&) { return std::array<double, 3>{2, 2, 2}; });
    EXPECT_TRUE(env::split_bright_texels(flat, 2, 1024).texels.empty());
}

// The kernel (kernels/prefilter/prefilter.cl) against the C++ estimator on the same points (the same
// numbers up to float rounding), and against the brute-force oracle within its Bonferroni-t error bars, on the
// bright-disc scene with texels next to seams and corners, filtered and not.
TEST(IblPrefilterKernel, MatchesTheCppEstimatorAndTheOracle) {
    const env::Dir d0{0.2, 0.1, std::sqrt(1 - 0.05)};
    const std::uint32_t n = 32;
    const env::Cubemap src = make_prefilter_cube(n, [&](const env::Dir& d) {
        const double c = d.x * d0.x + d.y * d0.y + d.z * d0.z;
        return std::array<double, 3>{c > std::cos(0.1) ? 50.0 : 0.2 + 0.1 * d.y, 1, 0.5 + 0.5 * d.x};
    });
    const std::vector<env::Cubemap> chain = env::mip_chain(src);
    const prefilter::SourceChain packed = pack_chain(chain);
    const PointSet pts = make_point_set({Sequence::sobol, 8192, 8, 5});
    std::vector<prefilter::Target> targets;
    for (double rough : {0.2, 0.5, 0.9})
        for (int face : {0, 4, 5})
            for (double s : {-0.99, 0.3})
                for (double t : {-0.99, 0.6}) {
                    const env::Dir d = env::cube_direction(face, s, t);
                    targets.push_back({d.x, d.y, d.z, rough});
                }
    const double tq = student_t_quantile(1 - 0.001 / (3.0 * targets.size()), 7);
    for (bool filtered : {false, true}) {
        prefilter::RoutineConfig config;
        config.filtered = filtered;
        env::PrefilterOptions options;
        options.filtered = filtered;
        prefilter::PrefilterIntegrand kernel(packed, targets, 8, pts, config, nullptr);
        schedule::Scheduler device(schedule::Backend::opencl(ocl::select_devices("default")));
        device.run(kernel);
        for (std::size_t i = 0; i < targets.size(); ++i) {
            const prefilter::Target& t = targets[i];
            const env::PrefilterValue cpu = env::prefilter_direction(chain, {t.x, t.y, t.z}, t.roughness, pts, options);
            const env::PrefilterValue k = reduce_sums(kernel.sums().data() + i * 4 * 8, 8);
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(k.value[c], cpu.value[c], 2e-4 * std::abs(cpu.value[c]) + 1e-6) << i << " " << c << " filtered " << filtered;
                if (!filtered) {
                    const auto oracle = env::prefilter_oracle(src, {t.x, t.y, t.z}, t.roughness);
                    EXPECT_NEAR(k.value[c], oracle[c], tq * k.std_error[c] + 0.01 * oracle[c]) << i << " " << c;
                }
            }
        }
    }
}

class IblPrefilterCli : public ms::testing::ScratchDirTest {
protected:
    IblPrefilterCli() : ScratchDirTest("ibl_prefilter") {}
};

TEST_F(IblPrefilterCli, WritesMipsIrradianceAndPreviews) {
    // A 4:3 horizontal cross of 16^2 faces: a sky gradient.
    env::Cubemap cube = make_prefilter_cube(16, [](const env::Dir& d) { return std::array<double, 3>{1 + d.y, 1, 0.5}; });
    env::write_exr(path("sky.exr"), env::cross_image(cube), {{"note", "test"}});
    const auto res = ms::testing::run_shell(std::string(MICROSHADOW_CLI) + " ibl prefilter " + path("sky.exr") + " --out " + path("out") +
                                            " --samples 64 --verify 4 --irradiance-size 8 --threads 2 2>&1");
    ASSERT_EQ(res.exit_code, 0) << res.output;
    // By default one KTX2 cubemap holds the whole chain (what engines load), the irradiance another.
    for (const char* f : {"specular.ktx2", "specular_preview.png", "irradiance.ktx2", "irradiance_preview.png", "sh.json", "ibl.json"})
        EXPECT_TRUE(std::filesystem::exists(path(std::string("out/") + f))) << f;
    EXPECT_FALSE(std::filesystem::exists(path("out/specular_m0.exr")));
    std::ifstream in(path("out/ibl.json"));
    const auto meta = nlohmann::json::parse(in);
    EXPECT_EQ(meta.at("specular").at("mapping"), "cmgen");
    EXPECT_EQ(meta.at("specular").at("roughness").size(), 3u);
    EXPECT_LT(meta.at("specular").at("verify").at("max_relative").get<double>(), 0.05);
    // The preview's mip labels (white text in the black strip under each cross, cells of 4n + 8 pixels
    // side by side) stay inside their cells: a few columns either side of every boundary between two
    // cells are dark in the strip. Before, "mip 0  16x16  roughness 0.000" ran across into the next
    // cell's label.
    const std::uint32_t n = 16, cell = 4 * n + 8, strip = 3 * n + 4;
    const auto red = scene::read_channels(path("out/specular_preview.png"), {"R"}).at(0);
    for (std::uint32_t boundary = cell; boundary + 2 < red.width; boundary += cell)
        for (std::uint32_t y = strip; y < strip + 16 && y < red.height; ++y)
            for (std::uint32_t x = boundary - 2; x < boundary + 2; ++x)
                EXPECT_EQ(red.at(x, y), 0.0f) << "label text at (" << x << ", " << y << "), across the cells' boundary " << boundary;
}

}  // namespace

namespace {
// The automatic split: on a scene with a small disc 1000x brighter than the rest it takes the disc's texels
// (the rest's coefficient of variation falls from ~5 to ~0.3, worth far more than their explicit cost) and
// keeps the split exact (the texels plus the rest's power are the source's); a constant environment gets none.
TEST(IblPrefilter, AutomaticSplitTakesTheDisc) {
    const env::Dir d0{0.2, 0.1, std::sqrt(1 - 0.05)};
    const env::Cubemap src = make_prefilter_cube(32, [&](const env::Dir& d) {
        const double c = d.x * d0.x + d.y * d0.y + d.z * d0.z;
        return std::array<double, 3>{c > std::cos(3 * kPi / 180) ? 1000.0 : 0.5 + 0.3 * d.y, 1, 0.2};
    });
    const env::BrightSplit fixed = env::split_bright_texels(src, 50, 1024);
    const env::BrightSplit chosen = env::choose_bright_split(src, 0.01, 1024);
    EXPECT_GE(chosen.texels.size(), fixed.texels.size());  // at least every disc texel
    EXPECT_GE(chosen.bright_power_fraction, fixed.bright_power_fraction - 1e-12);
    EXPECT_GT(chosen.threshold, 0);
    const env::Cubemap flat = make_prefilter_cube(8, [](const env::Dir&) { return std::array<double, 3>{2, 2, 2}; });
    EXPECT_TRUE(env::choose_bright_split(flat, 0.01, 1024).texels.empty());
    EXPECT_THROW(env::choose_bright_split(flat, 0, 1024), std::invalid_argument);
}
}  // namespace
