// The anisotropic representation "anisotropic-harmonics" (no command bakes it any more; its files still
// open): a tiny file baked with the exact method before its bake was retired (tests/data/repr/
// anisotropic-harmonics-tiny.exr: 3 visibility x 3 NdotL x 2 NdotV texels, nodes 0.35 and 0.7, ratio <= 4)
// opens, and at its texel centres and every pair of view and light nodes its C++ lookup, fed the
// tangent-frame query a renderer has (alpha_x, alpha_y, V and L), is the stored series a0 + a1 cos dphi +
// a2 cos 2 dphi + a3 rho of the slot and slab the layout names; an isotropic query gives the isotropic
// caller's answer whatever the frame's rotation; its domain counts a ratio or an axis roughness outside
// as outside; its file round-trips and a damaged coefficient is refused.
// "anisotropic-mapped-harmonics" (an azimuth-harmonics texture looked up at the surface's isotropic
// equivalent): on isotropic surfaces it is the azimuth-harmonics lookup of its bake in any frame, on
// anisotropic ones that lookup at repr::isotropic_equivalent; the mapping meets its measured accuracy
// against the exact term on random anisotropic queries; its file round-trips.
// The anisotropic preset's kind ("anisotropic-corrected-harmonics": the mapped lookup plus a correction
// per texel): on isotropic surfaces it is the azimuth-harmonics lookup whatever its correction; on
// anisotropic ones the mapped lookup plus exactly the correction its stencil says it reads; the preset
// meets its measured accuracy against the exact term (and the target 0.03) where the mapped lookup alone
// does not; its file round-trips and a coefficient beyond its recorded bound is refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <sstream>

#include "core/query.hpp"
#include "exact/exact_term.hpp"
#include "jobs/eval.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"
#include "repr/texture_repr.hpp"
#include "max_search.hpp"
#include "sanitizers.hpp"

namespace {

namespace repr = ms::repr;

// The grid of the tiny file: 3 visibility x 3 NdotL x 2 NdotV texels, 2 geometric nodes.
repr::ReprGrid tiny_grid() {
    repr::ReprGrid g;
    g.visibility = 3, g.n_dot_l = 3, g.n_dot_v = 2;
    g.roughness = {0.35, 0.7};
    g.warps = {repr::NdotVWarp::sqrt, repr::NdotLWarp::edge_roughness, repr::VisibilityWarp::sqrt_top};
    g.edge_width = 1.0;
    return g;
}

const repr::Representation& tiny() {
    static const auto r = repr::open_representation(std::string(MICROSHADOW_TEST_DATA) + "/repr/anisotropic-harmonics-tiny.exr");
    return *r;
}

ms::Vec3 direction(double cos_theta, double phi) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// At a texel centre and a pair of nodes the lookup is the stored series of that texel: the file's layout
// (x = light node x visibility texels + visibility texel, z = view node x NdotV texels + NdotV texel),
// read back. Surfaces with their principal axes along V and L have projected alphas alpha_x along one
// and alpha_y along the other, rho = 0 and dphi = pi / 2 (series a0 - a2), or both along V (dphi = 0,
// rho = 1: a0 + a1 + a2 + a3 on the diagonal slab).
TEST(ReprAnisotropicTest, AtItsNodesTheLookupIsTheStoredSeriesOfTheSlotAndSlabTheLayoutNames) {
    const auto& rep = tiny();
    EXPECT_EQ(rep.kind(), "anisotropic-harmonics");
    const repr::ReprGrid g = tiny_grid();
    ASSERT_EQ(rep.grid().roughness, g.roughness);
    ASSERT_EQ(rep.texture_width(), 6u);
    ASSERT_EQ(rep.texture_depth(), 4u);
    const std::vector<float>& texels = rep.texels();
    const std::uint32_t width = rep.texture_width(), height = rep.texture_height();
    std::size_t checked = 0, nonzero = 0;
    for (std::uint32_t jv = 0; jv < 2; ++jv)
        for (std::uint32_t jl = 0; jl < 2; ++jl)
            for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
                for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                    for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                        const double av = g.roughness[jv] * g.roughness[jv], al = g.roughness[jl] * g.roughness[jl];
                        ms::Query q;
                        q.visibility = g.visibility_at(iv);
                        q.alpha_x = av, q.alpha_y = al;
                        const bool same = jv == jl;  // dphi = 0 on the diagonal slab, else pi / 2
                        q.wi = direction(g.n_dot_v_at(ivv), 0);
                        q.wo = direction(g.n_dot_l_at(iv, il, jl), same ? 0 : M_PI / 2);
                        const std::size_t x = std::size_t(jl) * g.visibility + iv, z = std::size_t(jv) * g.n_dot_v + ivv;
                        const float* a = &texels[((z * height + il) * width + x) * 4];
                        const double series = same ? double(a[0]) + a[1] + a[2] + a[3] : double(a[0]) - a[2];
                        // The zero region (2 v + NdotL <= 1 under cosine weighting) is 0 by rule; a direction along the
                        // normal has no azimuth, so no projected alpha of its own.
                        if (2 * q.visibility + q.wo.z <= 1 + 1e-6 || q.wo.z > 1 - 1e-9 || q.wi.z > 1 - 1e-9) continue;
                        const double got = rep(ms::approx::inputs_of(q, ms::AoWeighting::cosine));
                        EXPECT_NEAR(got, std::clamp(series, 0.0, 1.0), 1e-6)
                            << "slab (" << jv << ", " << jl << ") texel (" << iv << ", " << il << ", " << ivv << ")";
                        ++checked;
                        nonzero += got > 0.01;
                    }
    EXPECT_GT(checked, 50u);
    EXPECT_GT(nonzero, 20u);  // a lookup that answered 0 everywhere would not pass
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

// The tiny grid's azimuth bake (7 azimuth nodes, exact method), as the anisotropic preset bakes its own.
const repr::AzimuthBake& tiny_azimuth_bake() {
    static const repr::AzimuthBake b = [] {
        repr::AzimuthBakeSpec s;
        s.grid = tiny_grid();
        s.azimuth_nodes = 7;
        s.plan.method = ms::Method::exact;
        auto backend = ms::make_oracle_backend();
        return repr::bake_azimuth(s, *backend);
    }();
    return b;
}

ms::approx::Inputs isotropic_inputs(double v, double nl, double nv, double roughness, double cos_phi) {
    ms::approx::Inputs in;
    in.visibility = v, in.n_dot_l = nl, in.n_dot_v = nv, in.roughness = roughness;
    in.relative_azimuth = std::acos(std::clamp(cos_phi, -1.0, 1.0));
    return in;
}

// On isotropic surfaces in any tangent frame (300 random queries, roughness 0.3-0.8), `rep` must give
// `plain`'s lookup at the relative azimuth within 1e-9 (`why`: the bound's reason); the lookups must
// also move (a spread above 0.5), or a lookup that ignored its inputs would pass.
void expect_isotropic_identity(const repr::Representation& rep, const repr::Representation& plain, unsigned seed, const char* why) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    double spread = 0;  // how far the lookups move over these queries: what a wrong mapping would err by
    for (int i = 0; i < 300; ++i) {
        const double r = 0.3 + 0.5 * u(rng), v = u(rng), nl = u(rng), nv = 0.05 + 0.95 * u(rng);
        const double dphi = M_PI * u(rng), frame = 2 * M_PI * u(rng);
        ms::Query q;
        q.visibility = v, q.alpha_x = q.alpha_y = r * r;
        q.wi = direction(nv, frame);
        q.wo = direction(nl, frame + (i % 2 ? dphi : -dphi));
        const double expected = plain(isotropic_inputs(v, nl, nv, r, std::cos(dphi)));
        EXPECT_NEAR(rep(ms::approx::inputs_of(q, ms::AoWeighting::cosine)), expected, 1e-9)
            << why << ": roughness " << r << " dphi " << dphi << " frame " << frame;
        spread = std::max(spread, expected);
    }
    EXPECT_GT(spread, 0.5);
}

TEST(ReprAnisotropicMappedTest, IsotropicSurfacesInAnyFrameGiveTheAzimuthHarmonicsLookupOfTheBake) {
    const auto mapped = repr::build_representation("anisotropic-mapped-harmonics", tiny_azimuth_bake());
    const auto plain = repr::build_representation("azimuth-harmonics", tiny_azimuth_bake());
    EXPECT_EQ(mapped->kind(), "anisotropic-mapped-harmonics");
    EXPECT_EQ(mapped->cost().fetches_per_light, 2u);
    // The mapping is the identity on an isotropic surface up to double rounding (1e-15 relative),
    // which the lookup's slopes (< 1e4 per unit) keep below 1e-9.
    expect_isotropic_identity(*mapped, *plain, 5, "the mapping's identity");
}

TEST(ReprAnisotropicMappedTest, AnAnisotropicSurfaceIsLookedUpAtItsIsotropicEquivalent) {
    const auto mapped = repr::build_representation("anisotropic-mapped-harmonics", tiny_azimuth_bake());
    const auto plain = repr::build_representation("azimuth-harmonics", tiny_azimuth_bake());
    std::mt19937 rng(6);
    std::uniform_real_distribution<double> u(0, 1);
    int differs = 0;
    for (int i = 0; i < 300; ++i) {
        ms::Query q;
        q.visibility = u(rng), q.alpha_x = 0.1 + 0.4 * u(rng), q.alpha_y = q.alpha_x / (1 + 9 * u(rng));
        const double pv = 2 * M_PI * u(rng), pl = 2 * M_PI * u(rng), nv = 0.05 + 0.95 * u(rng), nl = u(rng);
        q.wi = direction(nv, pv), q.wo = direction(nl, pl);
        const auto e = repr::isotropic_equivalent(q.alpha_x, q.alpha_y, pv, pl, nv, nl);
        const auto in = ms::approx::inputs_of(q, ms::AoWeighting::cosine);
        const double got = (*mapped)(in);
        // The mapping reads the light's own NdotL for the zero region, its equivalent for the texel.
        const double expected = in.n_dot_l <= 0 || 2 * q.visibility + in.n_dot_l <= 1
                                    ? 0.0
                                    : (*plain)(isotropic_inputs(q.visibility, e.n_dot_l, e.n_dot_v, e.roughness, e.cos_phi));
        EXPECT_NEAR(got, expected, 1e-9) << "query " << i;
        // The isotropic-equivalent roughness and true azimuth would read another texel.
        const double naive = (*plain)(in);
        differs += std::abs(naive - got) > 1e-3;
    }
    EXPECT_GT(differs, 100);
}

// The mapping against the exact term, without a texture: the exact isotropic term at the isotropic
// equivalent, on random queries of the preset's domain (scripts/repr_queries.py anisotropic's law).
// Measured on 10,000 queries of another seed (docs/representations.md): N.L-weighted RMS 0.0444; the
// bound is that plus 3 standard errors of this sample's RMS (delta method from the spread of the
// weighted squared errors), so a mapping no better than measured passes with probability ~0.999 and
// the isotropic-equivalent roughness with the true azimuth (RMS 0.125) fails.
TEST(ReprAnisotropicMappedTest, TheMappingMeetsItsMeasuredAccuracyAgainstTheExactTerm) {
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> u(0, 1);
    const std::size_t n = 2000;
    std::vector<ms::Query> aniso, iso, naive;
    for (std::size_t i = 0; i < n; ++i) {
        const double v = 0.02 + 0.98 * u(rng), ratio = 1 + 24 * u(rng);
        const double r_max = 0.05 * std::sqrt(ratio) + (1 - 0.05 * std::sqrt(ratio)) * u(rng), a_max = r_max * r_max;
        const bool x_rougher = u(rng) < 0.5;
        const double ax = x_rougher ? a_max : a_max / ratio, ay = x_rougher ? a_max / ratio : a_max;
        const double nv = 0.02 + 0.98 * u(rng), nl = u(rng), pv = 2 * M_PI * u(rng), pl = 2 * M_PI * u(rng);
        ms::Query q;
        q.visibility = v, q.alpha_x = ax, q.alpha_y = ay;
        q.wi = direction(nv, pv), q.wo = direction(nl, pl);
        aniso.push_back(q);
        const auto e = repr::isotropic_equivalent(ax, ay, pv, pl, nv, nl);
        ms::Query m;
        m.visibility = v, m.alpha_x = m.alpha_y = e.roughness * e.roughness;
        m.wi = direction(e.n_dot_v, 0), m.wo = direction(e.n_dot_l, std::acos(e.cos_phi));
        iso.push_back(m);
        m.alpha_x = m.alpha_y = std::sqrt(ax * ay);
        m.wi = direction(nv, 0), m.wo = direction(nl, pl - pv);
        naive.push_back(m);
    }
    auto backend = ms::make_oracle_backend();
    ms::SamplingPlan plan;
    plan.method = ms::Method::exact;
    const auto exact = ms::evaluate(*backend, aniso, ms::TermOptions{}, plan);
    auto rms_and_error = [&](const std::vector<ms::Query>& qs) {
        const auto mapped = ms::evaluate(*backend, qs, ms::TermOptions{}, plan);
        double w = 0, s = 0, s2 = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const double e2 = std::pow(mapped[i].term - exact[i].term, 2), wi = aniso[i].wo.z;
            w += wi, s += wi * e2, s2 += wi * e2 * e2;
        }
        const double mse = s / w;
        // Standard error of the weighted mean of e^2 (weights normalised), then of its square root.
        double var = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const double wi = aniso[i].wo.z / w, e2 = std::pow(mapped[i].term - exact[i].term, 2);
            var += wi * wi * (e2 - mse) * (e2 - mse);
        }
        return std::make_pair(std::sqrt(mse), std::sqrt(var) / (2 * std::sqrt(mse)));
    };
    const auto [rms, se] = rms_and_error(iso);
    EXPECT_LE(rms, 0.0444 + 3 * se) << "standard error " << se;
    const auto [naive_rms, naive_se] = rms_and_error(naive);
    EXPECT_GT(naive_rms, 0.0444 + 3 * se) << "the isotropic-equivalent roughness: standard error " << naive_se;
}

TEST(ReprAnisotropicMappedTest, TheMappedKindsFileRoundTrips) {
    const auto rep = repr::build_representation("anisotropic-mapped-harmonics", tiny_azimuth_bake());
    const std::string dir = ::testing::TempDir() + "repr_anisotropic_mapped";
    std::filesystem::create_directories(dir);
    rep->write(dir + "/tiny.exr", false);
    const auto back = repr::open_representation(dir + "/tiny.exr");
    EXPECT_EQ(back->kind(), "anisotropic-mapped-harmonics");
    EXPECT_EQ(back->cost().fetches_per_light, 2u);
    ms::Query q;
    q.visibility = 0.7, q.alpha_x = 0.3, q.alpha_y = 0.15;
    q.wi = direction(0.6, 0.4), q.wo = direction(0.8, 2.0);
    const auto in = ms::approx::inputs_of(q, ms::AoWeighting::cosine);
    EXPECT_EQ((*rep)(in), (*back)(in));
}

// A correction of random coefficients in [-1, 1] for the tiny grid.
std::vector<float> random_correction(const repr::ReprGrid& g, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<float> c(repr::anisotropic_correction_texels(g) * 4);
    for (auto& x : c) x = float(u(rng));
    return c;
}

TEST(ReprAnisotropicCorrectedTest, IsotropicSurfacesInAnyFrameGiveTheAzimuthHarmonicsLookupWhateverTheCorrection) {
    const auto corrected = repr::build_anisotropic_corrected(tiny_azimuth_bake(), random_correction(tiny_grid(), 3), nlohmann::json::object());
    const auto plain = repr::build_representation("azimuth-harmonics", tiny_azimuth_bake());
    EXPECT_EQ(corrected->kind(), "anisotropic-corrected-harmonics");
    EXPECT_EQ(corrected->cost().fetches_per_light, 4u);
    EXPECT_EQ(corrected->texture_depth(), 2 * plain->texture_depth());
    // The features are 0 up to double rounding (1e-16), times coefficients <= 1: below 1e-9.
    expect_isotropic_identity(*corrected, *plain, 7, "zero features");
}

TEST(ReprAnisotropicCorrectedTest, AnAnisotropicLookupIsTheMappedOnePlusTheCorrectionItsStencilReads) {
    const auto& bake = tiny_azimuth_bake();
    const auto correction = random_correction(bake.grid, 4);
    const auto corrected = repr::build_anisotropic_corrected(bake, correction, nlohmann::json::object());
    const auto zero = repr::build_anisotropic_corrected(bake, {}, nlohmann::json::object());
    const auto mapped = repr::build_representation("anisotropic-mapped-harmonics", bake);
    std::mt19937 rng(8);
    std::uniform_real_distribution<double> u(0, 1);
    int moved = 0, active = 0;
    for (int i = 0; i < 300; ++i) {
        ms::Query q;
        q.visibility = u(rng), q.alpha_x = 0.1 + 0.4 * u(rng), q.alpha_y = q.alpha_x / (1 + 9 * u(rng));
        const double pv = 2 * M_PI * u(rng), pl = 2 * M_PI * u(rng);
        q.wi = direction(0.05 + 0.95 * u(rng), pv), q.wo = direction(u(rng), pl);
        const auto in = ms::approx::inputs_of(q, ms::AoWeighting::cosine);
        // A zero correction is the mapped lookup.
        EXPECT_NEAR((*zero)(in), (*mapped)(in), 1e-12) << "query " << i;
        const auto s = repr::correction_stencil(*corrected, in);
        const double got = (*corrected)(in);
        if (!s.active) {
            EXPECT_EQ(got, (*mapped)(in)) << "query " << i << ": answered by rule";
            continue;
        }
        ++active;
        const auto g = repr::anisotropy_features(q.alpha_x, q.alpha_y, in.view_azimuth, in.light_azimuth);
        for (int m = 0; m < 4; ++m) EXPECT_EQ(s.features[m], g[m]);
        EXPECT_EQ(s.texels, 16u);
        double value = s.base;
        for (std::size_t k = 0; k < s.texels; ++k)
            for (int m = 0; m < 4; ++m) value += s.weight[k] * correction.at(4 * std::size_t(s.texel[k]) + m) * g[m];
        // The stencil's blend (1 - f) a + f b and the lookup's a + (b - a) f differ by double rounding.
        EXPECT_NEAR(got, std::clamp(value, 0.0, 1.0), 1e-9) << "query " << i;
        moved += std::abs(got - (*mapped)(in)) > 1e-3;
    }
    EXPECT_GT(active, 150);
    EXPECT_GT(moved, 100);
}

TEST(ReprAnisotropicCorrectedTest, TheKindsFileRoundTripsAndACoefficientBeyondItsBoundIsRefused) {
    const auto& bake = tiny_azimuth_bake();
    const auto rep = repr::build_anisotropic_corrected(bake, random_correction(bake.grid, 5), nlohmann::json::object());
    const std::string dir = ::testing::TempDir() + "repr_anisotropic_corrected";
    std::filesystem::create_directories(dir);
    rep->write(dir + "/tiny.exr", false);
    const auto back = repr::open_representation(dir + "/tiny.exr");
    EXPECT_EQ(back->kind(), "anisotropic-corrected-harmonics");
    EXPECT_EQ(back->cost().fetches_per_light, 4u);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 50; ++i) {
        ms::Query q;
        q.visibility = u(rng), q.alpha_x = 0.1 + 0.4 * u(rng), q.alpha_y = q.alpha_x / (1 + 9 * u(rng));
        q.wi = direction(0.05 + 0.95 * u(rng), 2 * M_PI * u(rng)), q.wo = direction(u(rng), 2 * M_PI * u(rng));
        const auto in = ms::approx::inputs_of(q, ms::AoWeighting::cosine);
        EXPECT_EQ((*rep)(in), (*back)(in)) << "query " << i;
    }
    // The recorded bound is the largest |coefficient| (< 1 here): a texel rewritten to 3 is refused.
    auto damaged = rep->texels();
    damaged[damaged.size() - 2] = 3.0f;
    const auto& t = static_cast<const repr::TextureRepresentation&>(*rep);
    ms::repr::Texture3D tex{rep->texture_width(), rep->texture_height(), rep->texture_depth(), damaged};
    const auto bad = repr::make_anisotropic_corrected(rep->grid(), t.azimuth_nodes(), tex, t.metadata());
    EXPECT_THROW(static_cast<const repr::TextureRepresentation&>(*bad).check_contents(t.channel_names()), std::runtime_error);
}

// The preset against the exact term on random queries of its domain (scripts/repr_queries.py
// anisotropic's law, another seed than the figures' and than the correction's fit). Measured on 10,000
// queries (docs/representations.md): N.L-weighted RMS 0.0207, ratio 10-25 0.0232. Each bound is that
// figure plus 3 standard errors of this sample's RMS (delta method from the spread of the weighted
// squared errors), so a preset no worse than measured passes with probability ~0.999 each; the
// target 0.03 is asserted too (over 5 standard errors above the measured figure). The mapped lookup
// alone (the zero correction, measured 0.0463) fails the first bound.
// The preset's own fit at a small size (the whole preset's is 2,000,000 queries and runs in the test
// below): the same coefficients every time, and a fit that improves on the mapped lookup it starts
// from. Conjugate gradients from the zero correction never raise the ridge objective, so the weighted
// RMS of the data term can only fall (it is computed on the coefficients as stored).
TEST(ReprAnisotropicCorrectedTest, ASmallFitIsRepeatableAndImprovesOnTheMappedLookup) {
    auto p = repr::preset("anisotropic");
    p.grid = tiny_azimuth_bake().grid;
    p.correction_queries = 4000, p.correction_iterations = 10;
    auto backend = ms::make_oracle_backend();
    const auto a = repr::build_preset(p, tiny_azimuth_bake(), *backend);
    const auto b = repr::build_preset(p, tiny_azimuth_bake(), *backend);
    EXPECT_EQ(a->kind(), "anisotropic-corrected-harmonics");
    EXPECT_TRUE(a->texels() == b->texels());
    const auto texels = a->texels();
    EXPECT_TRUE(std::any_of(texels.begin() + texels.size() / 2, texels.end(), [](float x) { return x != 0; }));
    const auto& fit = static_cast<const repr::TextureRepresentation&>(*a).metadata().at("correction");
    EXPECT_LT(fit.at("fit_rms_after").get<double>(), fit.at("fit_rms_before").get<double>()) << fit.dump(2);
}

// The anisotropic preset's domain as a unit box for the adversarial search (tests/support/max_search.hpp):
// v (1 - v = 0.98 (1 - x)^4, dense towards v = 1), the rougher alpha geometric in [0.0025, 1], the other
// geometric from it down to the ratio 25 (or 0.0025), V's and L's azimuths from the tangent in [0, 2 pi)
// (the rougher axis along x loses nothing: a quarter turn of both swaps the axes), NdotV = 0.02 + 0.98 x^2
// and NdotL = x^2 (grazing views, the horizon).
ms::Query anisotropic_point(const std::vector<double>& x) {
    ms::Query q;
    q.visibility = 1 - 0.98 * std::pow(1 - x[0], 4);
    q.alpha_x = 0.0025 * std::pow(400.0, x[1]);
    const double lowest = std::max(q.alpha_x / 25, 0.0025);
    q.alpha_y = q.alpha_x * std::pow(lowest / q.alpha_x, x[2]);
    q.wi = direction(0.02 + 0.98 * x[3] * x[3], 2 * M_PI * x[4]);
    q.wo = direction(x[5] * x[5], 2 * M_PI * x[6]);
    return q;
}

ms::testing::MaxSearchResult search_anisotropic(const ms::approx::Approximation& rep, std::size_t screen, std::size_t starts,
                                                int steps, std::uint64_t seed) {
    const auto error = [&](const std::vector<double>& x) {
        const ms::Query q = anisotropic_point(x);
        const double term = q.wo.z <= 0 ? 0.0 : ms::exact::exact_term(q, ms::AoWeighting::cosine, 1e-9).term;
        return std::fabs(rep(ms::approx::inputs_of(q, ms::AoWeighting::cosine)) - term);
    };
    return ms::testing::search_max_error(error, 7, screen, starts, steps, seed);
}

std::string anisotropic_where(const ms::testing::MaxSearchResult& r) {
    const ms::Query q = anisotropic_point(r.at);
    std::ostringstream o;
    o << "max " << r.max_error << " at v " << q.visibility << " alpha_x " << q.alpha_x << " alpha_y " << q.alpha_y << " V ("
      << q.wi.x << ", " << q.wi.y << ", " << q.wi.z << ") L (" << q.wo.x << ", " << q.wo.y << ", " << q.wo.z << ") ("
      << r.evaluations << " evaluations)";
    return o.str();
}

// The preset's stated max (docs/representations.md, "Presets"), which the search must not exceed.
constexpr double kAnisotropicStatedMax = 0.96;

TEST(ReprAnisotropicCorrectedTest, ThePresetMeetsItsMeasuredAccuracyAgainstTheExactTerm) {
    // The shipped preset's accuracy is a property of its numbers, measured in the optimised build; under
    // the sanitizers its 2,000,000-query fit would take minutes, and its code runs in the small fit above.
    if (ms::testing::kAsan) GTEST_SKIP() << "accuracy of the shipped preset: checked in the optimised build";
    const auto p = repr::preset("anisotropic");
    EXPECT_EQ(p.kind, "anisotropic-corrected-harmonics");
    EXPECT_DOUBLE_EQ(p.domain.max_alpha_ratio, 25);
    const auto rep = repr::baked_preset("anisotropic");
    EXPECT_EQ(rep->kind(), "anisotropic-corrected-harmonics");
    EXPECT_LE(rep->cost().bytes, 1u << 20);
    EXPECT_LE(rep->cost().fetches_per_light, 4u);
    std::mt19937_64 rng(33);
    std::uniform_real_distribution<double> u(0, 1);
    const std::size_t n = 3000;
    std::vector<ms::Query> qs;
    std::vector<double> ratios;
    for (std::size_t i = 0; i < n; ++i) {
        const double v = 0.02 + 0.98 * u(rng), ratio = 1 + 24 * u(rng);
        const double r_max = 0.05 * std::sqrt(ratio) + (1 - 0.05 * std::sqrt(ratio)) * u(rng), a_max = r_max * r_max;
        const bool x_rougher = u(rng) < 0.5;
        ms::Query q;
        q.visibility = v, q.alpha_x = x_rougher ? a_max : a_max / ratio, q.alpha_y = x_rougher ? a_max / ratio : a_max;
        const double nv = 0.02 + 0.98 * u(rng), nl = u(rng);
        q.wi = direction(nv, 2 * M_PI * u(rng)), q.wo = direction(nl, 2 * M_PI * u(rng));
        qs.push_back(q);
        ratios.push_back(ratio);
    }
    auto backend = ms::make_oracle_backend();
    ms::SamplingPlan plan;
    plan.method = ms::Method::exact;
    const auto exact = ms::evaluate(*backend, qs, ms::TermOptions{}, plan);
    // N.L-weighted RMS of a lookup over the queries whose ratio is in [lo, hi), and its standard error.
    auto rms_and_error = [&](const ms::approx::Approximation& a, double lo, double hi) {
        std::vector<double> e2, w;
        for (std::size_t i = 0; i < n; ++i) {
            if (ratios[i] < lo || ratios[i] >= hi) continue;
            e2.push_back(std::pow(a(ms::approx::inputs_of(qs[i], ms::AoWeighting::cosine)) - exact[i].term, 2));
            w.push_back(std::max(qs[i].wo.z, 0.0));
        }
        double sw = 0, s = 0;
        for (std::size_t i = 0; i < e2.size(); ++i) sw += w[i], s += w[i] * e2[i];
        const double mse = s / sw;
        double var = 0;
        for (std::size_t i = 0; i < e2.size(); ++i) var += std::pow(w[i] / sw, 2) * (e2[i] - mse) * (e2[i] - mse);
        return std::make_pair(std::sqrt(mse), std::sqrt(var) / (2 * std::sqrt(mse)));
    };
    const auto [rms, se] = rms_and_error(*rep, 1, 26);
    EXPECT_LE(rms, 0.0204 + 3 * se) << "standard error " << se;
    EXPECT_LE(rms, 0.03);
    const auto [band, band_se] = rms_and_error(*rep, 10, 26);
    EXPECT_LE(band, 0.0228 + 3 * band_se) << "ratio 10-25: standard error " << band_se;
    // The mapped lookup alone: the same texture without the correction.
    const auto& t = static_cast<const repr::TextureRepresentation&>(*rep);
    auto texels = rep->texels();
    std::fill(texels.begin() + texels.size() / 2, texels.end(), 0.0f);
    const auto zero = repr::make_anisotropic_corrected(rep->grid(), t.azimuth_nodes(),
                                                       ms::repr::Texture3D{rep->texture_width(), rep->texture_height(), rep->texture_depth(), texels},
                                                       t.metadata());
    const auto [zero_rms, zero_se] = rms_and_error(*zero, 1, 26);
    EXPECT_GT(zero_rms, 0.0204 + 3 * se) << "the mapped lookup alone: standard error " << zero_se;
    // The max, searched adversarially over the whole domain (the random queries above straddle it).
    const auto worst = search_anisotropic(*rep, 4096, 256, 300, 1);
    std::printf("[ figures  ] anisotropic searched %s\n", anisotropic_where(worst).c_str());
    EXPECT_LE(worst.max_error, kAnisotropicStatedMax) << anisotropic_where(worst);
}

// The figure of docs/representations.md: a search four times the size, from other seeds. Run by hand
// (--gtest_also_run_disabled_tests --gtest_filter='*MeasureSearchedMax*').
TEST(ReprAnisotropicCorrectedTest, DISABLED_MeasureSearchedMax) {
    const auto rep = repr::baked_preset("anisotropic");
    for (std::uint64_t seed : {2, 3, 4}) {
        const auto r = search_anisotropic(*rep, 16384, 1024, 300, seed);
        std::printf("[ figures  ] anisotropic seed %llu: searched %s\n", (unsigned long long)seed, anisotropic_where(r).c_str());
    }
}

}  // namespace
