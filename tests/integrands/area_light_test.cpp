// Area lights: known answers, symmetry, the kernel against the independent oracle, input checks.
//
// Error bars: every comparison of two estimates uses t(1 - (1 - 0.999) / N, R - 1) * sqrt(se_a^2 + se_b^2)
// (Student t with R - 1 degrees of freedom, Bonferroni over the N comparisons of a test), as
// tests/oracle/oracle_test.cpp does; a quadrature in the reference adds its own error estimate.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "cli_runner.hpp"
#include "core/area_light.hpp"
#include "core/estimate.hpp"
#include "integrands/area_light/area_light_integrand.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "integrands/dfg/dfg_quadrature.hpp"
#include "jobs/area.hpp"
#include "jobs/eval.hpp"
#include "oracle/oracle.hpp"
#include "sampling/joint_point_set.hpp"
#include "area_light_queries.hpp"

namespace ms {
namespace {

using area::AreaQuery;
using area::Lobe;
using testing::bar;
using testing::direction_deg;
using testing::have_device;
using testing::kReplicates;
using testing::plan;
using testing::sphere;
using area::LightShape;

// A square of side `side` facing the shaded point at unit distance along `towards`.
AreaQuery rect(double v, double alpha, double n_dot_v, const Vec3& towards, double side, Lobe lobe) {
    AreaQuery q = sphere(v, alpha, n_dot_v, 90, 0, 1, lobe);
    q.light.shape = LightShape::rect;
    const Vec3 c = towards;
    const Vec3 helper = std::fabs(c.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
    Vec3 t1{helper.y * c.z - helper.z * c.y, helper.z * c.x - helper.x * c.z, helper.x * c.y - helper.y * c.x};
    const double l = std::hypot(t1.x, t1.y, t1.z);
    t1 = {t1.x / l, t1.y / l, t1.z / l};
    const Vec3 t2{c.y * t1.z - c.z * t1.y, c.z * t1.x - c.x * t1.z, c.x * t1.y - c.y * t1.x};
    const double h = side / 2;
    auto corner = [&](double a, double b) {
        return Vec3{c.x + a * t1.x + b * t2.x, c.y + a * t1.y + b * t2.y, c.z + a * t1.z + b * t2.z};
    };
    q.light.rect.corners = {corner(-h, -h), corner(h, -h), corner(h, h), corner(-h, h)};
    return q;
}

std::unique_ptr<TermBackend> kernels() { return make_opencl_backend(ocl::select_devices("default")); }

Query point_query(const AreaQuery& q, const Vec3& wo) {
    Query p;
    p.visibility = q.visibility;
    p.alpha_x = q.alpha_x;
    p.alpha_y = q.alpha_y;
    p.wi = q.wi;
    p.wo = wo;
    return p;
}

TEST(AreaLightPoints, JointPointSetIsStratifiedAndExtendsTheTermPoints) {
    const SamplingPlan p = plan(8 * 256, 7);
    const JointPointSet joint = make_joint_point_set(p);
    const PointSet term = make_point_set(p);
    EXPECT_EQ(joint.normals.u1, term.u1);
    EXPECT_EQ(joint.normals.u2, term.u2);
    // Every 1D projection of every replicate has exactly one point in each of the n intervals, and
    // (u2, u3) (Sobol's dimensions 1 and 2) is a (0, m, 2)-net: one point per 16 x 16 cell at n = 256.
    const std::uint32_t n = 256;
    for (std::uint32_t r = 0; r < kReplicates; ++r) {
        for (const std::vector<float>* u : {&joint.normals.u1, &joint.normals.u2, &joint.u3, &joint.u4}) {
            std::vector<int> hits(n, 0);
            for (std::uint32_t i = 0; i < n; ++i) ++hits[std::size_t((*u)[r * n + i] * n)];
            for (int h : hits) ASSERT_EQ(h, 1);
        }
        std::vector<int> cells(256, 0);
        for (std::uint32_t i = 0; i < n; ++i)
            ++cells[std::size_t(joint.normals.u2[r * n + i] * 16) * 16 + std::size_t(joint.u3[r * n + i] * 16)];
        for (int c : cells) ASSERT_EQ(c, 1);
    }
    // Sobol's third dimension: the first direction numbers 1/2, 3/4, 3/8 (m = 1, 3, 3 for x^2 + x + 1).
    EXPECT_EQ(sobol_dimension3(1), 0x80000000u);
    EXPECT_EQ(sobol_dimension3(2), 0xc0000000u);
    EXPECT_EQ(sobol_dimension3(4), 0x60000000u);
}

TEST(AreaLightInput, RefusesBadLightsWithClearMessages) {
    auto message = [](const AreaQuery& q) {
        try {
            area::validate(q);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    AreaQuery q = sphere(0.5, 0.25, 0.7, 40, 0, 10, Lobe::ggx);
    EXPECT_EQ(message(q), "");
    q.light.sphere.half_angle = 0;
    EXPECT_NE(message(q).find("half-angle must be in (0, 90) degrees, got 0"), std::string::npos) << message(q);
    q.light.sphere.half_angle = area::radians(90);
    EXPECT_NE(message(q).find("got 90"), std::string::npos) << message(q);
    q.light.sphere.half_angle = -0.1;
    EXPECT_NE(message(q).find("half-angle"), std::string::npos);
    q = sphere(0.5, 0.25, 0.7, 40, 0, 10, Lobe::ggx);
    q.light.sphere.centre = {0, 0, 0};
    EXPECT_NE(message(q).find("centre direction"), std::string::npos);

    AreaQuery r = rect(0.5, 0.25, 0.7, direction_deg(40, 0), 0.5, Lobe::ggx);
    EXPECT_EQ(message(r), "");
    AreaQuery bad = r;
    bad.light.rect.corners[1] = bad.light.rect.corners[0];
    EXPECT_NE(message(bad).find("zero length"), std::string::npos) << message(bad);
    bad = r;
    bad.light.rect.corners[2].x += 0.1;
    EXPECT_NE(message(bad).find("p1 + p3 - p0"), std::string::npos) << message(bad);
    bad = r;  // a parallelogram: p3 moved along e1 (and p2 with it), the corner is no longer square
    for (int k : {2, 3}) {
        bad.light.rect.corners[k].x += 0.1 * (r.light.rect.corners[1].x - r.light.rect.corners[0].x);
        bad.light.rect.corners[k].y += 0.1 * (r.light.rect.corners[1].y - r.light.rect.corners[0].y);
        bad.light.rect.corners[k].z += 0.1 * (r.light.rect.corners[1].z - r.light.rect.corners[0].z);
    }
    EXPECT_NE(message(bad).find("not a right angle"), std::string::npos) << message(bad);
    bad = r;  // seen edge-on: the plane through the shaded point
    bad.light.rect.corners = {Vec3{1, 0, 0}, Vec3{2, 0, 0}, Vec3{2, 0, 1}, Vec3{1, 0, 1}};
    EXPECT_NE(message(bad).find("lies in the rectangle's plane"), std::string::npos) << message(bad);
}

TEST(AreaLightExact, LightsBelowTheHorizonAreExactlyZero) {
    const std::vector<AreaQuery> queries = {
        sphere(0.5, 0.25, 0.7, -20, 30, 19.9, Lobe::ggx),     // top at -0.1 degrees
        sphere(0.5, 0.25, 0.7, -20, 30, 20.0, Lobe::lambert),  // touches the horizon only
        rect(0.5, 0.25, 0.7, direction_deg(-40, 10), 0.5, Lobe::ggx),
    };
    auto oracle = make_oracle_backend(1);
    area::AreaEvalStats stats;
    const auto r = area::evaluate_area(*oracle, queries, {}, plan(8 * 64), {}, &stats);
    for (const auto& e : r) {
        EXPECT_EQ(e.term.term, 0.0);
        EXPECT_EQ(e.term.std_error, 0.0);
        EXPECT_FALSE(e.sampled);
    }
    // The light touching the horizon may be classified by either rule (its top is 0 up to rounding).
    EXPECT_EQ(stats.below_horizon + stats.zero_region, 3u);
    EXPECT_GE(stats.below_horizon, 2u);
    EXPECT_EQ(stats.sampled, 0u);
    // Just above: sampled, not classified.
    EXPECT_EQ(area::classify(area::normalised(sphere(0.5, 0.25, 0.7, -20, 30, 20.5, Lobe::ggx)), AoWeighting::cosine),
              area::ExactCase::none);
}

TEST(AreaLightGeometry, MaxHeightSolidAngleAndRepresentativePoint) {
    const AreaQuery s = area::normalised(sphere(0.5, 0.25, 0.6, 30, 0, 10, Lobe::ggx));
    EXPECT_NEAR(area::max_height(s.light), std::sin(area::radians(40)), 1e-12);
    EXPECT_NEAR(area::solid_angle(s.light), 2 * ms::kPi * (1 - std::cos(area::radians(10))), 1e-12);
    // A square of side 2 at unit distance subtends 4 asin(1/3) (a cube face: 4 pi / 6 = 2.0944).
    const AreaQuery face = rect(0.5, 0.25, 0.6, {0, 0, 1}, 2, Lobe::ggx);
    EXPECT_NEAR(area::solid_angle(face.light), 4 * ms::kPi / 6, 1e-12);
    EXPECT_EQ(area::max_height(face.light), 1.0);
    // Karis: the mirror direction inside the sphere is its own representative point; outside, the
    // point lies on the light's rim side towards it, within gamma of the centre.
    AreaQuery inside = area::normalised(sphere(0.5, 0.25, 0.6, 90 - area::degrees(std::acos(0.6)) + 3, 180, 10, Lobe::ggx));
    const Vec3 rp = area::representative_direction(inside);
    EXPECT_NEAR(rp.x, -inside.wi.x, 1e-12);
    EXPECT_NEAR(rp.z, inside.wi.z, 1e-12);
    const AreaQuery outside = area::normalised(sphere(0.5, 0.25, 0.6, 80, 0, 10, Lobe::ggx));
    const Vec3 op = area::representative_direction(outside);
    const Vec3 c = outside.light.sphere.centre;
    const double angle = std::acos(std::min(1.0, op.x * c.x + op.y * c.y + op.z * c.z));
    EXPECT_GT(angle, area::radians(5));
    EXPECT_LE(angle, area::radians(10) + 1e-12);
    EXPECT_LT(op.x, c.x);  // moved towards the mirror direction (negative x)
}

TEST(AreaLightPlugIn, GivenInnerTermHasKnownAnswers) {
    // T(wo) = 1 gives exactly 1; the step T(wo) = [wo.z > c] under a Lambert sphere light centred on the
    // normal gives the cosine-weighted share of the cap above z = c: (1 - c^2) / sin^2 gamma.
    const double c = std::cos(area::radians(20));
    area::AreaRoutineConfig one, step;
    one.inner_term = [](const Query&) { return 1.0; };
    step.inner_term = [c](const Query& q) { return q.wo.z > c ? 1.0 : 0.0; };
    const std::vector<AreaQuery> queries = {sphere(0.5, 0.25, 1.0, 90, 0, 30, Lobe::lambert),
                                            sphere(0.5, 0.25, 0.6, 50, 0, 30, Lobe::ggx)};
    auto oracle = make_oracle_backend(1);
    const auto ones = area::evaluate_area(*oracle, queries, {}, plan(8 * 1024), one);
    for (const auto& e : ones) EXPECT_NEAR(e.term.term, 1.0, 1e-12);
    const auto steps = area::evaluate_area(*oracle, {queries[0]}, {}, plan(8 * 4096), step);
    const double s = std::sin(area::radians(30));
    const double expected = (1 - c * c) / (s * s);
    EXPECT_NEAR(steps[0].term.term, expected, bar(steps[0].term.std_error, 0, 1) + 1e-6) << steps[0].term.std_error;
    // The lobe integral of a Lambert cap fully above the horizon: sin^2 gamma cos(theta_c).
    const AreaQuery tilted = sphere(0.5, 0.25, 0.6, 50, 0, 30, Lobe::lambert);
    const auto t = area::evaluate_area(*oracle, {tilted}, {}, plan(8 * 1024), one);
    EXPECT_NEAR(t[0].lobe_integral.term, s * s * std::sin(area::radians(50)), bar(t[0].lobe_integral.std_error, 0, 1) + 1e-9);
}

// The kernel against the independent oracle (different estimator: nested, plain light sampling,
// weighted inner term), and the kernel's lobe integral against closed forms.
TEST(AreaLightKernel, AgreesWithTheOracleWithinStatisticalBars) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    std::vector<AreaQuery> queries = {
        sphere(0.5, 0.25, 0.7, 40, 180, 10, Lobe::ggx),   sphere(0.6, 0.49, 0.4, 25, 60, 20, Lobe::lambert),
        sphere(0.3, 0.09, 0.9, 70, 0, 5, Lobe::ggx),      sphere(0.7, 1.0, 0.3, 5, 120, 15, Lobe::ggx),  // straddles the horizon
        rect(0.5, 0.25, 0.7, direction_deg(45, 180), 0.6, Lobe::ggx), rect(0.6, 0.36, 0.5, direction_deg(30, 90), 0.8, Lobe::lambert),
    };
    queries[1].alpha_y = 0.16;  // anisotropic
    auto device = kernels();
    auto oracle = make_oracle_backend();
    const auto k = area::evaluate_area(*device, queries, {}, plan(8 * 65536, 3));
    const auto o = area::evaluate_area(*oracle, queries, {}, plan(8 * 16384, 4));
    for (std::size_t i = 0; i < queries.size(); ++i) {
        ASSERT_TRUE(k[i].sampled && o[i].sampled);
        EXPECT_NEAR(k[i].term.term, o[i].term.term, bar(k[i].term.std_error, o[i].term.std_error, 2 * int(queries.size())))
            << "query " << i << ": kernel " << k[i].term.term << " +- " << k[i].term.std_error << ", oracle "
            << o[i].term.term << " +- " << o[i].term.std_error;
        EXPECT_NEAR(k[i].lobe_integral.term, o[i].lobe_integral.term,
                    bar(k[i].lobe_integral.std_error, o[i].lobe_integral.std_error, 2 * int(queries.size())))
            << "query " << i;
        EXPECT_LT(k[i].term.std_error, 2e-3) << "query " << i;
    }
}

TEST(AreaLightKernel, SmallLightGivesThePointTerm) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    // gamma = 0.05 degrees: T varies by far less than the error bars across the light.
    const std::vector<AreaQuery> queries = {sphere(0.5, 0.25, 0.7, 40, 180, 0.05, Lobe::ggx),
                                            sphere(0.6, 0.09, 0.4, 25, 60, 0.05, Lobe::lambert),
                                            rect(0.5, 0.36, 0.7, direction_deg(35, 90), 1e-3, Lobe::ggx)};
    auto device = kernels();
    const auto a = area::evaluate_area(*device, queries, {}, plan(8 * 65536, 5));
    std::vector<Query> points;
    for (const auto& q : queries) points.push_back(point_query(area::normalised(q), area::centre_direction(area::normalised(q).light)));
    const auto p = evaluate(*device, points, {}, plan(8 * 65536, 6));
    for (std::size_t i = 0; i < queries.size(); ++i)
        EXPECT_NEAR(a[i].term.term, p[i].term, bar(a[i].term.std_error, p[i].std_error, int(queries.size())))
            << "query " << i << ": area " << a[i].term.term << " +- " << a[i].term.std_error << ", point " << p[i].term;
}

TEST(AreaLightKernel, WholeHemisphereLambertIsTheCosineWeightedMean) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    // A Lambert sphere light centred on the normal with gamma = 89.99 degrees covers the hemisphere but a
    // band of cosine-weighted measure cos^2(89.99 deg) = 3e-8. With wi along the normal and an isotropic
    // surface T depends on NdotL = mu alone, so the mean is Int_0^1 T(mu) 2 mu dmu, here by Gauss-Legendre
    // on [mu0, 1] (T = 0 below mu0 = 2 cos_t^2 - 1) with T sampled at each node.
    for (double v : {0.4, 0.8}) {
        const AreaQuery q = sphere(v, 0.25, 1.0, 90, 0, 89.99, Lobe::lambert);
        auto device = kernels();
        const auto a = area::evaluate_area(*device, {q}, {}, plan(8 * 262144, 8));
        const double mu0 = std::max(0.0, 1 - 2 * v);
        auto mean = [&](int nodes, double* se) {
            // Gauss-Legendre nodes on [-1, 1] by Newton's iteration.
            std::vector<Query> pts;
            std::vector<double> w;
            for (int i = 0; i < nodes; ++i) {
                double z = std::cos(ms::kPi * (i + 0.75) / (nodes + 0.5)), dp = 0;
                for (int it = 0; it < 100; ++it) {
                    double p0 = 1, p1 = z;
                    for (int k = 2; k <= nodes; ++k) {
                        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
                        p0 = p1, p1 = p2;
                    }
                    dp = nodes * (z * p1 - p0) / (z * z - 1);
                    const double dz = p1 / dp;
                    z -= dz;
                    if (std::fabs(dz) < 1e-15) break;
                }
                const double mu = mu0 + (1 - mu0) * (z + 1) / 2;
                w.push_back((1 - mu0) / ((1 - z * z) * dp * dp) * 2 * mu);
                pts.push_back(point_query(q, {std::sqrt(1 - mu * mu), 0, mu}));
            }
            const auto t = evaluate(*device, pts, {}, plan(8 * 65536, 9));
            double m = 0;
            *se = 0;
            for (int i = 0; i < nodes; ++i) m += w[i] * t[i].term, *se += w[i] * t[i].std_error;  // correlated: bound
            return m;
        };
        double se16 = 0, se24 = 0;
        const double m16 = mean(16, &se16), m24 = mean(24, &se24);
        const double quadrature = std::fabs(m24 - m16);
        EXPECT_NEAR(a[0].term.term, m24, bar(a[0].term.std_error, se24, 2) + quadrature + 3e-8)
            << "v " << v << ": area " << a[0].term.term << " +- " << a[0].term.std_error << ", mean " << m24 << " +- " << se24
            << " (quadrature " << quadrature << ")";
    }
}

TEST(AreaLightKernel, SymmetricConfigurationsAgree) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    // Isotropic surface: mirroring the light across the view's plane (y -> -y), and rotating view and
    // light together about the normal, leave T_area unchanged; a sphere light and the same cone written
    // with its centre scaled agree bit for bit (directions are normalised first).
    AreaQuery a = sphere(0.5, 0.25, 0.6, 35, 70, 12, Lobe::ggx);
    AreaQuery mirrored = a;
    mirrored.light.sphere.centre.y = -mirrored.light.sphere.centre.y;
    AreaQuery rotated = a;
    const double r = area::radians(50);
    auto rot = [r](const Vec3& v) { return Vec3{std::cos(r) * v.x - std::sin(r) * v.y, std::sin(r) * v.x + std::cos(r) * v.y, v.z}; };
    rotated.wi = rot(a.wi);
    rotated.light.sphere.centre = rot(a.light.sphere.centre);
    AreaQuery scaled = a;
    scaled.light.sphere.centre = {a.light.sphere.centre.x * 7, a.light.sphere.centre.y * 7, a.light.sphere.centre.z * 7};
    AreaQuery lambert = a;
    lambert.lobe = Lobe::lambert;
    AreaQuery lambert_mirrored = mirrored;
    lambert_mirrored.lobe = Lobe::lambert;
    auto device = kernels();
    const auto e = area::evaluate_area(*device, {a, mirrored, rotated, scaled, lambert, lambert_mirrored}, {}, plan(8 * 65536, 10));
    EXPECT_NEAR(e[0].term.term, e[1].term.term, bar(e[0].term.std_error, e[1].term.std_error, 4));
    EXPECT_NEAR(e[0].term.term, e[2].term.term, bar(e[0].term.std_error, e[2].term.std_error, 4));
    EXPECT_NEAR(e[0].term.term, e[3].term.term, 1e-6);
    EXPECT_NEAR(e[4].term.term, e[5].term.term, bar(e[4].term.std_error, e[5].term.std_error, 4));
}

class AreaLightCli : public testing::ScratchDirTest {
protected:
    AreaLightCli() : ScratchDirTest("area") {}
    void write(const std::string& name, const std::string& text) { std::ofstream(path(name)) << text; }
};

TEST_F(AreaLightCli, EvalWritesTermsAndRefusesBadLights) {
    write("q.csv",
          "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg\n"
          "0.5,0.25,0.25,0.6,0,0.8,-0.5,0,0.8,10\n"
          "0.5,0.25,0.25,0.6,0,0.8,0,0,-1,10\n");
    const std::string cli = MICROSHADOW_CLI;
    auto ok = testing::run_shell(cli + " area eval --method sampled -q --backend oracle --samples 2048 --in " + path("q.csv") + " --out " +
                                 path("r.csv") + " 2>&1");
    ASSERT_EQ(ok.exit_code, 0) << ok.output;
    std::ifstream in(path("r.csv"));
    std::string header, row1, row2;
    std::getline(in, header), std::getline(in, row1), std::getline(in, row2);
    EXPECT_EQ(header, "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg,term,std_error");
    EXPECT_EQ(row2.substr(row2.rfind(',', row2.rfind(',') - 1)), ",0,0");  // below the horizon: exactly 0
    EXPECT_TRUE(std::filesystem::exists(path("r.csv.json")));

    for (const std::string& bad : {std::string("0"), std::string("90"), std::string("-3")}) {
        write("bad.csv", "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg\n"
                         "0.5,0.25,0.25,0.6,0,0.8,-0.5,0,0.8," + bad + "\n");
        auto r = testing::run_shell(cli + " area eval --method sampled -q --backend oracle --in " + path("bad.csv") + " --out " + path("b.csv") + " 2>&1");
        EXPECT_EQ(r.exit_code, 2) << r.output;
        EXPECT_NE(r.output.find("bad.csv:2 (row 1): column 'half_angle_deg': " + bad + " must be in (0, 90) degrees"), std::string::npos)
            << r.output;
        EXPECT_FALSE(std::filesystem::exists(path("b.csv")));
    }
    write("rect.csv", "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,p0_x,p0_y,p0_z,p1_x,p1_y,p1_z,p2_x,p2_y,p2_z,p3_x,p3_y,p3_z\n"
                      "0.5,0.25,0.25,0.6,0,0.8,0,0,1,1,0,1,1,0,1,0,0,1\n");
    auto r = testing::run_shell(cli + " area eval --method sampled -q --light rect --backend oracle --in " + path("rect.csv") + " --out " + path("b.csv") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("rect.csv:2 (row 1): degenerate rect light: a side (p1 - p0 or p3 - p0) has zero length"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(path("b.csv")));
}

}  // namespace
}  // namespace ms

namespace ms {
namespace {

TEST(AreaLightTaps, RuleIsExactForConstantsAndShrinksToThePoint) {
    // The taps' weights: 1/4 + 6 x 1/8 = 1 of the rule, times f cos; every tap inside the light.
    for (Lobe lobe : {Lobe::lambert, Lobe::ggx})
        for (double gamma : {0.5, 10.0, 30.0}) {
            const AreaQuery q = area::normalised(sphere(0.5, 0.04, 0.7, 40, 180, gamma, lobe));
            const auto taps = area::sphere_taps(q);
            ASSERT_EQ(taps.size(), 7u);
            const Vec3 c = q.light.sphere.centre;
            for (const auto& t : taps) {
                EXPECT_GE(t.wo.x * c.x + t.wo.y * c.y + t.wo.z * c.z, std::cos(q.light.sphere.half_angle) - 1e-12);
                EXPECT_GT(t.weight, 0);
            }
        }
    // A narrow GGX lobe whose mirror direction lies inside a wide light: the tap cone has the lobe's
    // radius; a Lambert lobe or a wide GGX lobe uses the light itself.
    const AreaQuery narrow = area::normalised(sphere(0.5, 0.01, std::cos(area::radians(40)), 50, 180, 20, Lobe::ggx));
    EXPECT_NEAR(area::tap_cone(narrow).half_angle, 2 * std::atan(0.02), 1e-12);
    EXPECT_EQ(area::tap_cone(area::normalised(sphere(0.5, 0.64, 0.7, 50, 180, 20, Lobe::ggx))).half_angle, area::radians(20));
    EXPECT_EQ(area::tap_cone(area::normalised(sphere(0.5, 0.01, 0.7, 50, 180, 20, Lobe::lambert))).half_angle, area::radians(20));
    // Below the horizon a tap weighs nothing.
    const auto straddling = area::sphere_taps(sphere(0.5, 0.25, 0.7, 0, 0, 20, Lobe::lambert));
    int below = 0;
    for (const auto& t : straddling) below += t.wo.z <= 0 && t.weight == 0;
    EXPECT_GE(below, 2);
}

TEST(AreaLightLobe, GrazingViewKeepsTheGgxWeightFiniteAndContinuous) {
    // A view that normalises to a denormal z: 4 wi.z (1 + Lambda(wi)) tends to a finite limit, so the
    // weight at wi.z = 7e-309 equals the one at 1e-12 up to O(wi.z) (relative 1e-9 is generous).
    AreaQuery q;
    q.visibility = 0.5;
    q.alpha_x = q.alpha_y = 0.25;
    q.lobe = Lobe::ggx;
    q.light.shape = LightShape::sphere;
    q.light.sphere.centre = {-0.3, 0.2, 0.9};
    q.light.sphere.half_angle = area::radians(10);
    q.wi = {0.714, 1e308, 0.7};  // normalised: (7.1e-309, 1, 7e-309)
    const AreaQuery denormal = area::normalised(q);
    ASSERT_GT(denormal.wi.z, 0);
    ASSERT_LT(denormal.wi.z, 1e-300);
    q.wi = {0.714e-12, 1, 0.7e-12};
    const AreaQuery tiny = area::normalised(q);
    const Vec3 wo = area::centre_direction(denormal.light);
    const double limit = area::lobe_weight(tiny, wo);
    ASSERT_TRUE(std::isfinite(limit));
    ASSERT_GT(limit, 0);
    EXPECT_NEAR(area::lobe_weight(denormal, wo), limit, 1e-9 * limit);
    for (const auto& t : area::sphere_taps(denormal)) EXPECT_TRUE(std::isfinite(t.weight) && t.weight >= 0);
    for (double u : {0.0, 0.3, 0.7, 0.999}) EXPECT_TRUE(std::isfinite(area::sample_light(denormal, u, 1 - u).weight));
}

TEST(AreaLightTaps, SweepAgreesWithTheAreaTermForSmallLights) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    // At gamma = 0.2 degrees the taps, the centre and T_area agree within their bars.
    area::StudyGrid g;
    g.half_angles_deg = {0.2};
    g.roughness = {0.5};
    g.visibility = {0.6};
    g.elevations_deg = {35};
    auto device = kernels();
    const auto rows = area::run_study(*device, area::grid_points(g), {}, plan(8 * 65536, 11));
    ASSERT_EQ(rows.size(), 2u);
    for (const auto& r : rows) {
        EXPECT_NEAR(r.taps.term, r.area.term.term, bar(r.taps.std_error, r.area.term.std_error, 4));
        EXPECT_NEAR(r.centre.term, r.area.term.term, bar(r.centre.std_error, r.area.term.std_error, 4));
    }
}

TEST_F(AreaLightCli, SweepWritesItsColumnsAndRefusesBadAxes) {
    const std::string cli = MICROSHADOW_CLI;
    auto ok = testing::run_shell(cli + " area sweep -q --samples 4096 --half-angles 5 --roughness 0.5 --visibility 0.5 "
                                       "--elevations 40 --lobes ggx --out " + path("s.csv") + " 2>&1");
    ASSERT_EQ(ok.exit_code, 0) << ok.output;
    std::ifstream in(path("s.csv"));
    std::string header, row;
    std::getline(in, header), std::getline(in, row);
    EXPECT_EQ(header.substr(0, 40), "lobe,half_angle_deg,roughness,visibility");
    EXPECT_EQ(row.substr(0, 8), "ggx,5,0.");
    for (const std::string& bad : {std::string("--half-angles 90"), std::string("--roughness 0"), std::string("--visibility 1.5"),
                                   std::string("--random 3 --max-half-angle 0")}) {
        auto r = testing::run_shell(cli + " area sweep -q " + bad + " --out " + path("b.csv") + " 2>&1");
        EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.output;
        EXPECT_FALSE(std::filesystem::exists(path("b.csv")));
    }
}

}  // namespace
}  // namespace ms


namespace ms {
namespace {

// The GGX lobe integral of a light covering the hemisphere is the directional albedo E = scale + bias of
// the split-sum DFG, whose quadrature oracle (integrands/dfg/) is independent of both light samplers:
// this checks the kernel's and the host's multiple importance sampling weights.
TEST(AreaLightLobe, HemisphereGgxLobeIntegralIsTheDirectionalAlbedo) {
    for (const auto& [n_dot_v, alpha] : {std::pair{0.7, 0.25}, std::pair{0.3, 0.5}, std::pair{0.9, 0.04}}) {
        const AreaQuery q = sphere(0.5, alpha, n_dot_v, 90, 0, 89.999, Lobe::ggx);
        const dfg::DfgQuadrature e = dfg::dfg_quadrature(n_dot_v, alpha);
        // The band above 89.999 degrees is missing from the light: its solid angle times the largest
        // f cos on it (sampled along the band; f cos vanishes at the horizon, so this bounds it).
        double band_max = 0;
        const AreaQuery nq = area::normalised(q);
        for (int k = 0; k < 360; ++k)
            for (double el : {0.0005, 0.001}) band_max = std::max(band_max, area::lobe_weight(nq, direction_deg(el, k)));
        const double band = 2 * ms::kPi * std::sin(area::radians(0.001)) * band_max;
        const double albedo = e.scale + e.bias, quadrature = e.scale_error + e.bias_error;
        area::AreaRoutineConfig one;
        one.inner_term = [](const Query&) { return 1.0; };
        auto oracle = make_oracle_backend(1);
        const auto host = area::evaluate_area(*oracle, {q}, {}, plan(8 * 8192, 12), one);
        EXPECT_NEAR(host[0].lobe_integral.term, albedo, bar(host[0].lobe_integral.std_error, 0, 6) + quadrature + band)
            << "host sampler, NdotV " << n_dot_v << " alpha " << alpha;
        if (!have_device()) continue;
        auto device = kernels();
        const auto k = area::evaluate_area(*device, {q}, {}, plan(8 * 65536, 13));
        EXPECT_NEAR(k[0].lobe_integral.term, albedo, bar(k[0].lobe_integral.std_error, 0, 6) + quadrature + band)
            << "kernel, NdotV " << n_dot_v << " alpha " << alpha << ": " << k[0].lobe_integral.term << " +- "
            << k[0].lobe_integral.std_error;
    }
}

}  // namespace
}  // namespace ms

namespace ms {
namespace {

TEST(AreaLightKernel, UniformAoAndLightsAcrossTheHorizonAgreeWithTheOracle) {
    if (!have_device()) GTEST_SKIP() << "no OpenCL device";
    const std::vector<AreaQuery> queries = {sphere(0.4, 0.36, 0.6, 8, 150, 20, Lobe::lambert),
                                            rect(0.5, 0.25, 0.8, direction_deg(6, 200), 0.7, Lobe::ggx),
                                            rect(0.3, 0.49, 0.5, direction_deg(20, 30), 0.4, Lobe::lambert)};
    TermOptions uniform;
    uniform.ao_weighting = AoWeighting::uniform;
    auto device = kernels();
    auto oracle = make_oracle_backend();
    const auto k = area::evaluate_area(*device, queries, uniform, plan(8 * 65536, 14));
    const auto o = area::evaluate_area(*oracle, queries, uniform, plan(8 * 16384, 15));
    for (std::size_t i = 0; i < queries.size(); ++i) {
        ASSERT_TRUE(k[i].sampled && o[i].sampled) << i;
        EXPECT_NEAR(k[i].term.term, o[i].term.term, bar(k[i].term.std_error, o[i].term.std_error, int(queries.size())))
            << "query " << i << ": kernel " << k[i].term.term << " +- " << k[i].term.std_error << ", oracle "
            << o[i].term.term << " +- " << o[i].term.std_error;
        // Non-trivial cases, resolved: neither 0 nor lost in the bars.
        EXPECT_GT(k[i].term.term, 0.02) << "query " << i;
        EXPECT_LT(k[i].term.std_error, 5e-3) << "query " << i;
    }
}

}  // namespace
}  // namespace ms

namespace ms {
namespace {

TEST(AreaLightGeometry, RectRepresentativePointIsTheClampedMirrorHit) {
    // A 2 x 2 square on the plane z = 1 centred over the shaded point; wi at 30 degrees from the normal.
    AreaQuery q = rect(0.5, 0.25, std::cos(area::radians(30)), {0, 0, 1}, 2, Lobe::ggx);
    const Vec3 r = area::representative_direction(q);  // the mirror direction hits the square (tan 30 < 1)
    EXPECT_NEAR(r.x, -q.wi.x, 1e-12);
    EXPECT_NEAR(r.z, q.wi.z, 1e-12);
    q.wi = {std::sin(area::radians(60)), 0, std::cos(area::radians(60))};  // tan 60 > 1: clamped to x = -1
    const Vec3 c = area::representative_direction(q);
    EXPECT_NEAR(c.x / c.z, -1.0, 1e-12);
    EXPECT_NEAR(c.y, 0.0, 1e-12);
    q.lobe = Lobe::lambert;  // Lambert: the centre
    const Vec3 l = area::representative_direction(q);
    EXPECT_NEAR(l.z, 1.0, 1e-12);
    EXPECT_NEAR(area::max_height(q.light), 1.0, 0);
}

TEST(AreaLightTaps, RectTapsCoverTheLightOrTheNarrowLobeAndWeighNothingBelowTheHorizon) {
    // Lambert, or GGX wider than the light: nine taps inside the rectangle, the rule's weights times solid
    // angle and f cos; their sum times the area is the 3 x 3 Gauss estimate of Int f cos dw, which on a
    // rectangle facing the normal at unit distance (half-angle ~20 degrees) is Lambert's polygon formula to
    // the rule's error (the integrand is a smooth rational function of the corners: 1e-4 relative is loose
    // for degree 5 on this size; measured 2e-6).
    const AreaQuery facing = area::normalised(rect(0.5, 0.25, 0.7, {0, 0, 1}, 0.5, Lobe::lambert));
    const auto taps = area::rect_taps(facing);
    ASSERT_EQ(taps.size(), 9u);
    double sum = 0;
    for (const auto& t : taps) {
        EXPECT_GT(t.weight, 0);
        const Vec3 p{t.wo.x / t.wo.z, t.wo.y / t.wo.z, 1};  // on the plane z = 1: inside the square of side 0.5
        EXPECT_LE(std::max(std::fabs(p.x), std::fabs(p.y)), 0.25 + 1e-12);
        sum += t.weight;
    }
    double polygon = 0;
    const auto& k = facing.light.rect.corners;
    for (int e = 0; e < 4; ++e) {
        const Vec3 a = k[e], b = k[(e + 1) % 4];
        const Vec3 n{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
        polygon += std::atan2(std::hypot(n.x, n.y, n.z), a.x * b.x + a.y * b.y + a.z * b.z) * n.z / std::hypot(n.x, n.y, n.z);
    }
    const double lambert_integral = std::fabs(polygon) / (2 * ms::kPi);  // (1/pi) Int cos dw
    EXPECT_NEAR(sum * 0.25, lambert_integral, 1e-4 * lambert_integral);  // area 0.5 x 0.5
    // A narrow GGX lobe (alpha 0.01) whose mirror direction hits a large panel: the taps gather within the
    // lobe's angle (2 atan(0.02) along each side, sqrt(2) of it to a corner) of Karis's point.
    const AreaQuery narrow = area::normalised(rect(0.5, 0.01, std::cos(area::radians(30)), {0, 0, 1}, 3, Lobe::ggx));
    const Vec3 r = area::representative_direction(narrow);
    for (const auto& t : area::rect_taps(narrow)) {
        const double angle = std::acos(std::min(1.0, t.wo.x * r.x + t.wo.y * r.y + t.wo.z * r.z));
        EXPECT_LE(angle, std::sqrt(2.0) * 2 * std::atan(0.02) + 1e-9);
    }
    // A panel across the horizon: the taps below it weigh nothing.
    const auto straddling = area::rect_taps(rect(0.5, 0.25, 0.7, direction_deg(0, 30), 0.8, Lobe::lambert));
    int below = 0, above = 0;
    for (const auto& t : straddling) below += t.wo.z <= 0 && t.weight == 0, above += t.wo.z > 0 && t.weight > 0;
    EXPECT_GE(below, 3);
    EXPECT_GE(above, 3);
}

}  // namespace
}  // namespace ms
