// Tests of the scalar double-precision oracle (host/oracle/): every fact docs/method.md states about the
// generic VNDF-based micro-shadowing term, checked on the oracle alone.
//
// Tolerances: Monte Carlo estimates are compared with t * std_error, t the two-sided 99.9% Student-t
// quantile with replicates - 1 degrees of freedom (student_t_quantile); exact facts (v = 1, v = 0, the
// early-out zeros, below-horizon zeros) are compared exactly; identities that only differ by rounding
// get a bound derived from the number of floating-point operations; deterministic quadratures are
// checked against their own a-posteriori error (coarse vs fine); the sampler is checked by a
// chi-square test against a quantile computed for its degrees of freedom. All randomness is seeded.
#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/estimate.hpp"
#include "core/types.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"

namespace {

using namespace ms;
namespace o = ms::oracle;

using ms::kPi;
constexpr double kConfidence = 0.999;

Vec3 spherical(double cos_theta, double phi) {
    const double s = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// A random direction: the azimuth is drawn first, then cos_theta = cos_of(u) (or a fixed value that
// draws nothing). Spelled out because spherical(f(U(rng)), g(U(rng))) leaves the order of the two draws
// to the compiler (GCC and clang differ), and with it the test's queries.
template <class CosOf>
Vec3 random_direction(std::mt19937_64& rng, CosOf cos_of) {
    std::uniform_real_distribution<double> U(0, 1);
    const double phi = 2 * kPi * U(rng);
    return spherical(cos_of(U), phi);
}

PointSet points(std::uint64_t samples, std::uint32_t replicates, std::uint64_t seed,
                Sequence sequence = Sequence::sobol) {
    SamplingPlan plan;
    plan.sequence = sequence;
    plan.samples = samples;
    plan.replicates = replicates;
    plan.seed = seed;
    return make_point_set(plan);
}

// Error bar of an estimate from `replicates` independent randomisations.
double error_bar(const Estimate& e, std::uint32_t replicates) {
    return student_t_quantile(kConfidence, int(replicates) - 1) * e.std_error;
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton iteration on P_n).
struct GaussLegendre {
    std::vector<double> x, w;
    explicit GaussLegendre(int n) : x(n), w(n) {
        for (int i = 0; i < n; ++i) {
            double z = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 0;
            for (int it = 0; it < 100; ++it) {
                double p0 = 1, p1 = z;
                for (int k = 2; k <= n; ++k) {
                    const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n * (z * p1 - p0) / (z * z - 1);
                const double dz = p1 / dp;
                z -= dz;
                if (std::fabs(dz) < 1e-16) break;
            }
            x[i] = z;
            w[i] = 2 / ((1 - z * z) * dp * dp);
        }
    }
};

// Upper quantile of the standard normal: z with P(Z > z) = tail, by bisection on erfc.
double normal_upper_quantile(double tail) {
    double lo = -40, hi = 40;
    for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(mid / std::sqrt(2.0)) > tail ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// Upper quantile of chi-square with k degrees of freedom by the Wilson-Hilferty transformation
// (chi2/k)^(1/3) ~ N(1 - 2/(9k), 2/(9k)); relative error well below 1e-3 for the k >= 50 used here.
double chi_square_upper_quantile(double tail, int k) {
    const double z = normal_upper_quantile(tail);
    const double c = 2.0 / (9.0 * k);
    return k * std::pow(1 - c + z * std::sqrt(c), 3);
}

// ---------------------------------------------------------------------------------------------
// Exact facts.

TEST(OracleTerm, ConeMappingOfBothWeightings) {
    // Part 1: cosine-weighted AO, cos_t = sqrt(1 - v); uniform-weighted AO, cos_t = 1 - v.
    EXPECT_EQ(o::cone_cos_theta(0.75, AoWeighting::cosine), 0.5);
    EXPECT_EQ(o::cone_cos_theta(0.0, AoWeighting::cosine), 1.0);
    EXPECT_EQ(o::cone_cos_theta(1.0, AoWeighting::cosine), 0.0);
    EXPECT_EQ(o::cone_cos_theta(0.25, AoWeighting::uniform), 0.75);
    EXPECT_EQ(o::cone_cos_theta(1.0, AoWeighting::uniform), 0.0);
    EXPECT_THROW(o::cone_cos_theta(1.5, AoWeighting::cosine), std::invalid_argument);
    EXPECT_THROW(o::cone_cos_theta(-0.1, AoWeighting::uniform), std::invalid_argument);
}


TEST(OracleTerm, FullVisibilityIsExactlyOne) {
    // v = 1: cos_t = 0, so the cone and hemisphere terms are the same number for every sample.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> U(0, 1);
    const PointSet ps = points(1 << 12, 4, 3);
    for (int i = 0; i < 40; ++i) {
        Query q;
        q.visibility = 1;
        q.alpha_x = 0.02 + 0.98 * U(rng);
        q.alpha_y = i % 2 ? q.alpha_x : 0.02 + 0.98 * U(rng);
        q.wi = random_direction(rng, [&](auto& u) { return 0.02 + 0.98 * u(rng); });
        q.wo = random_direction(rng, [&](auto& u) { return 0.1 + 0.9 * u(rng); });
        TermOptions opt;
        opt.form = i % 3 ? Form::height_correlated : Form::uncorrelated;
        opt.ao_weighting = i % 4 ? AoWeighting::cosine : AoWeighting::uniform;
        const o::Tally t = o::tally(q, opt, ps);
        for (double h : t.hemisphere) ASSERT_GT(h, 0.0) << "query " << i;  // the fact's precondition
        const Estimate e = o::generic_m_g(q, opt, ps);
        EXPECT_EQ(e.term, 1.0) << "query " << i;
        EXPECT_EQ(e.std_error, 0.0) << "query " << i;
    }
}

TEST(OracleTerm, ZeroVisibilityIsExactlyZero) {
    // v = 0: cos_t = 1 and clamped dot products never exceed 1, so no microfacet passes the cone.
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> U(0, 1);
    const PointSet ps = points(1 << 12, 4, 4);
    for (int i = 0; i < 40; ++i) {
        Query q;
        q.visibility = 0;
        q.alpha_x = 0.02 + 0.98 * U(rng);
        q.alpha_y = 0.02 + 0.98 * U(rng);
        q.wi = random_direction(rng, [&](auto& u) { return 0.02 + 0.98 * u(rng); });
        q.wo = i == 0 ? Vec3{0, 0, 1} : random_direction(rng, [&](auto& u) { return u(rng); });
        TermOptions opt;
        opt.ao_weighting = i % 2 ? AoWeighting::cosine : AoWeighting::uniform;
        const Estimate e = o::generic_m_g(q, opt, ps);
        EXPECT_EQ(e.term, 0.0) << "query " << i;
        EXPECT_EQ(e.std_error, 0.0) << "query " << i;
    }
}

// Both cone conditions, angle(wg,wm) < theta and angle(wm,wo) < theta, imply angle(wg,wo) < 2 theta,
// so NdotL <= cos(2 theta) = 2 cos_t^2 - 1 gives exactly 0; for cosine weighting that is 2v + NdotL <= 1.
void expect_zero_region(AoWeighting weighting, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(0, 1);
    const PointSet ps = points(1 << 10, 4, seed);
    TermOptions opt;
    opt.ao_weighting = weighting;
    int tested = 0;
    for (int i = 0; i < 250; ++i) {
        Query q;
        q.visibility = 0.5 * U(rng);  // above v = 1/2 (cosine) the region has no NdotL >= 0
        const double cos_t = o::cone_cos_theta(q.visibility, weighting);
        const double limit = 2 * cos_t * cos_t - 1;  // NdotL at most this
        // Part 2's form for cosine weighting; (1 - v)^2 for uniform weighting.
        const double expected_limit = weighting == AoWeighting::cosine ? 1 - 2 * q.visibility
                                                                       : 2 * (1 - q.visibility) * (1 - q.visibility) - 1;
        ASSERT_NEAR(limit, expected_limit, 4 * DBL_EPSILON);
        if (limit <= 0) continue;
        // Spread over the region, with every tenth query exactly on its boundary.
        const double n_dot_l = i % 10 == 0 ? limit : limit * U(rng);
        q.alpha_x = std::exp(std::log(0.005) * U(rng));  // log-uniform in (0.005, 1]
        q.alpha_y = i % 2 ? q.alpha_x : std::exp(std::log(0.005) * U(rng));
        q.wi = random_direction(rng, [&](auto& u) { return 0.01 + 0.99 * u(rng); });
        q.wo = spherical(n_dot_l, 2 * kPi * U(rng));
        opt.form = i % 3 ? Form::height_correlated : Form::uncorrelated;
        const Estimate e = o::generic_m_g(q, opt, ps);
        EXPECT_EQ(e.term, 0.0) << "v " << q.visibility << " NdotL " << n_dot_l;
        EXPECT_EQ(e.std_error, 0.0);
        ++tested;
    }
    EXPECT_GE(tested, 100);
}

TEST(OracleTerm, EarlyOutRegionIsExactlyZeroCosine) { expect_zero_region(AoWeighting::cosine, 21); }
TEST(OracleTerm, EarlyOutRegionIsExactlyZeroUniform) { expect_zero_region(AoWeighting::uniform, 22); }

TEST(OracleTerm, LightAtOrBelowHorizonGivesZeroAndNothingIsNaN) {
    const PointSet ps = points(1 << 10, 4, 5);
    for (double wo_z : {0.0, -1e-12, -0.3, -1.0}) {
        for (double v : {0.0, 0.3, 0.8, 1.0}) {
            for (Form form : {Form::height_correlated, Form::uncorrelated}) {
                Query q;
                q.visibility = v;
                q.alpha_x = 0.3;
                q.alpha_y = 0.7;
                q.wi = spherical(0.4, 1.0);
                q.wo = spherical(wo_z, 2.0);
                TermOptions opt;
                opt.form = form;
                const o::Tally t = o::tally(q, opt, ps);
                for (std::size_t r = 0; r < t.cone.size(); ++r) {
                    EXPECT_EQ(t.cone[r], 0.0);
                    EXPECT_EQ(t.hemisphere[r], 0.0);
                }
                const Estimate e = o::generic_m_g(q, opt, ps);
                EXPECT_EQ(e.term, 0.0) << "wo.z " << wo_z << " v " << v;
                EXPECT_EQ(e.std_error, 0.0);
            }
        }
    }
    // A view exactly on the horizon (NdotV = 0, an endpoint-convention LUT texel) is the continuous
    // limit of grazing views: same points, wi.z = 0 against wi.z = 1e-9 (wm moves by ~1e-9, far
    // below the error bar), and the value is a proper fraction.
    {
        const std::uint32_t replicates = 8;
        const PointSet pv = points(1 << 14, replicates, 13);
        Query q;
        q.visibility = 0.6;
        q.alpha_x = 0.3;
        q.alpha_y = 0.5;
        q.wo = spherical(0.7, 0.4);
        q.wi = {1, 0, 0};
        const Estimate e0 = o::generic_m_g(q, TermOptions{}, pv);
        q.wi = spherical(1e-9, 0.0);
        const Estimate e1 = o::generic_m_g(q, TermOptions{}, pv);
        EXPECT_TRUE(e0.term > 0 && e0.term < 1) << e0.term;
        EXPECT_NEAR(e0.term, e1.term, error_bar(e1, replicates));
        q.wi = spherical(-0.1, 0.0);
        EXPECT_THROW(o::generic_m_g(q, TermOptions{}, pv), std::invalid_argument);
    }
    // Per-microfacet pieces on arbitrary normals (including below the horizon and perpendicular to
    // wi or wo) and grazing directions: finite everywhere.
    std::mt19937_64 rng(6);
    std::uniform_real_distribution<double> U(0, 1);
    for (int i = 0; i < 20000; ++i) {
        const Vec3 wm = i % 7 == 0 ? Vec3{0, 0, 1} : random_direction(rng, [&](auto& u) { return 2 * u(rng) - 1; });
        const Vec3 wi = random_direction(rng, [&](auto& u) { return i % 5 == 0 ? 1e-9 : u(rng); });
        const Vec3 wo = random_direction(rng, [&](auto& u) { return i % 3 == 0 ? 0.0 : 2 * u(rng) - 1; });
        const double ax = 1e-4 + U(rng), ay = 1e-4 + U(rng);
        for (Form form : {Form::height_correlated, Form::uncorrelated}) {
            const o::MicrofacetTerm m = o::generic_m_m(U(rng), wm, wo, wi, ax, ay, form);
            ASSERT_TRUE(std::isfinite(m.cone) && std::isfinite(m.hemisphere) && std::isfinite(m.weight));
            ASSERT_GE(m.weight, 0.0);
            ASSERT_LE(m.weight, 1.0);
            if (!(wo.z > 0)) {
                ASSERT_EQ(m.hemisphere, 0.0);
            }
        }
        ASSERT_TRUE(std::isfinite(o::vndf_pdf(wi, wm, ax, ay)));
        const double u2 = U(rng), u1 = U(rng);  // GCC's order, made explicit
        const Vec3 s = o::sample_vndf(wi, ax, ay, u1, u2);
        ASSERT_TRUE(std::isfinite(s.x) && std::isfinite(s.y) && std::isfinite(s.z));
    }
}

// ---------------------------------------------------------------------------------------------
// The weight and Smith Lambda.

TEST(OracleTerm, BothSmithFormsGiveTheSameRatio) {
    // Under the Smith profile w = H(wo.wm) * constant (Lambda depends on the macro directions only)
    // and both terms already require wm.wo > 0: the constant cancels in the ratio. The sums are
    // compensated, so the two ratios differ only by a few rounding errors (~1e-16); 1e-12 is far
    // below any statistical difference (std errors here are ~1e-3) and far above the rounding.
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> U(0, 1);
    const PointSet ps = points(1 << 14, 4, 7);
    for (int i = 0; i < 20; ++i) {
        Query q;
        q.visibility = 0.2 + 0.8 * U(rng);
        q.alpha_x = 0.05 + 0.95 * U(rng);
        q.alpha_y = i % 2 ? q.alpha_x : 0.05 + 0.95 * U(rng);
        q.wi = random_direction(rng, [&](auto& u) { return 0.05 + 0.95 * u(rng); });
        q.wo = random_direction(rng, [&](auto& u) { return 0.05 + 0.95 * u(rng); });
        TermOptions hc, unc;
        hc.form = Form::height_correlated;
        unc.form = Form::uncorrelated;
        hc.ao_weighting = unc.ao_weighting = i % 2 ? AoWeighting::cosine : AoWeighting::uniform;
        const o::Tally th = o::tally(q, hc, ps), tu = o::tally(q, unc, ps);
        // Non-trivial: the weights differ. (1 + Li) / (1 + Li + Lo) > 1 / (1 + Lo) iff Li Lo > 0, so
        // the height-correlated weight is the larger one for any tilted wi and wo.
        ASSERT_GT(th.hemisphere[0], tu.hemisphere[0]);
        const Estimate eh = o::generic_m_g(q, hc, ps), eu = o::generic_m_g(q, unc, ps);
        ASSERT_GT(eh.term, 0.0);
        EXPECT_NEAR(eh.term, eu.term, 1e-12 * eh.term) << "query " << i;
        EXPECT_NEAR(eh.std_error, eu.std_error, 1e-9 * eh.std_error + 1e-15) << "query " << i;
        // ... and both equal the unweighted count ratio a fast path would use.
        double cone = 0, hemi = 0;
        const double cos_t = o::cone_cos_theta(q.visibility, hc.ao_weighting);
        for (std::size_t k = 0; k < ps.total(); ++k) {
            const Vec3 wm = o::sample_vndf(q.wi, q.alpha_x, q.alpha_y, ps.u1[k], ps.u2[k]);
            const o::MicrofacetTerm m = o::generic_m_m(cos_t, wm, q.wo, q.wi, q.alpha_x, q.alpha_y, hc.form);
            cone += m.cone > 0;
            hemi += m.hemisphere > 0;
        }
        EXPECT_NEAR(cone / hemi, eh.term, 1e-12 * eh.term) << "query " << i;
    }
}

TEST(OracleSmith, RoughnessProjectionEqualsDirectAnisotropicLambda) {
    // alpha_w^2 tan^2 theta = (ax^2 cos^2 phi + ay^2 sin^2 phi)(x^2 + y^2)/z^2 = (ax^2 x^2 + ay^2 y^2)/z^2.
    // Rounding bound: the projection goes through phi = atan2(y, x), whose rounding (up to eps pi in
    // absolute terms) moves cos and sin by up to eps pi each, so alpha_w^2 moves by up to
    // 2 eps pi (ax^2 |cos| + ay^2 |sin|); everything else is a handful of correctly rounded
    // operations (<= 16 eps relative), and Lambda's relative change is at most that of its argument
    // (Lambda(a) = a / (2 (1 + sqrt(1 + a))) has d ln Lambda / d ln a in (1/2, 1]). Tolerance: twice
    // that first-order bound.
    std::mt19937_64 rng(41);
    std::uniform_real_distribution<double> U(0, 1);
    for (int i = 0; i < 100000; ++i) {
        const double cz = i % 10 == 0 ? 1e-6 * U(rng) + 1e-12 : U(rng) + 1e-12;
        const Vec3 w = spherical(std::min(cz, 1.0), 2 * kPi * U(rng));
        const double ax = std::exp(std::log(1e-3) * U(rng)) * 2, ay = std::exp(std::log(1e-3) * U(rng)) * 2;
        const double lp = o::smith_lambda(w, ax, ay), ld = o::smith_lambda_anisotropic(w, ax, ay);
        const double r = std::hypot(w.x, w.y), c = std::fabs(w.x) / r, s = std::fabs(w.y) / r;
        const double alpha2 = ax * ax * c * c + ay * ay * s * s;
        const double rel = 16 * DBL_EPSILON + 2 * kPi * DBL_EPSILON * (ax * ax * c + ay * ay * s) / alpha2;
        ASSERT_NEAR(lp, ld, 2 * rel * ld) << "w " << w.x << ' ' << w.y << ' ' << w.z;
    }
    // Spot values: isotropic alpha = 1 at 45 degrees, (-1 + sqrt 2) / 2; the normal has Lambda = 0;
    // an anisotropic direction along x only sees alpha_x.
    const Vec3 w45{std::sqrt(0.5), 0, std::sqrt(0.5)};
    EXPECT_NEAR(o::smith_lambda(w45, 1, 1), (std::sqrt(2.0) - 1) / 2, 4 * DBL_EPSILON);
    EXPECT_EQ(o::smith_lambda({0, 0, 1}, 0.3, 0.9), 0.0);
    EXPECT_NEAR(o::projected_alpha({0.6, 0, 0.8}, 0.3, 0.9), 0.3, 4 * DBL_EPSILON);
    EXPECT_NEAR(o::projected_alpha({0, -0.6, 0.8}, 0.3, 0.9), 0.9, 4 * DBL_EPSILON);
    // G1 is 0 at and below the horizon, and for normals facing away from w.
    EXPECT_EQ(o::smith_g1({1, 0, 0}, {0, 0, 1}, 0.5, 0.5), 0.0);
    EXPECT_EQ(o::smith_g1({0.6, 0, -0.8}, {0, 0, 1}, 0.5, 0.5), 0.0);
    EXPECT_EQ(o::smith_g1({0.6, 0, 0.8}, {-0.8, 0, -0.6}, 0.5, 0.5), 0.0);
    EXPECT_DOUBLE_EQ(o::smith_g1(w45, {0, 0, 1}, 1, 1), 1 / (1 + (std::sqrt(2.0) - 1) / 2));
}

// ---------------------------------------------------------------------------------------------
// The VNDF: its density and the sampler.

struct VndfCase {
    const char* name;
    double ax, ay;
    Vec3 wi;
};
const VndfCase kVndfCases[] = {
    {"isotropic", 0.3, 0.3, spherical(0.6, 0.7)},
    {"anisotropic", 0.08, 0.6, spherical(0.5, 0.5)},
    {"grazing", 0.25, 0.5, spherical(0.03, 2.2)},
};

// Int over the hemisphere of vndf_pdf, in polar coordinates. For each phi the support ends where
// wi.wm = 0: sin(theta) d + cos(theta) wi.z = 0 with d = wi.x cos phi + wi.y sin phi, so theta runs
// to atan2(wi.z, -d) (pi/2 when d >= 0) and the integrand is smooth on it; theta = t s^2 (s in [0,1])
// puts nodes where the peak near the normal is. Trapezoid in phi (periodic), Gauss-Legendre in s.
double integrate_vndf(const VndfCase& c, int n_phi, int panels, const GaussLegendre& gl) {
    double total = 0;
    for (int j = 0; j < n_phi; ++j) {
        const double phi = 2 * kPi * j / n_phi;
        const double d = c.wi.x * std::cos(phi) + c.wi.y * std::sin(phi);
        const double t_end = d >= 0 ? kPi / 2 : std::atan2(c.wi.z, -d);
        double inner = 0;
        for (int p = 0; p < panels; ++p) {
            const double a = double(p) / panels, b = double(p + 1) / panels;
            for (std::size_t k = 0; k < gl.x.size(); ++k) {
                const double s = 0.5 * (a + b) + 0.5 * (b - a) * gl.x[k];
                const double theta = t_end * s * s, dtheta = 2 * t_end * s;
                const Vec3 wm{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
                inner += 0.5 * (b - a) * gl.w[k] * o::vndf_pdf(c.wi, wm, c.ax, c.ay) * std::sin(theta) * dtheta;
            }
        }
        total += inner * (2 * kPi / n_phi);
    }
    return total;
}

TEST(OracleVndf, PdfIntegratesToOneOverTheHemisphere) {
    const GaussLegendre gl(8);
    for (const VndfCase& c : kVndfCases) {
        const double coarse = integrate_vndf(c, 256, 32, gl);
        const double fine = integrate_vndf(c, 512, 64, gl);
        // A-posteriori bound: the fine rule's error is below the coarse-fine difference (the rules
        // converge), plus the worst-case rounding of summing this many positive terms.
        const double rounding = 512.0 * 64 * 8 * DBL_EPSILON;
        EXPECT_NEAR(fine, 1.0, std::fabs(fine - coarse) + rounding)
            << c.name << ": coarse " << coarse << " fine " << fine;
    }
}

TEST(OracleVndf, SamplesLieInTheVisibleHemisphere) {
    const PointSet ps = points(1 << 14, 1, 8, Sequence::random);
    for (const VndfCase& c : kVndfCases) {
        for (std::size_t k = 0; k < ps.total(); ++k) {
            const Vec3 wm = o::sample_vndf(c.wi, c.ax, c.ay, ps.u1[k], ps.u2[k]);
            ASSERT_NEAR(wm.x * wm.x + wm.y * wm.y + wm.z * wm.z, 1.0, 8 * DBL_EPSILON);
            ASSERT_GE(wm.z, 0.0);
            ASSERT_GT(wm.x * c.wi.x + wm.y * c.wi.y + wm.z * c.wi.z, 0.0) << c.name;
        }
    }
}

// Pearson's chi-square of sample_vndf(sample_alpha) against vndf_pdf(pdf_alpha) over a grid of
// n_theta x n_phi cells of equal d(theta) d(phi). Expected counts integrate the pdf over each cell
// with 2 x 2 panels of 6-point Gauss-Legendre per dimension; cells expecting fewer than 5 samples are
// pooled into one. Returns (statistic, degrees of freedom).
std::pair<double, int> vndf_chi_square(const VndfCase& c, double sample_scale, const PointSet& ps) {
    const int n_theta = 48, n_phi = 96;
    const double d_theta = kPi / 2 / n_theta, d_phi = 2 * kPi / n_phi;
    std::vector<double> observed(n_theta * n_phi, 0.0), expected(n_theta * n_phi, 0.0);
    for (std::size_t k = 0; k < ps.total(); ++k) {
        const Vec3 wm = o::sample_vndf(c.wi, c.ax * sample_scale, c.ay * sample_scale, ps.u1[k], ps.u2[k]);
        const double theta = std::acos(std::min(1.0, std::max(-1.0, wm.z)));
        double phi = std::atan2(wm.y, wm.x);
        if (phi < 0) phi += 2 * kPi;
        const int i = std::min(n_theta - 1, int(theta / d_theta)), j = std::min(n_phi - 1, int(phi / d_phi));
        observed[i * n_phi + j] += 1;
    }
    const GaussLegendre gl(6);
    const int sub = 2;
    for (int i = 0; i < n_theta; ++i)
        for (int j = 0; j < n_phi; ++j) {
            double mass = 0;
            for (int a = 0; a < sub; ++a)
                for (int b = 0; b < sub; ++b)
                    for (std::size_t ka = 0; ka < gl.x.size(); ++ka)
                        for (std::size_t kb = 0; kb < gl.x.size(); ++kb) {
                            const double h_t = d_theta / sub, h_p = d_phi / sub;
                            const double theta = i * d_theta + (a + 0.5 + 0.5 * gl.x[ka]) * h_t;
                            const double phi = j * d_phi + (b + 0.5 + 0.5 * gl.x[kb]) * h_p;
                            const Vec3 wm{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                          std::cos(theta)};
                            mass += 0.25 * h_t * h_p * gl.w[ka] * gl.w[kb] * std::sin(theta) *
                                    o::vndf_pdf(c.wi, wm, c.ax, c.ay);
                        }
            expected[i * n_phi + j] = mass * double(ps.total());
        }
    double chi2 = 0, pooled_o = 0, pooled_e = 0;
    int cells = 0;
    for (std::size_t k = 0; k < expected.size(); ++k) {
        if (expected[k] < 5) {
            pooled_o += observed[k];
            pooled_e += expected[k];
            continue;
        }
        chi2 += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
        ++cells;
    }
    if (pooled_e > 0) {  // the pooled cell; a sample in zero-probability cells makes this explode
        chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        ++cells;
    }
    return {chi2, cells - 1};
}

TEST(OracleVndf, SamplerMatchesPdfChiSquare) {
    // Independent uniform points (the chi-square law assumes a multinomial sample). Significance
    // 1e-4 per case; the quantile is computed for the actual degrees of freedom after pooling.
    const PointSet ps = points(1 << 20, 1, 9, Sequence::random);
    for (const VndfCase& c : kVndfCases) {
        const auto [chi2, dof] = vndf_chi_square(c, 1.0, ps);
        ASSERT_GE(dof, 50) << c.name;
        const double critical = chi_square_upper_quantile(1e-4, dof);
        EXPECT_LT(chi2, critical) << c.name << ": chi2 " << chi2 << " dof " << dof;
        // The test has teeth: a sampler with 5% more roughness than the pdf is rejected.
        const auto [chi2_wrong, dof_wrong] = vndf_chi_square(c, 1.05, ps);
        EXPECT_GT(chi2_wrong, chi_square_upper_quantile(1e-4, dof_wrong)) << c.name << " (negative control)";
    }
}

// ---------------------------------------------------------------------------------------------
// Limits and measured facts.

TEST(OracleTerm, SmoothLimitIsPartOnesReferenceStep) {
    // At alpha = 1e-4 the VNDF hugs the normal. Bias bound: D_wi <= D / wi.z, and for isotropic GGX
    // Int_{theta_m > delta} D dwm = Int_{t0}^inf alpha^2 sqrt(1+t) / (alpha^2+t)^2 dt
    //                            <= 2 alpha^2 sqrt(1 + t0) / t0,   t = tan^2 theta_m, t0 = tan^2 delta.
    // If every wm lies within delta = |theta_o - theta_t| / 2 of the normal, both cone conditions
    // agree with step(cos_t, NdotL) (and wm.wo > 0), so with m the VNDF mass beyond delta the exact
    // term differs from the step by at most m / (1 - m). Tolerance: that bias plus the error bar.
    const double alpha = 1e-4;
    const std::uint32_t replicates = 8;
    const PointSet ps = points(1 << 16, replicates, 10);
    struct Case {
        double v, n_dot_l;
        AoWeighting w;
    };
    const Case cases[] = {
        {0.5, 0.9, AoWeighting::cosine},  {0.5, 0.5, AoWeighting::cosine},  {0.2, 0.95, AoWeighting::cosine},
        {0.2, 0.85, AoWeighting::cosine}, {0.9, 0.2, AoWeighting::cosine},  {0.9, 0.45, AoWeighting::cosine},
        {0.3, 0.8, AoWeighting::uniform}, {0.3, 0.6, AoWeighting::uniform}, {0.7, 0.15, AoWeighting::uniform},
    };
    int azimuth = 0;
    for (const Case& c : cases) {
        Query q;
        q.visibility = c.v;
        q.alpha_x = q.alpha_y = alpha;
        q.wi = spherical(0.6, 0.3);
        q.wo = spherical(c.n_dot_l, 0.3 + 0.9 * azimuth++);
        TermOptions opt;
        opt.ao_weighting = c.w;
        const double step = o::reference_step(c.v, c.n_dot_l, c.w);
        const double theta_t = std::acos(o::cone_cos_theta(c.v, c.w)), theta_o = std::acos(c.n_dot_l);
        const double delta = 0.5 * std::fabs(theta_o - theta_t);
        ASSERT_LT(theta_o + delta, kPi / 2);
        const double t0 = std::tan(delta) * std::tan(delta);
        const double m = 2 * alpha * alpha * std::sqrt(1 + t0) / t0 / q.wi.z;
        const Estimate e = o::generic_m_g(q, opt, ps);
        EXPECT_NEAR(e.term, step, m / (1 - m) + error_bar(e, replicates))
            << "v " << c.v << " NdotL " << c.n_dot_l << " (" << to_string(c.w) << ")";
    }
    // The step itself: strict inequality of part 1's piecewise definition.
    EXPECT_EQ(o::reference_step(0.5, 0.8, AoWeighting::cosine), 1.0);
    EXPECT_EQ(o::reference_step(0.5, 0.7, AoWeighting::cosine), 0.0);
    EXPECT_EQ(o::reference_step(0.75, 0.5, AoWeighting::cosine), 0.0);  // cos_t = 0.5 exactly: not lit
    EXPECT_EQ(o::reference_step(0.5, 0.6, AoWeighting::uniform), 1.0);
}

Estimate azimuth_estimate(double n_dot_v, double azimuth_deg, const PointSet& ps) {
    Query q;
    q.visibility = 0.5;
    q.alpha_x = q.alpha_y = 0.16;
    q.wi = spherical(n_dot_v, 0.0);
    q.wo = spherical(0.8, azimuth_deg * kPi / 180);  // azimuth 0: light on the side of the view
    return o::generic_m_g(q, TermOptions{}, ps);
}

TEST(OracleTerm, IsotropicTermDependsOnAzimuthBetweenViewAndLight) {
    // docs/method.md (a known answer): NdotV 0.2, v 0.5, NdotL 0.8, alpha 0.16 gives about 0.90 / 0.74 / 0.59 at 0 / 90 /
    // 180 degrees. The quoted values are rounded to 2 digits (+-0.005); add the estimate's error bar.
    const std::uint32_t replicates = 8;
    const PointSet ps = points(1 << 18, replicates, 12);
    const double azimuths[] = {0, 90, 180}, quoted[] = {0.90, 0.74, 0.59};
    for (int k = 0; k < 3; ++k) {
        const Estimate e = azimuth_estimate(0.2, azimuths[k], ps);
        EXPECT_NEAR(e.term, quoted[k], 0.005 + error_bar(e, replicates)) << "azimuth " << azimuths[k];
    }
}

TEST(OracleTerm, AzimuthDoesNotMatterAtNormalView) {
    // wi = wg: an isotropic VNDF is rotationally symmetric, so rotating wo cannot change the exact
    // term. Independent point sets per azimuth: the difference of two independent estimates has
    // standard error sqrt(se_a^2 + se_b^2) (t with replicates - 1 dof is the conservative choice).
    const std::uint32_t replicates = 8;
    const double t = student_t_quantile(kConfidence, int(replicates) - 1);
    const Estimate base = azimuth_estimate(1.0, 0, points(1 << 16, replicates, 100));
    std::uint64_t seed = 101;
    for (double az : {37.0, 90.0, 180.0, 271.0}) {
        const Estimate e = azimuth_estimate(1.0, az, points(1 << 16, replicates, seed++));
        EXPECT_NEAR(e.term, base.term, t * std::hypot(e.std_error, base.std_error)) << "azimuth " << az;
    }
}

}  // namespace
