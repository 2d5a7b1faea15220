// The irradiance cubemap by direct convolution. Convention: E(n) = integral L max(0, n.l) dl; the
// files hold E / pi. Known answers: a constant environment gives E = pi L (oracle to double rounding, kernel
// to float rounding); the upper half-space L = [d.z > 0] (piecewise constant on the texels of an even face
// size) gives the sky-view closed form E = pi (1 + n.z) / 2; one lit face gives Lambert's formula for the
// square. The kernel against the oracle within its bound, which must also be far from vacuous; SH against
// the direct map within the clamped cosine's truncation bound 3/32 int L dl.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "core/types.hpp"
#include "env/irradiance.hpp"
#include "env/sh.hpp"
#include "integrands/irradiance/irradiance_integrand.hpp"
#include "jobs/ibl_irradiance.hpp"
#include "schedule/scheduler.hpp"

namespace {

using namespace ms;
using ms::kPi;

env::Cubemap make_cube(std::uint32_t n, const std::function<std::array<double, 3>(const env::Dir&)>& f) {
    env::Cubemap c(n);
    for (int face = 0; face < 6; ++face)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const auto v = f(env::cube_direction(face, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1));
                for (int k = 0; k < 3; ++k) c.texel(face, x, y)[k] = float(v[k]);
            }
    return c;
}

// Normals that put the horizon through every kind of texel: axes, face edges, corners, generic.
std::vector<env::Dir> probe_normals() {
    std::vector<env::Dir> out;
    for (const auto& v : std::vector<std::array<double, 3>>{{0, 0, 1}, {1, 0, 0}, {0, -1, 0}, {1, 1, 0}, {1, 1, 1}, {-1, 2, 3}, {0.3, -0.5, 0.81}, {-0.7, 0.1, -0.2}}) {
        const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        out.push_back({v[0] / l, v[1] / l, v[2] / l});
    }
    return out;
}

TEST(IblIrradiance, OracleTexelIntegralsAreExact) {
    // A constant environment: the texel integrals of max(0, n.l) add up to pi for every n.
    const env::Cubemap ones = make_cube(12, [](const env::Dir&) { return std::array<double, 3>{1, 2, 0.5}; });
    for (const env::Dir& n : probe_normals()) {
        const auto e = env::irradiance_exact(ones, n);
        EXPECT_NEAR(e[0], kPi, 1e-12) << n.x << " " << n.y << " " << n.z;
        EXPECT_NEAR(e[1], 2 * kPi, 2e-12);
    }
    // The upper half-space: E = pi (1 + n.z) / 2 (the z = 0 plane runs along texel edges for an even size).
    const env::Cubemap sky = make_cube(10, [](const env::Dir& d) { return std::array<double, 3>{d.z > 0 ? 1.0 : 0.0, 0, 0}; });
    for (const env::Dir& n : probe_normals()) EXPECT_NEAR(env::irradiance_exact(sky, n)[0], kPi * (1 + n.z) / 2, 1e-12) << n.z;
    // Face +Z alone: Lambert's formula for the square (corners (+-1, +-1, 1)), for normals that see all of it
    // and for n = +X, which sees its s > 0 half (a rectangle with corners (0, +-1, 1), (1, +-1, 1)).
    const env::Cubemap face = make_cube(8, [](const env::Dir& d) {
        return std::array<double, 3>{std::abs(d.z) >= std::abs(d.x) && std::abs(d.z) >= std::abs(d.y) && d.z > 0 ? 1.0 : 0.0, 0, 0};
    });
    auto lambert = [](const std::vector<std::array<double, 3>>& poly, const env::Dir& n) {
        double sum = 0;
        for (std::size_t i = 0; i < poly.size(); ++i) {
            auto a = poly[i], b = poly[(i + 1) % poly.size()];
            const double la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
            for (int k = 0; k < 3; ++k) a[k] /= la, b[k] /= lb;
            const double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
            const double cl = std::sqrt(cx * cx + cy * cy + cz * cz);
            sum += std::atan2(cl, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * (n.x * cx + n.y * cy + n.z * cz) / cl;
        }
        return 0.5 * std::abs(sum);
    };
    const std::vector<std::array<double, 3>> square{{-1, -1, 1}, {1, -1, 1}, {1, 1, 1}, {-1, 1, 1}};
    for (const env::Dir& n : {env::Dir{0, 0, 1}, env::Dir{0.2, 0.1, std::sqrt(0.95)}})
        EXPECT_NEAR(env::irradiance_exact(face, n)[0], lambert(square, n), 1e-12);
    EXPECT_NEAR(env::irradiance_exact(face, {1, 0, 0})[0], lambert({{0, -1, 1}, {1, -1, 1}, {1, 1, 1}, {0, 1, 1}}, {1, 0, 0}), 1e-12);
}

TEST(IblIrradiance, ReductionKeepsPowerAndItsBoundHolds) {
    // A disc brighter than the rest by 200 on a 32^2 source, reduced to 8^2: the exact convolution of the reduced
    // map differs from the source's by no more than the bound, for every normal.
    const env::Dir d0{0.3, 0.2, std::sqrt(0.87)};
    const env::Cubemap src = make_cube(32, [&](const env::Dir& d) {
        const double c = d.x * d0.x + d.y * d0.y + d.z * d0.z;
        return std::array<double, 3>{c > std::cos(0.08) ? 200.0 : 0.5 + 0.4 * d.y, 1, 0.5 + 0.5 * d.x};
    });
    const env::ReducedCubemap red = env::reduce_cubemap(src, 8);
    for (const env::Dir& n : probe_normals()) {
        const auto full = env::irradiance_exact(src, n), reduced = env::irradiance_exact(red.mean, n);
        EXPECT_NEAR(reduced[1], full[1], 1e-5 * full[1]);  // a constant channel is unchanged (float means)
        EXPECT_NEAR(reduced[0], full[0], std::max(1e-9, 0.2 * full[0])) << "sanity";
    }
    EXPECT_THROW(env::reduce_cubemap(src, 12), std::invalid_argument);
}

// The kernel through the scheduler against the oracle (the exact convolution of the full source): within the
// bound at every output texel, and the bound within a small factor of the actual difference.
TEST(IblIrradianceKernel, WithinItsBoundOfTheOracle) {
    const env::Dir d0{0.3, 0.2, std::sqrt(0.87)};
    const env::Cubemap src = make_cube(32, [&](const env::Dir& d) {
        const double c = d.x * d0.x + d.y * d0.y + d.z * d0.z;
        return std::array<double, 3>{c > std::cos(0.08) ? 200.0 : 0.5 + 0.4 * d.y, 1, 0.5 + 0.5 * d.x};
    });
    for (std::uint32_t source_size : {32u, 8u}) {
        IrradianceMapSpec spec;
        spec.face_size = 6;
        spec.source_size = source_size;
        const IrradianceMapResult kernel = compute_irradiance_map(src, spec);
        ASSERT_EQ(kernel.convolution_size, source_size);
        IrradianceMapSpec ospec = spec;
        ospec.backend.kind = schedule::Backend::Kind::oracle;
        ospec.backend.threads = 2;
        const IrradianceMapResult oracle = compute_irradiance_map(src, ospec);
        double worst_ratio = 0, worst_rel_diff = 0, largest = 0, largest_bound = 0;
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < 6; ++y)
                for (std::uint32_t x = 0; x < 6; ++x)
                    for (int c = 0; c < 3; ++c) {
                        const double k = kernel.map.texel(f, x, y)[c], o = oracle.map.texel(f, x, y)[c];
                        const double b = kernel.bound.texel(f, x, y)[c] + 6e-8 * std::abs(o);  // + the float map's rounding
                        EXPECT_LE(std::abs(k - o), b) << "size " << source_size << " face " << f << " " << x << " " << y << " " << c;
                        worst_ratio = std::max(worst_ratio, std::abs(k - o) / b);
                        largest = std::max(largest, o);
                        largest_bound = std::max(largest_bound, b);
                        if (o > 0) worst_rel_diff = std::max(worst_rel_diff, std::abs(k - o) / o);
                    }
        std::printf("[ irradiance ] convolution %u^2 of a 32^2 source: max relative bound %.3g, largest bound / largest value %.3g, "
                    "max relative diff %.3g, worst diff / bound %.3g; SH max relative %.3g\n",
                    source_size, kernel.max_relative_bound, largest_bound / largest, worst_rel_diff, worst_ratio, kernel.sh_max_relative);
        if (source_size == 32) {
            EXPECT_LT(kernel.max_relative_bound, 1e-3);  // rounding only
            EXPECT_LT(worst_rel_diff, 2e-5);
        } else {
            EXPECT_LT(largest_bound / largest, 0.5);  // a bound that says something on this harsh scene
            EXPECT_GT(worst_ratio, 1e-2);             // and not 100x above what happens
        }
        // Order 2 cannot hold the bright disc; the comparison sees it, within the truncation bound.
        EXPECT_GT(kernel.sh_max_relative, 0.03);
        EXPECT_LE(kernel.sh_max_abs, kernel.sh_truncation_bound);
    }
}

TEST(IblIrradianceKernel, ConstantAndSkyThroughTheKernel) {
    const env::Cubemap ones = make_cube(16, [](const env::Dir&) { return std::array<double, 3>{1, 2, 0.5}; });
    IrradianceMapSpec spec;
    spec.face_size = 4;
    spec.source_size = 16;
    const IrradianceMapResult r = compute_irradiance_map(ones, spec);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < 4; ++y)
            for (std::uint32_t x = 0; x < 4; ++x) {
                EXPECT_NEAR(r.map.texel(f, x, y)[0], 1.0, 4e-6);  // E / pi = L, to float rounding
                EXPECT_NEAR(r.map.texel(f, x, y)[1], 2.0, 8e-6);
                EXPECT_LE(std::abs(r.map.texel(f, x, y)[0] - 1.0), r.bound.texel(f, x, y)[0] + 6e-8);
            }
    // Order-2 SH is exact for a constant; the comparison says so.
    EXPECT_LT(r.sh_max_relative, 1e-5);
    const env::Cubemap sky = make_cube(16, [](const env::Dir& d) { return std::array<double, 3>{d.y > 0 ? 3.0 : 0.0, 0, 0}; });
    const IrradianceMapResult s = compute_irradiance_map(sky, spec);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < 4; ++y)
            for (std::uint32_t x = 0; x < 4; ++x) {
                const env::Dir n = env::cube_direction(f, 2 * (x + 0.5) / 4 - 1, 2 * (y + 0.5) / 4 - 1);
                EXPECT_NEAR(s.map.texel(f, x, y)[0], 3.0 * (1 + n.y) / 2, s.bound.texel(f, x, y)[0] + 1e-6);
            }
    // SH of a half-space sky: its irradiance is linear in n and the step has no l = 2 part, so order 2 is exact up
    // to the projection's texel-centre quadrature; the truncation bound 3/32 int L dl / pi = 3/32 * 3 * 2 pi / pi.
    EXPECT_NEAR(s.sh_truncation_bound, 3.0 / 32 * 6, 1e-4);
    EXPECT_LT(s.sh_max_abs, 0.01);
}

class IblIrradianceCli : public ms::testing::ScratchDirTest {
protected:
    IblIrradianceCli() : ScratchDirTest("ibl_irradiance") {}
};

TEST_F(IblIrradianceCli, WritesTheMapWithProvenanceAndVerifies) {
    const env::Cubemap cube = make_cube(16, [](const env::Dir& d) { return std::array<double, 3>{1 + d.y, 1, d.x > 0.9 ? 40.0 : 0.5}; });
    env::write_exr(path("sky.exr"), env::cross_image(cube), {{"note", "test"}});
    const std::string cli = std::string(MICROSHADOW_CLI) + " ibl irradiance " + path("sky.exr");
    auto r = ms::testing::run_shell(cli + " --out " + path("a") + " --face-size 4 --source-size 8 --verify 6 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const char* f : {"irradiance.exr", "irradiance.json", "irradiance_preview.png"}) EXPECT_TRUE(std::filesystem::exists(path(std::string("a/") + f))) << f;
    nlohmann::json meta;
    std::ifstream(path("a/irradiance.json")) >> meta;
    EXPECT_EQ(meta.at("convolution_size"), 8);
    EXPECT_EQ(meta.at("verify").at("failed"), 0);
    // The measured difference says what it is against: a cross is convolved as given.
    EXPECT_EQ(meta.at("verify").at("reference"), "the exact convolution of the source cube as given");
    EXPECT_GT(meta.at("sh_comparison").at("max_relative").get<double>(), 0);
    const env::Image cross = env::read_exr_rgb(path("a/irradiance.exr"));
    EXPECT_EQ(cross.width, 16u);
    // An equirectangular ENV is resampled to a cube first, and that cube is what --verify convolves exactly.
    env::Image equirect(32, 16, {"R", "G", "B"});
    for (float& v : equirect.data) v = 1.5f;
    env::write_exr(path("latlong.exr"), equirect, {});
    r = ms::testing::run_shell(std::string(MICROSHADOW_CLI) + " ibl irradiance " + path("latlong.exr") + " --out " + path("e") +
                               " --face-size 4 --source-size 8 --verify 2 --quiet 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    nlohmann::json emeta;
    std::ifstream(path("e/irradiance.json")) >> emeta;
    EXPECT_NE(emeta.at("verify").at("reference").get<std::string>().find("resampled cube"), std::string::npos) << emeta.at("verify");
    r = ms::testing::run_shell(cli + " --out " + path("b") + " --face-size 4 --format ktx2 --quiet 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(std::filesystem::exists(path("b/irradiance.ktx2")));
    r = ms::testing::run_shell(std::string(MICROSHADOW_CLI) + " ibl irradiance --out " + path("c") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
