// The anisotropic representation ("anisotropic-harmonics", the anisotropic preset's kind) on a tiny
// grid baked with the exact method: at its texel centres and roughness nodes its C++ lookup, fed the
// tangent-frame query a renderer has (alpha_x, alpha_y, V and L), agrees with the exact term within the
// bake's own recorded fit residual; an isotropic query gives the isotropic caller's answer whatever the
// frame's rotation; its domain counts a ratio or an axis roughness outside as outside; its file round-trips.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "core/query.hpp"
#include "jobs/eval.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"
#include "repr/texture_repr.hpp"

namespace {

namespace repr = ms::repr;

// 3 visibility x 3 NdotL x 2 NdotV texels, 2 geometric nodes, 4 x 2 configurations up to ratio 4: 4
// slabs x <= 8 surfaces x 18 texels, a few hundred exact queries (well under a second).
repr::AnisotropicBakeSpec tiny_spec() {
    repr::AnisotropicBakeSpec s;
    s.grid.visibility = 3, s.grid.n_dot_l = 3, s.grid.n_dot_v = 2;
    s.grid.roughness = {0.35, 0.7};
    s.grid.warps = {repr::NdotVWarp::sqrt, repr::NdotLWarp::edge_roughness, repr::VisibilityWarp::sqrt_top};
    s.grid.edge_width = 1.0;
    s.azimuth_configs = 4, s.correlation_configs = 2, s.max_ratio = 4;
    s.plan.method = ms::Method::exact;
    return s;
}

const repr::Representation& tiny() {
    static auto r = [] {
        auto backend = ms::make_oracle_backend();
        return repr::bake_anisotropic(tiny_spec(), *backend);
    }();
    return *r;
}

double recorded(const char* field) {
    return static_cast<const repr::TextureRepresentation&>(tiny()).metadata().at("bake").at(field).get<double>();
}

ms::Vec3 direction(double cos_theta, double phi) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

TEST(ReprAnisotropicTest, AtItsNodesTheLookupMatchesTheExactTermWithinTheRecordedFitResidual) {
    const auto spec = tiny_spec();
    const auto& g = spec.grid;
    const auto& rep = tiny();
    std::vector<ms::Query> queries;
    std::vector<double> looked_up, weights;
    for (std::uint32_t jv = 0; jv < 2; ++jv)
        for (std::uint32_t jl = 0; jl < 2; ++jl) {
            const double av = g.roughness[jv] * g.roughness[jv], al = g.roughness[jl] * g.roughness[jl];
            const auto surfaces = repr::anisotropic_surfaces(spec, av, al);
            ASSERT_GE(surfaces.size(), 4u) << "slab " << jv << ", " << jl;
            for (const auto& s : surfaces) {
                const double pv = -s.axis_angle, pl = s.dphi - s.axis_angle;
                // The surface is what the slab stands for: its projected alphas along V and L are the
                // nodes' (forward, from its principal axes) and its ratio is within the bake's.
                const double av2 = std::pow(s.alpha_x * std::cos(pv), 2) + std::pow(s.alpha_y * std::sin(pv), 2);
                const double al2 = std::pow(s.alpha_x * std::cos(pl), 2) + std::pow(s.alpha_y * std::sin(pl), 2);
                EXPECT_NEAR(std::sqrt(av2), av, 1e-9);
                EXPECT_NEAR(std::sqrt(al2), al, 1e-9);
                // Within the bake's ratio, or twice the nodes' ratio for a slab no such surface reaches.
                const double ratio = std::max(spec.max_ratio, 2 * std::max(av / al, al / av));
                EXPECT_LE(std::max(s.alpha_x / s.alpha_y, s.alpha_y / s.alpha_x), ratio * (1 + 1e-9));
                for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
                    for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                        for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                            ms::Query q;
                            q.visibility = g.visibility_at(iv);
                            q.alpha_x = s.alpha_x, q.alpha_y = s.alpha_y;
                            q.wi = direction(g.n_dot_v_at(ivv), pv);
                            q.wo = direction(g.n_dot_l_at(iv, il, jl), pl);
                            queries.push_back(q);
                            looked_up.push_back(rep(ms::approx::inputs_of(q, ms::AoWeighting::cosine)));
                            weights.push_back(q.wo.z);
                        }
            }
        }
    auto backend = ms::make_oracle_backend();
    ms::SamplingPlan plan;
    plan.method = ms::Method::exact;
    const auto exact = ms::evaluate(*backend, queries, ms::TermOptions{}, plan);
    // At a texel centre and a node the lookup is the fitted series at the surface's (dphi, rho): the
    // bake's fit residual there (recorded as fit_max) plus float storage of the coefficients (|a_m| <=
    // coefficient_bound, 4 terms of |basis| <= 1: 4 x 2^-24 relative) and the exact method's 1e-10.
    const double bound = static_cast<const repr::TextureRepresentation&>(rep).metadata().at("coefficient_bound").get<double>();
    const double tolerance = recorded("fit_max") + 4 * bound * std::ldexp(1.0, -23) + 1e-9;
    double worst = 0, sum = 0, weight = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const double e = looked_up[i] - exact[i].term;
        worst = std::max(worst, std::abs(e));
        sum += weights[i] * e * e, weight += weights[i];
    }
    EXPECT_LE(worst, tolerance) << queries.size() << " queries";
    // These are the bake's own surfaces and texels, so the N.L-weighted RMS is the recorded fit RMS
    // (the same residuals, up to the same float storage): a lookup that read another slab, node or
    // azimuth would move it by the coefficients' spread.
    EXPECT_NEAR(std::sqrt(sum / weight), recorded("fit_rms"), 4 * bound * std::ldexp(1.0, -23) + 1e-9);
}

TEST(ReprAnisotropicTest, AnIsotropicQueryGivesTheIsotropicCallersAnswerInAnyFrame) {
    const auto& rep = tiny();
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 200; ++i) {
        const double r = 0.35 + 0.35 * u(rng), v = u(rng), nl = u(rng), nv = 0.05 + 0.95 * u(rng);
        const double dphi = M_PI * u(rng), frame = 2 * M_PI * u(rng);
        ms::approx::Inputs iso;  // what an isotropic caller gives: roughness and relative azimuth only
        iso.visibility = v, iso.n_dot_l = nl, iso.n_dot_v = nv, iso.roughness = r, iso.relative_azimuth = dphi;
        ms::Query q;
        q.visibility = v, q.alpha_x = q.alpha_y = r * r;
        q.wi = direction(nv, frame);
        q.wo = direction(nl, frame + (i % 2 ? dphi : -dphi));
        const double a = rep(iso), b = rep(ms::approx::inputs_of(q, ms::AoWeighting::cosine));
        EXPECT_NEAR(a, b, 1e-9) << "roughness " << r << " dphi " << dphi << " frame " << frame;
    }
}

TEST(ReprAnisotropicTest, ARatioOrAnAxisRoughnessOutsideTheBakedDomainIsOutside) {
    const auto d = tiny().domain();
    ASSERT_TRUE(d.has_value());
    EXPECT_DOUBLE_EQ(d->max_alpha_ratio, 4);
    const double r = 0.5;  // isotropic-equivalent roughness inside [0.35, 0.7] in every case
    EXPECT_TRUE(d->contains(0.5, 0.5, 0.5, r, 0.3, 0.2));
    EXPECT_TRUE(d->contains(0.5, 0.5, 0.5, r));  // no alphas: the roughness stands for both axes
    // Ratio 4.9 > 4.
    EXPECT_FALSE(d->contains(0.5, 0.5, 0.5, r, 0.49, 0.1));
    EXPECT_NE(d->first_outside(0.5, 0.5, 0.5, r, 0.49, 0.1).find("alpha ratio"), std::string::npos);
    // Ratio 2 but alpha_y 0.09 (roughness 0.3 < 0.35).
    EXPECT_FALSE(d->contains(0.5, 0.5, 0.5, r, 0.18, 0.09));
    EXPECT_NE(d->first_outside(0.5, 0.5, 0.5, r, 0.18, 0.09).find("sqrt(alpha_y)"), std::string::npos);
    // Recorded in the file's metadata and read back.
    const auto back = ms::LookupDomain::from_json(d->to_json(), "test");
    EXPECT_DOUBLE_EQ(back.max_alpha_ratio, 4);
    // The preset records ratio 25.
    EXPECT_DOUBLE_EQ(repr::preset("anisotropic").domain.max_alpha_ratio, 25);
}

TEST(ReprAnisotropicTest, FileRoundTripsAndADamagedCoefficientIsRefused) {
    const auto& rep = tiny();
    const std::string dir = ::testing::TempDir() + "repr_anisotropic";
    std::filesystem::create_directories(dir);
    const std::string path = dir + "/tiny.exr";
    rep.write(path, false);
    const auto back = repr::open_representation(path);
    EXPECT_EQ(back->kind(), "anisotropic-harmonics");
    EXPECT_EQ(back->cost().fetches_per_light, 4u);
    ms::Query q;
    q.visibility = 0.7, q.alpha_x = 0.3, q.alpha_y = 0.15;
    q.wi = direction(0.6, 0.4), q.wo = direction(0.8, 2.0);
    const auto in = ms::approx::inputs_of(q, ms::AoWeighting::cosine);
    EXPECT_EQ(rep(in), (*back)(in));
    // A coefficient beyond the bake's bound (the largest |P| row sum) is refused when opened.
    std::vector<float> texels = rep.texels();
    const double bound = static_cast<const repr::TextureRepresentation&>(rep).metadata().at("coefficient_bound").get<double>();
    texels[5] = float(2 * bound);
    nlohmann::json meta = static_cast<const repr::TextureRepresentation&>(rep).metadata();
    const auto damaged = repr::build_anisotropic_harmonics(rep.grid(), texels, meta);
    damaged->write(dir + "/damaged.exr", false);
    EXPECT_THROW(repr::open_representation(dir + "/damaged.exr"), std::runtime_error);
}

}  // namespace
