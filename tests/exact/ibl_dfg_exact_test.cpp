// The deterministic DFG path (exact/dfg_exact.*): closed forms, the independent quadrature of
// integrands/dfg/dfg_quadrature.* over a LUT's texels to 1e-10, and the sheen channel against closed
// forms and against plain Monte Carlo written here.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "exact/dfg_exact.hpp"
#include "integrands/dfg/dfg_quadrature.hpp"
#include "jobs/ibl_dfg.hpp"

namespace {

using namespace ms;

// Charlie sheen at normal incidence has a closed form: with V = n, L.z = 2 c^2 - 1 and V_N = 1/4,
// sheen = 2 pi k int_{c > 1/sqrt 2} (1 - c^2)^m (2 c^2 - 1) c dc = (1/2)^(m + 1) / (m + 2), m = 1 / (2 alpha).
double sheen_normal_incidence(double alpha) {
    const double m = 0.5 / alpha;
    return std::pow(0.5, m + 1) / (m + 2);
}

TEST(IblDfgExact, ClosedFormsAtNormalIncidence) {
    // GGX at alpha = 1: D = 1 / pi and G2 = 2 NdotL / (1 + NdotL), so E = 1 - ln 2.
    const exact::DfgExact e = exact::dfg_exact(1.0, 1.0);
    EXPECT_NEAR(e.scale + e.bias, 1 - std::log(2.0), 1e-13);
    for (double alpha : {1.0, 0.5, 0.1, 0.01}) {
        const exact::DfgExact s = exact::dfg_exact(1.0, alpha);
        EXPECT_NEAR(s.sheen, sheen_normal_incidence(alpha), 1e-13 + 1e-12 * sheen_normal_incidence(alpha)) << alpha;
        const dfg::DfgQuadrature q = dfg::dfg_quadrature(1.0, alpha, 16, true);
        EXPECT_NEAR(q.sheen, sheen_normal_incidence(alpha), 1e-11) << alpha;
    }
}

// Over texel centres of a 64 x 64 LUT (every 21st texel each way, NdotV and roughness down to 1/128):
// the exact path and the independent quadrature (order 20) agree to 1e-10 in every channel, and the
// exact path's own error estimate (against order 12) is below 1e-10.
TEST(IblDfgExact, AgreesWithTheIndependentQuadratureTo1e10) {
    double worst = 0, worst_estimate = 0;
    for (int y = 0; y < 64; y += 21)
        for (int x = 0; x < 64; x += 21) {
            const double r = (y + 0.5) / 64, v = (x + 0.5) / 64, alpha = r * r;
            const exact::DfgExact e = exact::dfg_exact(v, alpha);
            const dfg::DfgQuadrature q = dfg::dfg_quadrature(v, alpha, 20, true);
            const double d[3] = {std::abs(e.scale - q.scale), std::abs(e.bias - q.bias), std::abs(e.sheen - q.sheen)};
            for (double di : d) worst = std::max(worst, di);
            worst_estimate = std::max({worst_estimate, e.scale_error, e.bias_error, e.sheen_error});
            EXPECT_LT(std::max({d[0], d[1], d[2]}), 1e-10) << "NdotV " << v << " roughness " << r << ": " << d[0] << " " << d[1]
                                                          << " " << d[2] << " sheen " << e.sheen << " vs " << q.sheen;
        }
    std::printf("worst |exact - quadrature| %.3g, worst exact error estimate %.3g\n", worst, worst_estimate);
    EXPECT_LT(worst_estimate, 1e-10);
}

// --verify of an exact bake: the bake as made passes both checks (the quadrature within 1e-10, the kernel
// within its bars); a texel corrupted by 1e-9 fails the deterministic check while the kernel cannot see
// it, and one corrupted by 1e-2 fails both.
TEST(IblDfgExact, VerifyCatchesACorruptedTexel) {
    DfgBakeSpec spec;
    spec.n_dot_v.count = 3;
    spec.roughness.count = 2;
    spec.method = DfgMethod::exact;
    spec.plan.samples = 16384;
    DfgBakeResult r = bake_dfg(spec);
    const DfgVerification clean = verify_dfg(spec, r, 6);
    EXPECT_EQ(clean.checked, 6u);
    EXPECT_EQ(clean.failed, 0u) << clean.worst_texel;
    EXPECT_LT(clean.worst_deterministic_diff, 1e-12);

    r.values[4].scale.term += 1e-9;
    r.values[4].albedo.term += 1e-9;
    const DfgVerification small = verify_dfg(spec, r, 6);
    EXPECT_EQ(small.failed, 1u);
    EXPECT_GT(small.worst_deterministic_diff, 9e-10);
    EXPECT_LT(small.worst_z, small.threshold);  // far inside the kernel's bars
    EXPECT_NE(small.worst_deterministic_texel.find("texel (1, 1) scale"), std::string::npos) << small.worst_deterministic_texel;

    r.values[4].scale.term += 1e-2;
    const DfgVerification large = verify_dfg(spec, r, 6);
    EXPECT_EQ(large.failed, 1u);
    EXPECT_GT(large.worst_z, large.threshold);
}

}  // namespace
