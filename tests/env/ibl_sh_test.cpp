// Environment maps and irradiance: the mappings and exact solid angles, SH of analytic
// functions, a constant environment's exact SH irradiance, SH against brute-force irradiance on a
// low-frequency environment, the irradiance cubemap, the Radiance RGBE reader and the CLI.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>

#include "cli_runner.hpp"
#include "core/types.hpp"
#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/preview.hpp"
#include "env/sh.hpp"
#include "env/sphere.hpp"
#include "jobs/ibl_env.hpp"

namespace {

using namespace ms;
using ms::testing::run_shell;
using ms::kPi;

env::Image equirect(std::uint32_t w, const std::function<std::array<double, 3>(const env::Dir&)>& f) {
    env::Image img(w, w / 2, {"R", "G", "B"});
    for (std::uint32_t y = 0; y < img.height; ++y)
        for (std::uint32_t x = 0; x < img.width; ++x) {
            const auto v = f(env::equirect_direction((x + 0.5) / img.width, (y + 0.5) / img.height));
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = float(v[c]);
        }
    return img;
}

TEST(IblSphere, MappingsRoundTripAndSolidAnglesSumToFourPi) {
    double total = 0;
    for (std::uint32_t y = 0; y < 37; ++y) total += 80 * env::equirect_texel_solid_angle(y, 80, 37);
    EXPECT_NEAR(total, 4 * kPi, 1e-12);
    double cube = 0;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < 7; ++y)
            for (std::uint32_t x = 0; x < 7; ++x) cube += env::cube_texel_solid_angle(x, y, 7);
    EXPECT_NEAR(cube, 4 * kPi, 1e-12);
    // The image centre looks down -Z, the top row is +Y.
    const env::Dir c = env::equirect_direction(0.5, 0.5);
    EXPECT_NEAR(c.z, -1, 1e-12);
    EXPECT_NEAR(env::equirect_direction(0.3, 0).y, 1, 1e-12);
    for (int f = 0; f < 6; ++f)
        for (double s : {-0.9, 0.1, 0.7})
            for (double t : {-0.5, 0.3}) {
                const env::Dir d = env::cube_direction(f, s, t);
                int g;
                double s2, t2;
                env::cube_face_st(d, g, s2, t2);
                EXPECT_EQ(g, f);
                EXPECT_NEAR(s2, s, 1e-12);
                EXPECT_NEAR(t2, t, 1e-12);
                double u, v;
                env::equirect_uv(d, u, v);
                const env::Dir e = env::equirect_direction(u, v);
                EXPECT_NEAR(e.x * d.x + e.y * d.y + e.z * d.z, 1, 1e-12);
            }
}

// SH of analytic functions, projected exactly (the product rule is exact for these polynomials).
TEST(IblSh, AnalyticFunctions) {
    // Each basis function projects onto itself (orthonormality).
    for (int k = 0; k < 9; ++k) {
        const env::Sh9 sh = env::sh_project_function([k](const env::Dir& d) {
            const double v = env::sh_basis(d)[k];
            return std::array<double, 3>{v, 2 * v, 0};
        });
        for (int j = 0; j < 9; ++j) {
            EXPECT_NEAR(sh[j][0], j == k ? 1 : 0, 1e-12) << k << " " << j;
            EXPECT_NEAR(sh[j][1], j == k ? 2 : 0, 1e-12);
        }
    }
    // z^2 = 1/3 + (2/3) P2(z): L00 = (4 pi / 3) Y00, L20 = sqrt(5 / (16 pi)) * 16 pi / 15, the rest 0.
    const env::Sh9 z2 = env::sh_project_function([](const env::Dir& d) { return std::array<double, 3>{d.z * d.z, 0, 0}; });
    EXPECT_NEAR(z2[0][0], 4 * kPi / 3 * 0.5 / std::sqrt(kPi), 1e-12);
    EXPECT_NEAR(z2[6][0], std::sqrt(5 / (16 * kPi)) * 16 * kPi / 15, 1e-12);
    for (int k : {1, 2, 3, 4, 5, 7, 8}) EXPECT_NEAR(z2[k][0], 0, 1e-12);
    // Irradiance of L = 1 + z (band-limited to l = 1, so the clamped-cosine convolution is exact):
    // E(n) = pi + (2 pi / 3) n_z.
    const env::Sh9 lin = env::sh_project_function([](const env::Dir& d) { return std::array<double, 3>{1 + d.z, 1, 0}; });
    for (const env::Dir& n : {env::Dir{0, 0, 1}, env::Dir{1, 0, 0}, env::Dir{0, 0.6, -0.8}}) {
        EXPECT_NEAR(env::sh_irradiance(lin, n)[0], kPi + 2 * kPi / 3 * n.z, 1e-12);
        EXPECT_NEAR(env::sh_irradiance(lin, n)[1], kPi, 1e-12);
    }
    // Irradiance of L = z^2 at the pole: int z^2 cos = 2 pi / 4 = pi / 2, and SH order 2 holds it exactly.
    EXPECT_NEAR(env::sh_irradiance(z2, {0, 0, 1})[0], kPi / 2, 1e-12);
}

// A constant environment: Y00 only, and the SH irradiance is exactly pi times the radiance at every
// normal (each texel's basis integrals are exact, so the projection of a piecewise-constant image is).
TEST(IblSh, ConstantEnvironmentIsExact) {
    const env::Image img = equirect(64, [](const env::Dir&) { return std::array<double, 3>{0.25, 1.0, 3.0}; });
    const IrradianceResult r = compute_irradiance(img, 8);
    const double y00 = 0.5 / std::sqrt(kPi);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.sh[0][c], 4 * kPi * y00 * img.at(0, 0, c), 1e-12);
    for (int k = 1; k < 9; ++k)
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.sh[k][c], 0, 1e-12) << k;
    for (const env::Dir& n : {env::Dir{0, 1, 0}, env::Dir{0.6, 0, 0.8}, env::Dir{0, -1, 0}})
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(env::sh_irradiance(r.sh, n)[c], kPi * img.at(0, 0, c), 1e-12);
    EXPECT_LT(r.max_relative_sh_error, 3e-3);  // brute force at 26 normals: texel-centre cosines cut the horizon (64 x 32)
    // The irradiance cubemap holds E / pi = the radiance on every face texel.
    for (int f = 0; f < 6; ++f) {
        std::uint32_t ox, oy;
        cross_face_origin(f, 8, ox, oy);
        for (std::uint32_t y = 0; y < 8; ++y)
            for (std::uint32_t x = 0; x < 8; ++x) EXPECT_NEAR(r.irradiance_cross.at(ox + x, oy + y, 2), 3.0, 2e-6);
    }
}

// A low-frequency sky (a linear gradient plus an l = 2 term) from an equirectangular image: SH
// irradiance against brute force over the texels; they differ only by the discretisation of the image.
TEST(IblSh, LowFrequencyEnvironmentAgainstBruteForce) {
    const env::Image img = equirect(256, [](const env::Dir& d) {
        return std::array<double, 3>{1 + 0.8 * d.y + 0.3 * d.x, 0.5 + 0.3 * d.x * d.z + 0.2 * d.x * d.y + 0.1 * (d.x * d.x - d.y * d.y),
                                     2 + d.z + 0.4 * d.y * d.z};
    });
    const env::Sh9 sh = env::sh_project_equirect(img);
    for (const env::Dir& n : {env::Dir{0, 1, 0}, env::Dir{0.6, 0, 0.8}, env::Dir{0, -0.6, 0.8}, env::Dir{-1, 0, 0},
                              env::Dir{0.48, 0.6, 0.64}, env::Dir{-0.6, 0.64, -0.48}}) {
        const auto a = env::sh_irradiance(sh, n);
        const auto b = env::irradiance_brute_force(img, n);
        // Exact values (l = 1 terms scale by 2/3, the traceless l = 2 terms by 1/4): every basis function of
        // the equirectangular projection's closed forms is exercised.
        const double exact[3] = {kPi * (1 + 2.0 / 3 * (0.8 * n.y + 0.3 * n.x)),
                                 kPi * (0.5 + 0.25 * (0.3 * n.x * n.z + 0.2 * n.x * n.y + 0.1 * (n.x * n.x - n.y * n.y))),
                                 kPi * (2 + 2.0 / 3 * n.z + 0.25 * 0.4 * n.y * n.z)};
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR(a[c], exact[c], 2e-4 * exact[c]) << c;  // SH: exact up to the image's float storage
            EXPECT_NEAR(b[c], exact[c], 2e-3 * exact[c]) << c;  // brute force: the horizon cut through texels
        }
    }
}

// A Radiance RGBE file, flat and run-length encoded scanlines.
// The shader constants (cmgen --sh-shader's form): parsed back from the generated GLSL and HLSL, the
// polynomial sum max(0, sum K_k P_k(n)) equals the SH irradiance E(n) / pi of the coefficients at
// normals through axes, diagonals and generic directions (to the 9 printed digits).
TEST(IblSh, ShaderConstantsEvaluateToTheShIrradiance) {
    const env::Sh9 sh = env::sh_project_function([](const env::Dir& d) {
        return std::array<double, 3>{2 + d.z + 0.5 * d.x * d.y, 1 + 0.3 * d.y - 0.2 * d.x * d.z, 1.5 + 0.4 * (3 * d.z * d.z - 1) + 0.1 * d.x};
    });
    for (const char* file : {"sh.glsl", "sh.hlsl"}) {
        const std::string text = sh_shader_source(sh, file, "sky_sh", "   test");
        EXPECT_NE(text.find("sky_sh_irradiance"), std::string::npos);
        EXPECT_NE(text.find(std::string(file) == std::string("sh.glsl") ? "const vec3 sky_sh[9] = vec3[9](" : "static const float3 sky_sh[9] = {"),
                  std::string::npos)
            << text;
        // The nine constants: the numbers inside the nine "vec3(" / "float3(" after the array's name.
        std::array<std::array<double, 3>, 9> k{};
        std::size_t at = text.find("sky_sh[9]");
        for (int i = 0; i < 9; ++i) {
            at = text.find("(", text.find(std::string(file) == std::string("sh.glsl") ? "vec3(" : "float3(", at + 1));
            const char* p = text.c_str() + at + 1;
            for (int c = 0; c < 3; ++c) {
                char* end;
                k[i][c] = std::strtod(p, &end);
                p = end + 1;
            }
        }
        for (const env::Dir n : {env::Dir{0, 0, 1}, env::Dir{1, 0, 0}, env::Dir{0, -1, 0}, env::Dir{0.6, 0.8, 0}, env::Dir{0.48, -0.6, 0.64}}) {
            const std::array<double, 3> e = env::sh_irradiance(sh, n);
            const double p[9] = {1, n.y, n.z, n.x, n.x * n.y, n.y * n.z, 3 * n.z * n.z - 1, n.x * n.z, n.x * n.x - n.y * n.y};
            for (int c = 0; c < 3; ++c) {
                double sum = 0;
                for (int i = 0; i < 9; ++i) sum += k[i][c] * p[i];
                EXPECT_NEAR(std::max(0.0, sum), std::max(0.0, e[c] / 3.14159265358979323846), 1e-8) << file << " channel " << c;
            }
        }
    }
    EXPECT_THROW(check_sh_shader_output("sh.txt", "a"), std::invalid_argument);
    EXPECT_THROW(check_sh_shader_output("sh.glsl", "2x"), std::invalid_argument);
}

// Cross previews name each face (white on a black shadow, at the face's top-left) and the tone map.
TEST(IblPreview, CrossFacesAreLabelledAndTheToneMapNamed) {
    env::Image cross(16, 12, {"R", "G", "B"});
    for (float& v : cross.data) v = 1.0f;  // Reinhard: 0.5, sRGB ~188 everywhere
    const env::Canvas c = env::cross_preview_canvas(cross, 1.0, "test");
    const std::uint32_t face = 4 * 24;  // 16 texels magnified 24x to 384 pixels: faces of 96
    for (int f = 0; f < 6; ++f) {
        std::uint32_t fx, fy;
        env::cross_face_offset(f, face, fx, fy);
        int white = 0, black = 0;
        for (std::uint32_t y = fy; y < fy + 20; ++y)
            for (std::uint32_t x = fx; x < fx + 40; ++x) {
                const std::uint8_t v = c.rgb[(std::size_t(y) * c.width + x) * 3];
                white += v == 255, black += v == 0;
            }
        EXPECT_GT(white, 10) << "face " << f;
        EXPECT_GT(black, 10) << "face " << f;
    }
    // Away from the labels the tone-mapped grey is untouched.
    EXPECT_EQ(c.rgb[(std::size_t(150) * c.width + 150) * 3], c.rgb[(std::size_t(160) * c.width + 160) * 3]);
    EXPECT_EQ(env::tone_map_caption(2), "Reinhard x / (1 + x), sRGB, exposure 2");
}

TEST(IblImage, ReadsRadianceRgbe) {
    const std::string path = ::testing::TempDir() + "/microshadow_ibl_rgbe.hdr";
    {
        std::ofstream f(path, std::ios::binary);
        f << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 8\n";
        // Row 0: new-style RLE, 8 pixels: R = run of 8 x 128, G = literal 0..7 x 16, B = run of 8 x 64, E = run of 8 x 129.
        const unsigned char head[4] = {2, 2, 0, 8};
        f.write((const char*)head, 4);
        const unsigned char r[2] = {128 + 8, 128};
        f.write((const char*)r, 2);
        unsigned char g[9] = {8};
        for (int i = 0; i < 8; ++i) g[1 + i] = (unsigned char)(16 * i);
        f.write((const char*)g, 9);
        const unsigned char b[2] = {128 + 8, 64}, e[2] = {128 + 8, 129};
        f.write((const char*)b, 2);
        f.write((const char*)e, 2);
        // Row 1: flat pixels (first byte not 2): (1, 1, 1, 128) = 1.5 / 256 * 2^0 ... i.e. (m + 0.5) 2^(e - 136).
        for (int i = 0; i < 8; ++i) {
            const unsigned char px[4] = {1, 2, 3, 128};
            f.write((const char*)px, 4);
        }
    }
    const env::Image img = env::read_rgbe(path);
    ASSERT_EQ(img.width, 8u);
    ASSERT_EQ(img.height, 2u);
    EXPECT_FLOAT_EQ(img.at(3, 0, 0), 128.5f * std::ldexp(1.0f, 129 - 136));
    EXPECT_FLOAT_EQ(img.at(3, 0, 1), 48.5f * std::ldexp(1.0f, 129 - 136));
    EXPECT_FLOAT_EQ(img.at(5, 0, 2), 64.5f * std::ldexp(1.0f, 129 - 136));
    EXPECT_FLOAT_EQ(img.at(7, 1, 2), 3.5f * std::ldexp(1.0f, 128 - 136));
    std::remove(path.c_str());
}

TEST(IblShCli, WritesCoefficientsAndIrradianceCross) {
    const std::string dir = ::testing::TempDir() + "/microshadow_ibl_sh_cli";
    std::filesystem::create_directories(dir);
    const env::Image img = equirect(64, [](const env::Dir& d) { return std::array<double, 3>{1 + d.y, 1, 1}; });
    env::write_exr(dir + "/env.exr", img, {{"note", "test"}});
    const auto res = run_shell(std::string(MICROSHADOW_CLI) + " ibl sh " + dir + "/env.exr --out " + dir + "/sh.json --irradiance " + dir +
                               "/irr.exr --face-size 4 2>&1");
    ASSERT_EQ(res.exit_code, 0) << res.output;
    std::ifstream in(dir + "/sh.json");
    const auto meta = nlohmann::json::parse(in);
    EXPECT_EQ(meta.at("radiance_sh").size(), 9u);
    // Irradiance SH of 1 + y: E = pi + (2 pi / 3) n_y, so the Y1-1 coefficient of E is (2 pi / 3) sqrt(4 pi / 3).
    // (64 x 32 texels sampled at their centres: 1e-3 relative.)
    EXPECT_NEAR(meta.at("irradiance_sh")[1][0].get<double>(), 2 * kPi / 3 * std::sqrt(4 * kPi / 3), 5e-3);
    const env::Image irr = env::read_exr_rgb(dir + "/irr.exr");
    EXPECT_EQ(irr.width, 16u);
    EXPECT_EQ(irr.height, 12u);
    std::filesystem::remove_all(dir);
}

}  // namespace
