// Area lights with the exact inner term (jobs/area.hpp, exact_inner_term): the sampled outer integral
// over the light with the deterministic evaluator's T(wo) at every direction, against the sampled
// paths within bars and against known answers.
//
// Bars: as tests/integrands/area_light_test.cpp, t(1 - (1 - 0.999) / N, R - 1) * sqrt(se_a^2 + se_b^2), plus the
// exact path's inner_error (a deterministic bound on what the inner values' own errors contribute).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "cli_runner.hpp"
#include "core/area_light.hpp"
#include "core/estimate.hpp"
#include "exact/exact_term.hpp"
#include "exact/gauss_legendre.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "jobs/area.hpp"
#include "jobs/eval.hpp"
#include "area_light_queries.hpp"

namespace ms {
namespace {

using area::AreaQuery;
using area::LightShape;
using area::Lobe;
using testing::bar;
using testing::direction_deg;
using testing::have_device;
using testing::kReplicates;
using testing::plan;
using testing::sphere;

// A rectangle of sides a x b facing the shaded point at distance 2 along `towards`.
AreaQuery rect(double v, double alpha, double n_dot_v, const Vec3& towards, double a, double b, Lobe lobe) {
    AreaQuery q = sphere(v, alpha, n_dot_v, 90, 0, 1, lobe);
    q.light.shape = LightShape::rect;
    const Vec3 c{2 * towards.x, 2 * towards.y, 2 * towards.z};
    const Vec3 helper = std::fabs(towards.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
    Vec3 t1{helper.y * towards.z - helper.z * towards.y, helper.z * towards.x - helper.x * towards.z,
            helper.x * towards.y - helper.y * towards.x};
    const double l = std::hypot(t1.x, t1.y, t1.z);
    t1 = {t1.x / l, t1.y / l, t1.z / l};
    const Vec3 t2{towards.y * t1.z - towards.z * t1.y, towards.z * t1.x - towards.x * t1.z, towards.x * t1.y - towards.y * t1.x};
    auto corner = [&](double s, double t) {
        return Vec3{c.x + s * t1.x + t * t2.x, c.y + s * t1.y + t * t2.y, c.z + s * t1.z + t * t2.z};
    };
    q.light.rect.corners = {corner(-a / 2, -b / 2), corner(a / 2, -b / 2), corner(a / 2, b / 2), corner(-a / 2, b / 2)};
    return q;
}

area::AreaRoutineConfig exact_config(double tolerance = area::kExactInnerTolerance) {
    area::AreaRoutineConfig c;
    c.inner_term = area::exact_inner_term(AoWeighting::cosine, tolerance);
    return c;
}

TEST(AreaLightExactInner, AgreesWithTheSampledPathWithinBars) {
    // Sphere and rectangle lights, both lobes, one anisotropic surface and one light across the horizon;
    // the sampled reference is the joint kernel where a device exists, else the independent oracle.
    std::vector<AreaQuery> queries = {
        sphere(0.5, 0.25, 0.7, 40, 180, 10, Lobe::ggx),
        sphere(0.6, 0.49, 0.4, 25, 60, 20, Lobe::lambert),
        sphere(0.7, 1.0, 0.3, 5, 120, 15, Lobe::ggx),  // straddles the horizon
        rect(0.5, 0.25, 0.7, direction_deg(45, 180), 1.2, 0.6, Lobe::ggx),
        rect(0.6, 0.36, 0.5, direction_deg(30, 90), 0.8, 1.6, Lobe::lambert),
    };
    queries[1].alpha_y = 0.16;
    auto host = make_oracle_backend();
    const auto e = area::evaluate_area(*host, queries, {}, plan(8 * 512, 11), exact_config());
    const bool device = have_device();
    auto sampled_backend = device ? make_opencl_backend(ocl::select_devices("default")) : make_oracle_backend();
    const auto s = area::evaluate_area(*sampled_backend, queries, {}, plan(device ? 8 * 65536 : 8 * 8192, 12));
    for (std::size_t i = 0; i < queries.size(); ++i) {
        ASSERT_TRUE(e[i].sampled && s[i].sampled);
        EXPECT_GT(e[i].inner_error, 0.0) << "query " << i;
        EXPECT_LT(e[i].inner_error, 1e-5) << "query " << i;  // a weighted mean of errors each <= ~1e-6
        EXPECT_NEAR(e[i].term.term, s[i].term.term,
                    bar(e[i].term.std_error, s[i].term.std_error, int(queries.size())) + e[i].inner_error)
            << "query " << i << ": exact inner " << e[i].term.term << " +- " << e[i].term.std_error << ", sampled "
            << s[i].term.term << " +- " << s[i].term.std_error;
    }
}

TEST(AreaLightExactInner, TinyLightsGiveTheExactPointTerm) {
    // gamma = 0.001 degrees (and a rectangle of the same size): T_area is a weighted mean of T over the
    // light, so it is within max |T(wo) - T(centre)| <= slope x radius of the centre's exact term. The
    // term's slope in any angle is about C / alpha with C <= 2 as measured for the scene's key grid
    // (jobs/scene.hpp); the bound below takes 2 C / alpha.
    const double gamma = area::radians(0.001);
    const std::vector<AreaQuery> queries = {sphere(0.5, 0.25, 0.7, 40, 180, 0.001, Lobe::ggx),
                                            sphere(0.6, 0.09, 0.4, 25, 60, 0.001, Lobe::lambert),
                                            rect(0.5, 0.36, 0.7, direction_deg(35, 90), 2 * std::tan(gamma), 2 * std::tan(gamma), Lobe::ggx)};
    auto host = make_oracle_backend();
    const auto e = area::evaluate_area(*host, queries, {}, plan(8 * 64, 13), exact_config(1e-10));
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const AreaQuery q = area::normalised(queries[i]);
        Query p;
        p.visibility = q.visibility;
        p.alpha_x = q.alpha_x;
        p.alpha_y = q.alpha_y;
        p.wi = q.wi;
        p.wo = area::centre_direction(q.light);
        const exact::ExactValue point = exact::exact_term(p, AoWeighting::cosine, 1e-10);
        const double slope_bound = 4.0 / std::min(q.alpha_x, q.alpha_y) * std::sqrt(2.0) * gamma;  // corners of the square
        EXPECT_NEAR(e[i].term.term, point.term,
                    bar(e[i].term.std_error, 0, int(queries.size())) + e[i].inner_error + point.error + slope_bound)
            << "query " << i;
        EXPECT_LT(std::fabs(e[i].term.term - point.term), 1e-3) << "query " << i;
    }
}

TEST(AreaLightExactInner, WholeHemisphereLambertIsTheCosineWeightedMean) {
    // As the kernel's test: a Lambert light of half-angle 89.99 degrees centred on the normal, wi along the
    // normal, isotropic: T depends on NdotL = mu alone and T_area = Int T(mu) 2 mu dmu / Int 2 mu dmu over
    // [cos 89.99 deg, 1]. The reference is deterministic: Gauss-Legendre on [mu0, 1] (T = 0 below
    // mu0 = 2 cos_t^2 - 1) in mu = mu0 + (1 - mu0) s^2, which makes T's square-root onset at mu0 smooth,
    // with the exact term at every node; its error is estimated by the 32- against the 48-point rule.
    for (double v : {0.4, 0.8}) {
        const AreaQuery q = sphere(v, 0.25, 1.0, 90, 0, 89.99, Lobe::lambert);
        auto host = make_oracle_backend();
        const auto a = area::evaluate_area(*host, {q}, {}, plan(8 * 1024, 14), exact_config(1e-9));
        const double mu0 = std::max(0.0, 1 - 2 * v), mu_min = std::cos(area::radians(89.99));
        double node_error = 0;
        auto mean = [&](int n) {
            const exact::GaussRule& rule = exact::gauss_legendre(n);
            double m = 0;
            for (std::size_t k = 0; k < rule.nodes.size(); ++k) {
                const double s = 0.5 * (rule.nodes[k] + 1), mu = mu0 + (1 - mu0) * s * s;
                Query p;
                p.visibility = v;
                p.alpha_x = p.alpha_y = 0.25;
                p.wi = {0, 0, 1};
                p.wo = {std::sqrt(1 - mu * mu), 0, mu};
                const exact::ExactValue t = exact::exact_term(p, AoWeighting::cosine, 1e-10);
                const double w = 0.5 * rule.weights[k] * (1 - mu0) * 2 * s * 2 * mu;  // ds, dmu/ds, 2 mu
                m += w * t.term;
                node_error += w * t.error;
            }
            return m / (1 - mu_min * mu_min);
        };
        const double m32 = mean(32), m48 = mean(48);
        const double reference_error = std::fabs(m48 - m32) + node_error;
        EXPECT_NEAR(a[0].term.term, m48, bar(a[0].term.std_error, 0, 2) + a[0].inner_error + reference_error)
            << "v " << v << ": area " << a[0].term.term << " +- " << a[0].term.std_error << ", mean " << m48
            << " (quadrature " << std::fabs(m48 - m32) << ")";
        // The outer sampling alone: without inner noise 8192 directions pin the mean far below the kernel's
        // ~1e-3 at 2^21 samples.
        EXPECT_LT(a[0].term.std_error, 2e-4) << "v " << v;
    }
}

TEST(AreaLightExactInner, ExactCasesAndSymmetryHold) {
    // The rules answer before any inner call (0 below the horizon, 1 at v = 1), and an isotropic
    // surface's light mirrored across the view's plane gives the same T_area within bars.
    int calls = 0;
    area::AreaRoutineConfig counting;
    counting.inner_term = [&calls](const Query&) {
        ++calls;
        return area::InnerValue(1.0);
    };
    auto host = make_oracle_backend(1);
    const auto r = area::evaluate_area(*host, {sphere(0.5, 0.25, 0.7, -30, 0, 10, Lobe::ggx), sphere(1.0, 0.25, 0.7, 40, 0, 10, Lobe::ggx)},
                                       {}, plan(8 * 64, 15), counting);
    EXPECT_EQ(calls, 0);
    EXPECT_EQ(r[0].term.term, 0.0);
    EXPECT_EQ(r[1].term.term, 1.0);
    AreaQuery a = sphere(0.5, 0.25, 0.6, 35, 70, 12, Lobe::ggx), mirrored = a;
    mirrored.light.sphere.centre.y = -mirrored.light.sphere.centre.y;
    const auto e = area::evaluate_area(*make_oracle_backend(), {a, mirrored}, {}, plan(8 * 512, 16), exact_config());
    EXPECT_NEAR(e[0].term.term, e[1].term.term, bar(e[0].term.std_error, e[1].term.std_error, 1) + e[0].inner_error + e[1].inner_error);
}

class AreaCommandCli : public testing::ScratchDirTest {
protected:
    AreaCommandCli() : ScratchDirTest("area-command") {}
    void write(const std::string& name, const std::string& text) { std::ofstream(path(name)) << text; }
};

TEST_F(AreaCommandCli, EvalMethodExactWritesTheInnerErrorAndRefusesWhatItIgnores) {
    write("q.csv",
          "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg\n"
          "0.5,0.25,0.25,0.6,0,0.8,-0.5,0,0.8,10\n"
          "0.5,0.25,0.25,0.6,0,0.8,0,0,-1,10\n");
    const std::string cli = MICROSHADOW_CLI;
    const std::string io = " --in " + path("q.csv") + " --out " + path("r.csv") + " 2>&1";
    auto ok = testing::run_shell(cli + " area eval --method exact -q --samples 1024" + io);
    ASSERT_EQ(ok.exit_code, 0) << ok.output;
    std::ifstream in(path("r.csv"));
    std::string header, row1, row2;
    std::getline(in, header), std::getline(in, row1), std::getline(in, row2);
    EXPECT_EQ(header, "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg,term,std_error,inner_error");
    EXPECT_EQ(row2.substr(row2.size() - 6), ",0,0,0");  // below the horizon: exactly 0, no inner call
    std::ifstream meta(path("r.csv.json"));
    const std::string json((std::istreambuf_iterator<char>(meta)), std::istreambuf_iterator<char>());
    EXPECT_NE(json.find("\"inner_tolerance\": 1e-06"), std::string::npos) << json;
    EXPECT_NE(json.find("\"method\": \"exact\""), std::string::npos) << json;
    std::filesystem::remove(path("r.csv"));
    for (const std::string& bad : {std::string(" --method exact --backend opencl"), std::string(" --method exact --device 0"),
                                   std::string(" --method sampled --tolerance 1e-6"), std::string(" --method exact --tolerance 1e-20")}) {
        auto r = testing::run_shell(cli + " area eval -q" + bad + io);
        EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.output;
        EXPECT_FALSE(std::filesystem::exists(path("r.csv"))) << bad;
    }
}

TEST_F(AreaCommandCli, RectSweepWritesItsRowsAndNeedsRandom) {
    const std::string cli = MICROSHADOW_CLI;
    auto ok = testing::run_shell(cli + " area sweep -q --light rect --random 3 --max-half-angle 20 --backend oracle --samples 1024 --out " +
                                 path("s.csv") + " 2>&1");
    ASSERT_EQ(ok.exit_code, 0) << ok.output;
    std::ifstream in(path("s.csv"));
    std::string line;
    int rows = -1;
    while (std::getline(in, line)) ++rows;
    EXPECT_EQ(rows, 3);
    std::ifstream meta(path("s.csv.json"));
    const std::string json((std::istreambuf_iterator<char>(meta)), std::istreambuf_iterator<char>());
    EXPECT_NE(json.find("\"light\": \"rect\""), std::string::npos) << json;
    auto r = testing::run_shell(cli + " area sweep -q --light rect --backend oracle --out " + path("t.csv") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("--light rect: the sweep draws random rectangles; give --random N"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(path("t.csv")));
    // The sweep is sampled throughout: an exact method is refused, not half applied.
    r = testing::run_shell(cli + " area sweep -q --method exact --random 2 --backend oracle --out " + path("t.csv") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("the exact inner term is `area eval --method exact`"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(path("t.csv")));
}

TEST(AreaLightStudy, RandomRectanglesHaveTheirHalfAngleAndAreValid) {
    // The widest corner angle is the drawn half-angle, every rectangle passes the checks, and the rect
    // representative point lies on the light.
    for (const auto& p : area::random_rect_points(200, 30, 5)) {
        ASSERT_NO_THROW(area::validate(p.query));
        const AreaQuery q = area::normalised(p.query);
        const Vec3 c = area::centre_direction(q.light);
        double widest = 0;
        for (const Vec3& k : q.light.rect.corners) {
            const double l = std::hypot(k.x, k.y, k.z);
            widest = std::max(widest, std::acos(std::min(1.0, (k.x * c.x + k.y * c.y + k.z * c.z) / l)));
        }
        EXPECT_NEAR(widest, area::radians(p.half_angle_deg), 1e-9);
        EXPECT_LE(p.half_angle_deg, 30.0);
    }
}

}  // namespace
}  // namespace ms
