// The DFG LUT: the quadrature oracle against closed forms, the VNDF kernel against the
// quadrature within Bonferroni-t error bars, the LUT's physical bounds and white furnace, published
// values (three.js) quoted as facts, the job's verification, and the CLI's file with its metadata.
#include <gtest/gtest.h>

#include <microshadow/microshadow.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "cli_runner.hpp"
#include "core/estimate.hpp"
#include "env/image.hpp"
#include "integrands/dfg/dfg_integrand.hpp"
#include "integrands/dfg/dfg_quadrature.hpp"
#include "jobs/ibl_dfg.hpp"
#include "lut/formats/texture_writer.hpp"
#include "schedule/scheduler.hpp"

namespace {

using namespace ms;
using ms::testing::run_shell;

// IEEE 754 binary16 to double (three.js stores its table as half floats).
double half_to_double(std::uint16_t h) {
    const int e = (h >> 10) & 0x1f, m = h & 0x3ff;
    const double v = e == 0 ? std::ldexp(m, -24) : std::ldexp(1024 + m, e - 25);
    return (h & 0x8000) ? -v : v;
}

TEST(IblDfgQuadrature, GaussLegendreIntegratesPolynomialsExactly) {
    std::vector<double> x, w;
    dfg::gauss_legendre(7, x, w);
    double s0 = 0, s12 = 0, s13 = 0;
    for (int i = 0; i < 7; ++i) s0 += w[i], s12 += w[i] * std::pow(x[i], 12), s13 += w[i] * std::pow(x[i], 13);
    EXPECT_NEAR(s0, 2, 1e-14);
    EXPECT_NEAR(s12, 2.0 / 13, 1e-14);  // degree 12 <= 2n - 1 = 13
    EXPECT_NEAR(s13, 0, 1e-14);
}

// Closed form: at alpha = 1 GGX is D = 1 / pi, and at NdotV = 1 with height-correlated Smith
// G2 = 2 NdotL / (1 + NdotL), so E = (1 / 4 pi) int G2 dL = 1 - ln 2.
TEST(IblDfgQuadrature, ClosedFormAtAlphaOneNormalIncidence) {
    const dfg::DfgQuadrature q = dfg::dfg_quadrature(1.0, 1.0);
    EXPECT_NEAR(q.scale + q.bias, 1 - std::log(2.0), 1e-10);
    EXPECT_LT(q.scale_error + q.bias_error, 1e-9);
}

// Smooth-surface limit: alpha -> 0 gives a mirror, L = reflect(V), VdotH = NdotV, G2 -> 1, so
// scale -> 1 - (1 - v)^5 and bias -> (1 - v)^5; the deviation shrinks with alpha.
TEST(IblDfgQuadrature, MirrorLimit) {
    for (double v : {0.1, 0.5, 0.9}) {
        const double fc = std::pow(1 - v, 5);
        const dfg::DfgQuadrature q = dfg::dfg_quadrature(v, 1e-4);
        EXPECT_NEAR(q.scale, 1 - fc, 1e-5) << v;
        EXPECT_NEAR(q.bias, fc, 1e-5) << v;
    }
}

// Converged to 1e-9 (its own two-order estimate) over the texel centres of a 16 x 16 LUT, with
// scale + bias <= 1 and both non-negative.
TEST(IblDfgQuadrature, ConvergedAndBoundedOverALut) {
    double worst = 0;
    for (int y = 0; y < 16; y += 3)
        for (int x = 0; x < 16; x += 3) {
            const double r = (y + 0.5) / 16, v = (x + 0.5) / 16;
            const dfg::DfgQuadrature q = dfg::dfg_quadrature(v, r * r);
            worst = std::max({worst, q.scale_error, q.bias_error});
            EXPECT_GE(q.scale, 0);
            EXPECT_GE(q.bias, 0);
            EXPECT_LE(q.scale + q.bias, 1 + 1e-9) << v << " " << r;
        }
    EXPECT_LT(worst, 1e-8);
}

// Published values quoted as facts. three.js r18x, src/renderers/shaders/DFGLUTData.js (stored
// version at commit 07e4c12b3840c9e30669924fe3e7528515a77cea of mrdoob/three.js, MIT licence):
// "Resolution: 16x16, Samples: 4096 per texel, Format: RG16F (scale, bias)"; the shader samples it at
// vec2(roughness, dotNV), so texel (x, y) holds roughness (x + 0.5) / 16 and NdotV (y + 0.5) / 16, and
// DATA[(y * 16 + x) * 2 + {0, 1}] are scale and bias as IEEE half floats. A handful of texels, quoted
// verbatim, with the quadrature's values at the same parameters:
struct Published {
    int x, y;                   // roughness index, NdotV index
    std::uint16_t scale, bias;  // three.js's half floats
    double scale_error;         // three.js scale minus the quadrature, measured (the report's figure)
};
const Published kThreeJs[] = {
    {0, 0, 0x30b5, 0x3ad1, -0.00025},   // r 0.03125, NdotV 0.03125
    {4, 0, 0x37f3, 0x36a6, -0.01424},   // r 0.28125, NdotV 0.03125: the worst texel of the table
    {5, 0, 0x38d1, 0x3539, -0.01398},
    {15, 0, 0x3ae1, 0x28ff, +0.00229},
    {4, 1, 0x3839, 0x35a4, -0.00576},   // r 0.28125, NdotV 0.09375: the worst of the second row
    {7, 7, 0x3ac2, 0x27b7, -0.00004},   // r 0.46875, NdotV 0.46875
    {15, 15, 0x3586, 0x049f, +0.00002}, // r 0.96875, NdotV 0.96875
};

TEST(IblDfgPublished, ThreeJsTableIsOffAtGrazingNdotV) {
    double worst = 0;
    for (const auto& p : kThreeJs) {
        const double r = (p.x + 0.5) / 16, v = (p.y + 0.5) / 16;
        const dfg::DfgQuadrature q = dfg::dfg_quadrature(v, r * r);
        const double s = half_to_double(p.scale), b = half_to_double(p.bias);
        // The measured difference, to the half float's resolution (2^-11 relative) plus 2e-5.
        EXPECT_NEAR(s - q.scale, p.scale_error, 2e-5 + s * std::ldexp(1.0, -11)) << p.x << "," << p.y;
        // The bias is within 7e-4 everywhere in the table (the report's figure).
        EXPECT_NEAR(b, q.bias, 7e-4) << p.x << "," << p.y;
        worst = std::max(worst, std::abs(s - q.scale));
    }
    // three.js's table "off by up to about 0.014 at grazing NdotV": 0.0142 at NdotV = 1/32, roughness 9/32,
    // 36x the 4e-4 that 4096 stratified samples and half storage account for.
    EXPECT_GT(worst, 0.014);
    EXPECT_LT(worst, 0.0145);
}

// The kernel against the quadrature at 8 x 8 texel centres (texels far from the grid's ends are the
// ones a LUT interpolates), 2^16 samples: every channel within t * se + the quadrature's error + 2e-6
// (float sums), t the Student-t quantile at 1 - 0.001 / (3 * 64) (Bonferroni).
TEST(IblDfgKernel, WithinErrorBarsOfTheQuadrature) {
    std::vector<dfg::DfgPoint> points;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            const double r = (y + 0.5) / 8;
            points.push_back({(x + 0.5) / 8, r * r});
        }
    SamplingPlan plan{Sequence::sobol, 65536, 8, 3};
    dfg::DfgIntegrand device(points, 8, plan);
    schedule::Scheduler gpu(schedule::Backend::opencl(ocl::select_devices("default")));
    gpu.run(device);
    dfg::DfgIntegrand oracle(points, 8, plan);
    schedule::Scheduler cpu(schedule::Backend::oracle(2));
    cpu.run(oracle);
    const double t = student_t_quantile(1 - 0.001 / (3.0 * points.size()), 7);
    double worst_z = 0, worst_diff = 0, max_se = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const auto& a = device.values()[i];
        const auto& b = oracle.values()[i];
        const Estimate* ea[3] = {&a.scale, &a.bias, &a.albedo};
        const Estimate* eb[3] = {&b.scale, &b.bias, &b.albedo};
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(ea[c]->term - eb[c]->term);
            const double bound = t * ea[c]->std_error + eb[c]->std_error + 2e-6;
            EXPECT_LE(diff, bound) << "point " << i << " channel " << c << ": " << ea[c]->term << " vs " << eb[c]->term;
            worst_diff = std::max(worst_diff, diff);
            max_se = std::max(max_se, ea[c]->std_error);
            if (ea[c]->std_error > 0) worst_z = std::max(worst_z, diff / ea[c]->std_error);
        }
    }
    std::printf("[ dfg ] 64 texels, 2^16 samples: worst |kernel - quadrature| %.2e, max se %.2e, worst z %.2f (t %.2f)\n",
                worst_diff, max_se, worst_z, t);
    // The error bars are honest and small: 2^16 scrambled samples resolve the LUT to ~1e-5.
    EXPECT_LT(max_se, 3e-5);
}

// The bake: bounds, the white furnace of the energy-compensated form, the exact roughness-0 row with
// endpoints, verification against the oracle, and the file with its metadata through the CLI.
class IblDfgBake : public ms::testing::ScratchDirTest {
protected:
    IblDfgBake() : ScratchDirTest("ibl_dfg") {}
};

TEST_F(IblDfgBake, BoundsWhiteFurnaceAndVerification) {
    DfgBakeSpec spec;
    spec.n_dot_v.count = 12;
    spec.roughness.count = 10;
    spec.plan.samples = 16384;
    spec.n_dot_v.texel = spec.roughness.texel = TexelConvention::endpoints;
    const DfgBakeResult r = bake_dfg(spec);
    const double t = student_t_quantile(0.999, 7);
    for (std::uint32_t y = 0; y < r.height; ++y)
        for (std::uint32_t x = 0; x < r.width; ++x) {
            const auto& v = r.at(x, y);
            // scale + bias <= 1 (within error bars): a BRDF with F = 1 reflects at most what arrives.
            EXPECT_LE(v.albedo.term, 1 + t * v.albedo.std_error + 1e-6) << x << "," << y;
            EXPECT_NEAR(v.albedo.term, v.scale.term + v.bias.term, 1e-12);
            // White furnace of the energy-compensated form (Filament: specular * (1 + F0 (1/E - 1))):
            // with F0 = 1 the compensated albedo E (1 + (1/E - 1)) is exactly 1 for every view and roughness.
            const double compensated = (v.scale.term + v.bias.term) * (1 + 1.0 * (1 / v.albedo.term - 1));
            EXPECT_NEAR(compensated, 1.0, 1e-12);
        }
    // Roughness 0 (endpoints): the exact mirror limit, not sampled.
    for (std::uint32_t x = 0; x < r.width; ++x) {
        const double v = std::max(spec.n_dot_v.value(x), kMinNdotV);
        EXPECT_EQ(r.exact[x], 1);
        EXPECT_DOUBLE_EQ(r.at(x, 0).bias.term, std::pow(1 - v, 5));
    }
    const DfgVerification check = verify_dfg(spec, r, 12);
    EXPECT_EQ(check.checked, 12u);
    EXPECT_EQ(check.failed, 0u) << check.worst_texel;
}

TEST_F(IblDfgBake, CliWritesTheExrWithMetadataAndPreview) {
    const std::string out = path("dfg.exr"), png = path("dfg.png");
    const auto res = run_shell(std::string(MICROSHADOW_CLI) + " ibl dfg --method sampled --out " + out + " --size 8 --samples 4096 --verify 4 --preview " +
                               png + " 2>&1");
    ASSERT_EQ(res.exit_code, 0) << res.output;
    nlohmann::json meta;
    const env::Image img = env::read_exr_rgb(out, &meta);
    EXPECT_EQ(img.width, 8u);
    EXPECT_EQ(img.height, 8u);
    EXPECT_EQ(meta.at("layout"), "dfg");
    EXPECT_EQ(meta.at("samples"), 4096);
    EXPECT_EQ(meta.at("verify").at("failed"), 0);
    EXPECT_NE(meta.at("command_line").get<std::string>().find("ibl dfg"), std::string::npos);
    // Row y = roughness, x = NdotV: at the smallest roughness the scale grows with NdotV.
    EXPECT_LT(img.at(0, 0, 0), img.at(7, 0, 0));
    EXPECT_TRUE(std::filesystem::exists(png));
    // The C header: the same texels, the metadata in a comment.
    const auto hdr = run_shell(std::string(MICROSHADOW_CLI) + " ibl dfg --method sampled --out " + path("dfg.h") + " --size 8 --samples 4096 --quiet 2>&1");
    ASSERT_EQ(hdr.exit_code, 0) << hdr.output;
    std::ifstream h(path("dfg.h"));
    const std::string text((std::istreambuf_iterator<char>(h)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("#define MICROSHADOW_DFG_WIDTH 8u"), std::string::npos);
    EXPECT_NE(text.find("static const char microshadow_dfg_metadata[]"), std::string::npos);
    // The first value of the array (texture_writer.hpp's C convention): same seed, same bits.
    const std::string first = "static const float microshadow_dfg_data[MICROSHADOW_DFG_DEPTH * MICROSHADOW_DFG_HEIGHT * "
                              "MICROSHADOW_DFG_WIDTH * 3u] = {\n    " +
                              ms::lutfmt::c_float_literal(img.at(0, 0, 0));
    EXPECT_NE(text.find(first), std::string::npos) << first;
    // An extension with no writer is refused with a message naming the formats (KTX2 / DDS: ibl_formats_test).
    const auto tga = run_shell(std::string(MICROSHADOW_CLI) + " ibl dfg --out " + path("dfg.tga") +
                               " --size 4 --samples 1024 --quiet 2>&1");
    EXPECT_NE(tga.exit_code, 0);
    EXPECT_NE(tga.output.find(".ktx2"), std::string::npos) << tga.output;
}

}  // namespace

// The public API's DFG bake (include/microshadow/ibl.hpp) gives the DFG job's texels.
namespace {
TEST(LibraryApi, BakeDfgGivesTheDfgJobsTexels) {
    microshadow::DfgOptions o;
    o.size = 3;
    o.samples = 256;
    o.replicates = 4;
    o.backend = microshadow::Backend::oracle;
    const microshadow::DfgLut lut = microshadow::bake_dfg(o);
    ms::DfgBakeSpec spec;
    spec.n_dot_v.count = spec.roughness.count = 3;
    spec.plan.samples = 256, spec.plan.replicates = 4;
    spec.method = ms::DfgMethod::quadrature;
    const ms::DfgBakeResult want = ms::bake_dfg(spec);
    const std::vector<double> got = lut.values();
    ASSERT_EQ(got.size(), 27u);
    EXPECT_EQ(got[(2 * 3 + 1) * 3 + 0], want.at(1, 2).scale.term);  // [roughness][n_dot_v][scale, bias, E]
    EXPECT_EQ(got[(2 * 3 + 1) * 3 + 2], want.at(1, 2).albedo.term);
    EXPECT_EQ(lut.n_dot_v_values(), spec.n_dot_v.values());
}

// The CLI's --method, --channels and --parameterization reach the job through the public options: the
// channels come back in the asked order, the axis as NdotV.
TEST(LibraryApi, BakeDfgTakesMethodChannelsAndParameterization) {
    microshadow::DfgOptions o;
    o.size = 3;
    o.method = "exact";
    o.channels = "E,sheen";
    o.parameterization = "sqrt-n-dot-v";
    const microshadow::DfgLut lut = microshadow::bake_dfg(o);
    ms::DfgBakeSpec spec;
    spec.n_dot_v.count = spec.roughness.count = 3;
    spec.method = ms::DfgMethod::exact;
    spec.channels = {ms::DfgChannel::albedo, ms::DfgChannel::sheen};
    spec.parameterization = ms::DfgParameterization::sqrt_n_dot_v;
    const ms::DfgBakeResult want = ms::bake_dfg(spec);
    EXPECT_EQ(lut.channels(), (std::vector<std::string>{"E", "sheen"}));
    const std::vector<double> got = lut.values();
    ASSERT_EQ(got.size(), 18u);
    EXPECT_EQ(got[(2 * 3 + 1) * 2 + 0], want.at(1, 2).albedo.term);  // [roughness][n_dot_v][E, sheen]
    EXPECT_EQ(got[(2 * 3 + 1) * 2 + 1], want.at(1, 2).sheen.term);
    EXPECT_DOUBLE_EQ(lut.n_dot_v_values()[1], 0.5 * 0.5);  // texel centre 0.5 holds NdotV 0.25
    o.backend = microshadow::Backend::oracle;  // the quadrature's older spelling contradicts exact
    EXPECT_THROW(microshadow::bake_dfg(o), std::invalid_argument);
}

}  // namespace
