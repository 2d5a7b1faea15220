// The azimuth grid (exact/azimuth_grid.hpp) against the per-value C++ evaluator (exact_term.hpp), which
// stays its oracle: the same term computed with the view rotated instead of the light and with the
// light's circle solved once per row must agree with the per-value path within the sum of both
// estimates, value by value and over whole small bakes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "core/cone.hpp"
#include "core/types.hpp"
#include "exact/azimuth_grid.hpp"
#include "exact/exact_term.hpp"
#include "grid/atlas.hpp"
#include "jobs/bake.hpp"
#include "sanitizers.hpp"

namespace {

using namespace ms;

// Rotating the view by -phi about e_z gives the term of the light at azimuth phi (the surface is
// isotropic), for any phi, including the grid's edge cases: normal incidence, grazing light, alpha 1
// (|v|^2 constant: the quartic degenerates and the arcs fall back to quadrature) and very smooth
// surfaces (poles next to the real axis).
TEST(AzimuthGrid, RotatingTheViewGivesThePerValueEvaluatorsTerm) {
    std::mt19937_64 rng(36);
    std::uniform_real_distribution<double> u(0, 1);
    const double alphas[] = {0.001, 0.01, 0.0625, 0.3, 0.77, 0.999, 1.0};
    int compared = 0;
    double worst_ratio = 0;
    for (int row = 0; row < 160; ++row) {
        const double v = row % 17 == 0 ? 1e-6 : u(rng);
        const double alpha = alphas[row % 7];
        const double nl = row % 11 == 0 ? 1.0 : row % 13 == 0 ? 1e-4 : 0.02 + 0.98 * u(rng);
        const AoWeighting weighting = row % 2 ? AoWeighting::cosine : AoWeighting::uniform;
        const exact::AzimuthGrid grid(v, alpha, nl, weighting);
        for (int k = 0; k < 6; ++k) {
            // (Not NdotV 1e-3 with visibility 1e-6: the cone's sine is then 1e-3 too and the support's
            // great circle is tangent to the cone's circle, where the term's sensitivity to the inputs'
            // last bits is unbounded and two frames' roundings differ by far more than the arithmetic
            // the estimates cover; a bake's azimuth mean only comes near such points on its breakpoints.)
            const double nv = k == 0 ? 1.0 : k == 1 ? 2.5e-3 : 0.01 + 0.99 * u(rng);
            const double phi = k == 2 ? 0.0 : k == 3 ? kPi : (2 * u(rng) - 1) * kPi;
            const exact::ExactValue fast = grid.term(nv, phi, 1e-10);
            const exact::ExactValue slow = exact::exact_term_at_azimuth(v, alpha, nv, nl, phi, weighting, 1e-10);
            const double allowed = fast.error + slow.error;
            EXPECT_LE(std::fabs(fast.term - slow.term), allowed)
                << "v " << v << " alpha " << alpha << " NdotL " << nl << " NdotV " << nv << " phi " << phi;
            EXPECT_LE(fast.error, 1e-10);
            worst_ratio = std::max(worst_ratio, std::fabs(fast.term - slow.term) / allowed);
            ++compared;
        }
    }
    std::printf("%d values, worst |grid - per-value| / (sum of estimates) %.3g\n", compared, worst_ratio);
}

// The hemisphere from the three great circles' meeting points against boundary_integral's arcs: random
// directions, and the LUT's own configurations where all three circles meet in two points (light and
// view in one vertical plane: relative azimuth 0 or pi) or two normals nearly coincide.
TEST(AzimuthGrid, HemisphereFromMeetingPointsMatchesTheArcs) {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> g(0, 1);
    std::uniform_real_distribution<double> u(0, 1);
    auto unit = [](Vec3 a) {
        const double n = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
        return Vec3{a.x / n, a.y / n, a.z / n};
    };
    const Vec3 ez{0, 0, 1};
    double worst = 0;
    for (int i = 0; i < 3000; ++i) {
        Vec3 wo = unit({g(rng), g(rng), std::fabs(g(rng)) + 1e-3});
        Vec3 wi = unit({g(rng), g(rng), std::fabs(g(rng)) + 1e-3});
        if (i % 5 == 1) wi = unit({wi.x, 0, wi.z}), wo = unit({i % 2 ? -wo.x : wo.x, 0, wo.z});   // coplanar
        if (i % 5 == 2) wo = unit({wi.x + 1e-9 * g(rng), wi.y + 1e-9 * g(rng), wi.z});             // wo ~ wi
        if (i % 5 == 3) wi = unit({1e-7 * g(rng), 1e-7 * g(rng), 1});                               // wi ~ e_z
        const double alpha = std::pow(10.0, -3 * u(rng));
        const exact::Microsurface surface = exact::make_microsurface(alpha, alpha, wi);
        const exact::BoundaryIntegral points = exact::hemisphere_integral(surface, ez, wo, wi);
        const exact::BoundaryIntegral arcs =
            exact::boundary_integral(surface, std::vector<exact::Cap>{{ez, 0, 1}, {wo, 0, 1}, {wi, 0, 1}}, exact::ArcRule{}, 0);
        const double allowed = points.error + arcs.error;
        EXPECT_LE(std::fabs(points.value - arcs.value), allowed) << "case " << i << " alpha " << alpha;
        worst = std::max(worst, std::fabs(points.value - arcs.value) / allowed);
    }
    std::printf("worst |meeting points - arcs| / (sum of estimates) %.3g\n", worst);
}

// The cone circles' meetings with each other's caps, found once per row (circle_in_cap) and passed to
// boundary_integral, give the bits boundary_integral finds without them: on random rows and views, with
// the cone's circles crossing, nested, apart and nearly coincident (NdotL near 1).
TEST(AzimuthGrid, KnownMeetingsGiveTheSameBitsAsFindingThem) {
    std::mt19937_64 rng(3604);
    std::uniform_real_distribution<double> u(0, 1);
    const Vec3 ez{0, 0, 1};
    int with_arcs = 0;
    for (int i = 0; i < 4000; ++i) {
        const double v = i % 9 == 0 ? 1e-5 : u(rng);
        const double alpha = std::pow(10.0, -2.5 * u(rng));
        const double nl = i % 7 == 0 ? 1 - 1e-9 * u(rng) : 0.01 + 0.99 * u(rng);
        const double nv = 0.01 + 0.99 * u(rng), phi = kPi * u(rng);
        const AoWeighting weighting = i % 2 ? AoWeighting::cosine : AoWeighting::uniform;
        const double c = cone_cos_theta(v, weighting), s = std::sqrt(cone_sin2_theta(v, weighting));
        const double sl = std::sqrt(1 - nl * nl), sv = std::sqrt(1 - nv * nv);
        const Vec3 wo{sl, 0, nl}, wi{sv * std::cos(phi), -sv * std::sin(phi), nv};
        const exact::Cap round_z{ez, c, s}, round_wo{wo, c, s};
        const exact::CircleInCap known[2] = {exact::circle_in_cap(round_z, round_wo), exact::circle_in_cap(round_wo, round_z)};
        const exact::PreparedCircle prepared = exact::prepare_circle(alpha, alpha, round_wo);
        const exact::Microsurface surface = exact::make_microsurface(alpha, alpha, wi);
        const exact::ArcRule rule = exact::arc_rule_for(1e-9);
        exact::Cap found_caps[3] = {round_z, round_wo, {wi, 0, 1}}, known_caps[3] = {round_z, round_wo, {wi, 0, 1}};
        const exact::BoundaryIntegral found = exact::boundary_integral(surface, found_caps, 3, rule, 1e-9, &prepared);
        const exact::BoundaryIntegral taken = exact::boundary_integral(surface, known_caps, 3, rule, 1e-9, &prepared, known, 2);
        EXPECT_EQ(found.value, taken.value) << "case " << i;
        EXPECT_EQ(found.error, taken.error) << "case " << i;
        EXPECT_EQ(found.quadrature_pieces, taken.quadrature_pieces) << "case " << i;
        with_arcs += found.value != 0;
    }
    EXPECT_GT(with_arcs, 1000);  // the cone is not empty in most cases, so the meetings were used
}

TEST(AzimuthGrid, MeansAgreeWithThePerValueEvaluatorsMeans) {
    std::mt19937_64 rng(3636);
    std::uniform_real_distribution<double> u(0, 1);
    for (int row = 0; row < 24; ++row) {
        const double v = 0.02 + 0.96 * u(rng), alpha = std::pow(0.05 + 0.95 * u(rng), 2), nl = 0.02 + 0.98 * u(rng);
        const exact::AzimuthGrid grid(v, alpha, nl, AoWeighting::cosine);
        for (int k = 0; k < 3; ++k) {
            const double nv = 0.02 + 0.98 * u(rng);
            const exact::ExactValue fast = grid.mean(nv, 1e-8);
            const exact::ExactValue slow = exact::exact_azimuth_mean(v, alpha, nv, nl, AoWeighting::cosine, 1e-8);
            EXPECT_LE(std::fabs(fast.term - slow.term), fast.error + slow.error)
                << "v " << v << " alpha " << alpha << " NdotL " << nl << " NdotV " << nv;
            EXPECT_LE(fast.error, 1e-8);
        }
    }
}

// A whole exact bake (which runs the grid) against the per-value evaluator on every texel: the stored
// float within its recorded error plus the per-value mean's estimate.
void check_bake_against_per_value_path(bool azimuth_mean, double tolerance) {
    BakeSpec spec = default_bake_spec(LutLayout::seed_3d, 8);
    spec.method = Method::exact;
    spec.tolerance = tolerance;
    spec.backend = schedule::BackendSpec::oracle();
    spec.azimuth_mean = azimuth_mean;
    spec.azimuth_degrees = 50;
    const BakeResult bake = bake_lut(spec);
    ASSERT_TRUE(bake.tolerance_met);
    const std::uint32_t channels = std::uint32_t(spec.roughness.size());
    const AtlasShape shape{spec.visibility.count, spec.n_dot_l.count, spec.n_dot_v.count, channels};
    std::size_t checked = 0, outside = 0;
    double worst_ratio = 0;
    for (std::uint32_t ch = 0; ch < channels; ++ch)
        for (std::uint32_t ivv = 0; ivv < spec.n_dot_v.count; ++ivv)
            for (std::uint32_t il = 0; il < spec.n_dot_l.count; ++il)
                for (std::uint32_t iv = 0; iv < spec.visibility.count; ++iv) {
                    const double v = spec.visibility.value(iv), nl = std::max(spec.n_dot_l.value(il), kMinNdotL);
                    const double nv = std::max(spec.n_dot_v.value(ivv), kMinNdotV);
                    const double alpha = spec.roughness[ch] * spec.roughness[ch];
                    const exact::ExactValue per_value =
                        azimuth_mean ? exact::exact_azimuth_mean(v, alpha, nv, nl, AoWeighting::cosine, tolerance)
                                     : exact::exact_term_at_azimuth(v, alpha, nv, nl, 50 * kPi / 180, AoWeighting::cosine,
                                                                    tolerance);
                    const std::size_t at = shape.index(ch, iv, il, ivv);
                    const double difference = std::fabs(bake.value[at] - per_value.term);
                    const double allowed = bake.std_error[at] + per_value.error;
                    ++checked;
                    worst_ratio = std::max(worst_ratio, allowed > 0 ? difference / allowed : difference > 0 ? 1e9 : 0);
                    if (difference > allowed && ++outside <= 10)
                        ADD_FAILURE() << "v " << v << " alpha " << alpha << " NdotV " << nv << " NdotL " << nl << ": grid "
                                      << bake.value[at] << " +- " << bake.std_error[at] << ", per value "
                                      << per_value.term << " +- " << per_value.error;
                }
    EXPECT_EQ(outside, 0u);
    EXPECT_EQ(checked, std::size_t(8) * 8 * 8 * channels);
    std::printf("%zu texels (%s), worst |grid bake - per-value| / (sum of estimates) %.3g\n", checked,
                azimuth_mean ? "azimuth means" : "azimuth 50 degrees", worst_ratio);
}

TEST(AzimuthGridBake, EveryTexelOfASmallMeanBakeAgreesWithThePerValueEvaluator) {
    if (ms::testing::kAsan) GTEST_SKIP() << "whole-bake comparisons run in the optimised build";
    check_bake_against_per_value_path(true, 1e-7);
}

TEST(AzimuthGridBake, EveryTexelOfASmallFixedAzimuthBakeAgreesWithThePerValueEvaluator) {
    check_bake_against_per_value_path(false, 1e-7);
}

}  // namespace
