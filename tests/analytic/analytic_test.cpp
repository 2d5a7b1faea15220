// Part 1's analytic micro-shadowing terms: hand-checked values and the properties part 1 states.
#include "analytic/part1_terms.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace {

namespace an = ms::analytic;
using ms::AoWeighting;

constexpr double kTight = 1e-12;

// An inclusive grid of n + 1 points on [lo, hi].
std::vector<double> grid(double lo, double hi, int n) {
    std::vector<double> g;
    for (int i = 0; i <= n; ++i) g.push_back(lo + (hi - lo) * i / n);
    return g;
}

// ---------------------------------------------------------------------------------------------------
// Cone

TEST(AnalyticCone, CosineAndUniformWeighting) {
    // cosine: sqrt(1 - 0.75) = sqrt(0.25) = 0.5; uniform: 1 - 0.75 = 0.25.
    EXPECT_DOUBLE_EQ(an::cone_cos_theta(0.75, AoWeighting::cosine), 0.5);
    EXPECT_DOUBLE_EQ(an::cone_cos_theta(0.75, AoWeighting::uniform), 0.25);
    // v = 0: no visibility, cone collapses to the normal (cos = 1); v = 1: hemisphere (cos = 0).
    EXPECT_DOUBLE_EQ(an::cone_cos_theta(0.0, AoWeighting::cosine), 1.0);
    EXPECT_DOUBLE_EQ(an::cone_cos_theta(1.0, AoWeighting::cosine), 0.0);
    EXPECT_DOUBLE_EQ(an::cone_cos_theta(0.0, AoWeighting::uniform), 1.0);
    EXPECT_DOUBLE_EQ(an::cone_cos_theta(1.0, AoWeighting::uniform), 0.0);
    // Uniform-weighted bakes give the wider cone for the same v in (0,1): 1 - v < sqrt(1 - v).
    for (double v : grid(0.01, 0.99, 20))
        EXPECT_LT(an::cone_cos_theta(v, AoWeighting::uniform), an::cone_cos_theta(v, AoWeighting::cosine));
}

// ---------------------------------------------------------------------------------------------------
// Reference step

TEST(AnalyticReference, HandValues) {
    // v = 0.75, cosine: cos = 0.5. step(0.5, NdotL) is inclusive (HLSL step: x >= a).
    EXPECT_EQ(an::reference_step(0.75, 0.5, AoWeighting::cosine), 1.0);
    EXPECT_EQ(an::reference_step(0.75, 0.49, AoWeighting::cosine), 0.0);
    EXPECT_EQ(an::reference_step(0.75, 0.9, AoWeighting::cosine), 1.0);
    // v = 0.75, uniform: cos = 0.25.
    EXPECT_EQ(an::reference_step(0.75, 0.3, AoWeighting::uniform), 1.0);
    EXPECT_EQ(an::reference_step(0.75, 0.2, AoWeighting::uniform), 0.0);
}

TEST(AnalyticReference, InclusiveBoundaryAtTheExtremes) {
    // The code's step() is inclusive, unlike part 1's strict "cos_theta < N.L":
    // v = 0 -> cos = 1, so NdotL = 1 is lit (1) and anything below is shadowed.
    EXPECT_EQ(an::reference_step(0.0, 1.0, AoWeighting::cosine), 1.0);
    EXPECT_EQ(an::reference_step(0.0, 0.999, AoWeighting::cosine), 0.0);
    // v = 1 -> cos = 0, so the horizon NdotL = 0 is lit and below it is shadowed.
    EXPECT_EQ(an::reference_step(1.0, 0.0, AoWeighting::cosine), 1.0);
    EXPECT_EQ(an::reference_step(1.0, -0.01, AoWeighting::cosine), 0.0);
}

// ---------------------------------------------------------------------------------------------------
// Naughty Dog

TEST(AnalyticNaughtyDog, HandValues) {
    // v = 0.5, NdotL = 0.8: 0.8 + 2 * 0.25 - 1 = 0.3.
    EXPECT_NEAR(an::naughty_dog(0.5, 0.8), 0.3, kTight);
    // v = 0.9, NdotL = 0.1: 0.1 + 2 * 0.81 - 1 = 0.72.
    EXPECT_NEAR(an::naughty_dog(0.9, 0.1), 0.72, kTight);
    // v = 0.9, NdotL = 0.5: 0.5 + 1.62 - 1 = 1.12 -> saturate -> 1.
    EXPECT_EQ(an::naughty_dog(0.9, 0.5), 1.0);
    // v = 0.3, NdotL = 0.5: 0.5 + 0.18 - 1 = -0.32 -> 0.
    EXPECT_EQ(an::naughty_dog(0.3, 0.5), 0.0);
}

TEST(AnalyticNaughtyDog, ZeroVisibilityIsFullyShadowed) {
    // v = 0: saturate(NdotL - 1) = 0 for every NdotL <= 1.
    for (double n_dot_l : grid(-1.0, 1.0, 40)) EXPECT_EQ(an::naughty_dog(0.0, n_dot_l), 0.0) << n_dot_l;
}

TEST(AnalyticNaughtyDog, BelowSqrtHalfShadowsEvenAlignedLight) {
    // At NdotL = 1 the term is saturate(2 v^2), < 1 exactly when v < sqrt(1/2).
    const double threshold = std::sqrt(0.5);
    for (double v : grid(0.0, threshold - 1e-6, 50)) EXPECT_LT(an::naughty_dog(v, 1.0), 1.0) << v;
    for (double v : grid(threshold + 1e-6, 1.0, 50)) EXPECT_EQ(an::naughty_dog(v, 1.0), 1.0) << v;
    // e.g. v = 0.5: 1 + 0.5 - 1 = 0.5.
    EXPECT_NEAR(an::naughty_dog(0.5, 1.0), 0.5, kTight);
}

TEST(AnalyticNaughtyDog, AboveSqrtHalfNeverFullyShadowedAboveHorizon) {
    // For v > sqrt(1/2): NdotL + 2 v^2 - 1 > NdotL >= 0, so the term is > 0 on NdotL in [0, 1].
    const double threshold = std::sqrt(0.5);
    for (double v : grid(threshold + 1e-6, 1.0, 50))
        for (double n_dot_l : grid(0.0, 1.0, 50)) EXPECT_GT(an::naughty_dog(v, n_dot_l), 0.0) << v << " " << n_dot_l;
    // ...while below sqrt(1/2) some NdotL in [0, 1] is fully shadowed (NdotL = 0 gives 2 v^2 - 1 < 0).
    for (double v : grid(0.0, threshold - 1e-6, 50)) EXPECT_EQ(an::naughty_dog(v, 0.0), 0.0) << v;
    // Below the horizon it can still reach 0: v = 0.8, NdotL = -0.5: -0.5 + 1.28 - 1 = -0.22 -> 0.
    EXPECT_EQ(an::naughty_dog(0.8, -0.5), 0.0);
}

TEST(AnalyticNaughtyDog, AoFresnelFade) {
    // lerp(1, v, saturate(NdotV)): v = 0.4, NdotV = 0.25: 1 + 0.25 (0.4 - 1) = 1 - 0.15 = 0.85.
    EXPECT_NEAR(an::naughty_dog_ao_fresnel_visibility(0.4, 0.25), 0.85, kTight);
    // NdotV = 1 keeps v, NdotV <= 0 (saturated) fades to 1.
    EXPECT_NEAR(an::naughty_dog_ao_fresnel_visibility(0.4, 1.0), 0.4, kTight);
    EXPECT_EQ(an::naughty_dog_ao_fresnel_visibility(0.4, 0.0), 1.0);
    EXPECT_EQ(an::naughty_dog_ao_fresnel_visibility(0.4, -0.3), 1.0);
    EXPECT_NEAR(an::naughty_dog_ao_fresnel_visibility(0.4, 1.7), 0.4, kTight);
    // Combined: v' = 0.85, NdotL = 0.5: 0.5 + 2 * 0.7225 - 1 = 0.945.
    EXPECT_NEAR(an::naughty_dog_with_ao_fresnel(0.4, 0.5, 0.25), 0.945, kTight);
    // Without the fade, v = 0.4, NdotL = 0.5: 0.5 + 0.32 - 1 < 0 -> 0.
    EXPECT_EQ(an::naughty_dog(0.4, 0.5), 0.0);
    // At grazing view the fade removes all micro-shadowing for NdotL >= 0 (v' = 1: NdotL + 1 >= 1).
    for (double n_dot_l : grid(0.0, 1.0, 20)) EXPECT_EQ(an::naughty_dog_with_ao_fresnel(0.0, n_dot_l, 0.0), 1.0);
}

// ---------------------------------------------------------------------------------------------------
// Activision

TEST(AnalyticActivision, HandValues) {
    // v = 0.75, cosine: cos = 0.5. NdotL = 0.25: (0.25 / 0.5)^2 = 0.25. NdotL = 0.6: saturate(1.2) = 1.
    EXPECT_NEAR(an::activision(0.75, 0.25, AoWeighting::cosine), 0.25, kTight);
    EXPECT_EQ(an::activision(0.75, 0.6, AoWeighting::cosine), 1.0);
    // v = 0.75, uniform: cos = 0.25. NdotL = 0.2: (0.2 / 0.25)^2 = 0.8^2 = 0.64.
    EXPECT_NEAR(an::activision(0.75, 0.2, AoWeighting::uniform), 0.64, kTight);
    // Below the horizon: saturate(negative) = 0.
    EXPECT_EQ(an::activision(0.75, -0.2, AoWeighting::cosine), 0.0);
}

TEST(AnalyticActivision, FollowsReferenceBoundary) {
    // The term is 1 exactly where the reference step is 1 (NdotL >= cos_theta), and < 1 elsewhere.
    for (AoWeighting w : {AoWeighting::cosine, AoWeighting::uniform})
        for (double v : grid(0.0, 0.99, 33))
            for (double n_dot_l : grid(-0.2, 1.0, 60)) {
                const double ref = an::reference_step(v, n_dot_l, w);
                const double act = an::activision(v, n_dot_l, w);
                if (ref == 1.0)
                    EXPECT_EQ(act, 1.0) << v << " " << n_dot_l;
                else
                    EXPECT_LT(act, 1.0) << v << " " << n_dot_l;
                EXPECT_GE(act, ref);  // never darker than the reference: the falloff is outside the cone
            }
}

TEST(AnalyticActivision, LightStillVisibleAtZeroVisibility) {
    // v = 0: cos = 1, so the term is saturate(NdotL)^2 -- not 0. NdotL = 0.5 -> 0.25.
    EXPECT_NEAR(an::activision(0.0, 0.5, AoWeighting::cosine), 0.25, kTight);
    EXPECT_NEAR(an::activision(0.0, 0.5, AoWeighting::uniform), 0.25, kTight);
    for (double n_dot_l : grid(0.05, 1.0, 19))
        EXPECT_NEAR(an::activision(0.0, n_dot_l, AoWeighting::cosine), n_dot_l * n_dot_l, kTight);
}

TEST(AnalyticActivision, FullVisibilityGuard) {
    // v == 1 returns 1 for every NdotL, even below the horizon (the code's division guard).
    for (double n_dot_l : grid(-1.0, 1.0, 8)) EXPECT_EQ(an::activision(1.0, n_dot_l, AoWeighting::cosine), 1.0);
}

TEST(AnalyticActivision, AdjustCosConeHandValue) {
    // cos = 0.5, gloss = 0.4, NdotV = 0.5:
    //   g = saturate(0.6) = 0.6; g^2 = 0.36; g^4 = 0.1296; g^8 = 0.01679616; 1 - g^8 = 0.98320384
    //   (1 - NdotV)^4 = 0.0625; 1 - 0.0625 = 0.9375
    //   t = 0.98320384 * 0.9375 = 0.9217536; adjusted = 0.5 * t = 0.4608768.
    EXPECT_NEAR(an::activision_adjust_cos_cone(0.5, 0.4, 0.5), 0.4608768, kTight);
    // Without the optional gloss scaling: g = 0.4; g^8 = 0.00065536;
    //   t = 0.99934464 * 0.9375 = 0.93688560; adjusted = 0.4684428.
    EXPECT_NEAR(an::activision_adjust_cos_cone(0.5, 0.4, 0.5, false), 0.4684428, kTight);
    // NdotV = 1: (1 - NdotV)^4 = 0, so only gloss matters; gloss = 0 -> unchanged cone.
    EXPECT_NEAR(an::activision_adjust_cos_cone(0.7, 0.0, 1.0), 0.7, kTight);
    // NdotV = 0 (grazing): 1 - 1 = 0 -> cone opened to 90 degrees.
    EXPECT_EQ(an::activision_adjust_cos_cone(0.7, 0.0, 0.0), 0.0);
    // gloss >= 2/3 -> g = 1 -> 1 - g^8 = 0 -> 90 degrees.
    EXPECT_EQ(an::activision_adjust_cos_cone(0.7, 0.7, 1.0), 0.0);
}

TEST(AnalyticActivision, WithConeAdjustmentHandValue) {
    // v = 0.75 (cos 0.5), roughness 0.6 (gloss 0.4), NdotV = 0.5: adjusted = 0.4608768 (see above).
    // NdotL = 0.3: 0.3 / 0.4608768 = 0.65093...; squared = 0.4237140...
    EXPECT_NEAR(an::activision_with_cone_adjustment(0.75, 0.6, 0.3, 0.5, AoWeighting::cosine),
                0.4237140019656224, 1e-12);
    // Uniform: cos = 0.25 -> adjusted = 0.2304384; NdotL = 0.2: (0.2 / 0.2304384)^2 = 0.753265...
    const double expected_uniform = std::pow(0.2 / 0.2304384, 2.0);
    EXPECT_NEAR(an::activision_with_cone_adjustment(0.75, 0.6, 0.2, 0.5, AoWeighting::uniform), expected_uniform,
                1e-12);
    // Roughness 1 (gloss 0, g^8 = 0) at NdotV = 1 (t = 1): the unadjusted Activision term.
    for (double v : grid(0.0, 0.99, 11))
        for (double n_dot_l : grid(0.0, 1.0, 11))
            EXPECT_NEAR(an::activision_with_cone_adjustment(v, 1.0, n_dot_l, 1.0, AoWeighting::cosine),
                        an::activision(v, n_dot_l, AoWeighting::cosine), 1e-12);
}

TEST(AnalyticActivision, NoMicroShadowingForRoughnessAtMostOneThird) {
    // roughness <= 1/3 -> gloss >= 2/3 -> saturate(1.5 gloss) = 1 -> adjusted cone 0 -> max(0, 0.001).
    // So the result is 1 for NdotL >= 0.001 and (1000 NdotL)^2 below, for every v and NdotV.
    for (double roughness : {0.0, 0.1, 0.2, 0.3, 1.0 / 3.0})
        for (double v : grid(0.0, 1.0, 10))
            for (double n_dot_v : grid(0.0, 1.0, 10)) {
                for (double n_dot_l : grid(0.001, 1.0, 20))
                    EXPECT_EQ(an::activision_with_cone_adjustment(v, roughness, n_dot_l, n_dot_v, AoWeighting::cosine),
                              1.0)
                        << roughness << " " << v << " " << n_dot_v << " " << n_dot_l;
                // NdotL = 0.0005: (0.0005 / 0.001)^2 = 0.25 -- the max(.., 0.001) clamp still shows.
                EXPECT_NEAR(an::activision_with_cone_adjustment(v, roughness, 0.0005, n_dot_v, AoWeighting::cosine),
                            0.25, 1e-9);
                EXPECT_EQ(an::activision_with_cone_adjustment(v, roughness, 0.0, n_dot_v, AoWeighting::cosine), 0.0);
            }
    // Just above 1/3 the adjustment lets micro-shadowing back in: roughness 0.4, gloss 0.6, g = 0.9,
    // g^8 = 0.43046721; NdotV = 1: adjusted = 0.56953279 cos. v = 0 (cos 1), NdotL = 0.5:
    // (0.5 / 0.56953279)^2 = 0.770727...
    EXPECT_NEAR(an::activision_with_cone_adjustment(0.0, 0.4, 0.5, 1.0, AoWeighting::cosine),
                std::pow(0.5 / 0.56953279, 2.0), 1e-9);
    EXPECT_LT(an::activision_with_cone_adjustment(0.0, 0.4, 0.5, 1.0, AoWeighting::cosine), 1.0);
}

TEST(AnalyticActivision, NoMicroShadowingAtGrazingView) {
    // NdotV = 0: (1 - 0)^4 = 1 -> t = 0 -> same clamp as above, for every roughness.
    for (double roughness : grid(0.0, 1.0, 10))
        for (double v : grid(0.0, 1.0, 10))
            EXPECT_EQ(an::activision_with_cone_adjustment(v, roughness, 0.5, 0.0, AoWeighting::cosine), 1.0);
}

TEST(AnalyticActivision, AlphaFromRoughnessHandValues) {
    // r = 1: sqrt(2 / (1 + 2^0)) = sqrt(1) = 1.
    EXPECT_NEAR(an::activision_alpha_from_roughness(1.0), 1.0, kTight);
    // r = 0.5: 2^9 = 512 -> sqrt(2 / 513) = 0.0624390541...
    EXPECT_NEAR(an::activision_alpha_from_roughness(0.5), std::sqrt(2.0 / 513.0), kTight);
    EXPECT_NEAR(an::activision_alpha_from_roughness(0.5), 0.062439054105446264, kTight);
    // r = 0: 2^18 = 262144 -> sqrt(2 / 262145) = 0.00276213...
    EXPECT_NEAR(an::activision_alpha_from_roughness(0.0), 0.00276213059566896, kTight);
    // Strictly increasing on [0, 1].
    double prev = 0.0;
    for (double r : grid(0.0, 1.0, 100)) {
        const double a = an::activision_alpha_from_roughness(r);
        EXPECT_GT(a, prev) << r;
        prev = a;
    }
}

TEST(AnalyticActivision, AlphaRoughnessRoundTrip) {
    for (double r : grid(-0.5, 1.5, 80))
        EXPECT_NEAR(an::activision_roughness_from_alpha(an::activision_alpha_from_roughness(r)), r, 1e-10) << r;
    for (double a : grid(0.003, 1.4, 80))
        EXPECT_NEAR(an::activision_alpha_from_roughness(an::activision_roughness_from_alpha(a)), a, 1e-12) << a;
    // alpha = 1 <-> r = 1 (2 / 1 - 1 = 1, log2 1 = 0).
    EXPECT_NEAR(an::activision_roughness_from_alpha(1.0), 1.0, kTight);
    EXPECT_THROW(an::activision_roughness_from_alpha(0.0), std::domain_error);
    EXPECT_THROW(an::activision_roughness_from_alpha(-0.1), std::domain_error);
    EXPECT_THROW(an::activision_roughness_from_alpha(std::sqrt(2.0)), std::domain_error);
    EXPECT_THROW(an::activision_roughness_from_alpha(std::nan("")), std::domain_error);
}

// ---------------------------------------------------------------------------------------------------
// PZ analytic

TEST(AnalyticPz, HandValues) {
    // v = 0.5: v^5 = 1/32 = 0.03125; cos' = sqrt(0.96875) = 0.98425098...; exponent 0.75 / 0.5 = 1.5.
    // NdotL = 0.5: (0.5 / 0.98425098)^1.5 = 0.50800^1.5 = 0.36207306...
    EXPECT_NEAR(an::pz_analytic(0.5, 0.5), 0.3620730662318301, 1e-12);
    // NdotL >= cos' saturates to 1: v = 0.5, NdotL = 0.99.
    EXPECT_EQ(an::pz_analytic(0.5, 0.99), 1.0);
    // v = 0.75: v^5 = 0.2373046875; cos' = sqrt(0.7626953125) = 0.87332...; exponent 1.
    // NdotL = 0.5: 0.5 / 0.87332... = 0.572525...
    EXPECT_NEAR(an::pz_analytic(0.75, 0.5), 0.5 / std::sqrt(0.7626953125), 1e-12);
    // Below the horizon: 0.
    EXPECT_EQ(an::pz_analytic(0.5, -0.3), 0.0);
}

TEST(AnalyticPz, EndpointsOfVisibility) {
    for (double n_dot_l : grid(-1.0, 1.0, 20)) {
        EXPECT_EQ(an::pz_analytic(1.0, n_dot_l), 1.0) << n_dot_l;
        EXPECT_EQ(an::pz_analytic(0.0, n_dot_l), 0.0) << n_dot_l;
    }
    // The v = 0 value comes from the frac() guard only: just above 0 an aligned light is fully lit
    // (NdotL / cos' >= 1 saturates, 1^(0.75 / v) = 1), while NdotL < 1 is driven towards 0.
    EXPECT_EQ(an::pz_analytic(1e-3, 1.0), 1.0);
    // v = 1e-3: cos' = sqrt(1 - 1e-15) ~ 1, exponent 750. NdotL = 0.99: 0.99^750 = e^(750 ln 0.99)
    // = e^(-7.5377) = 5.326e-4; NdotL = 0.9: 0.9^750 = e^(-79.02) ~ 4.8e-35.
    EXPECT_NEAR(an::pz_analytic(1e-3, 0.99), std::exp(750.0 * std::log(0.99)), 1e-15);
    EXPECT_NEAR(an::pz_analytic(1e-3, 0.99), 5.326e-4, 1e-6);
    EXPECT_LT(an::pz_analytic(1e-3, 0.9), 1e-34);
}

TEST(AnalyticPz, MonotonicInNdotLAndVisibility) {
    const std::vector<double> vs = grid(0.0, 1.0, 50);
    const std::vector<double> ls = grid(-0.2, 1.0, 60);
    for (double v : vs)
        for (size_t j = 1; j < ls.size(); ++j)
            EXPECT_GE(an::pz_analytic(v, ls[j]), an::pz_analytic(v, ls[j - 1])) << v << " " << ls[j];
    for (double n_dot_l : ls)
        for (size_t i = 1; i < vs.size(); ++i)
            EXPECT_GE(an::pz_analytic(vs[i], n_dot_l), an::pz_analytic(vs[i - 1], n_dot_l)) << vs[i] << " " << n_dot_l;
    // Values stay in [0, 1].
    for (double v : vs)
        for (double n_dot_l : ls) {
            const double t = an::pz_analytic(v, n_dot_l);
            EXPECT_GE(t, 0.0);
            EXPECT_LE(t, 1.0);
        }
}

// ---------------------------------------------------------------------------------------------------
// Schlick with the micro-occlusion F0 fix

TEST(AnalyticSchlick, HandValues) {
    // F0 = 0.04, F90 = 1, VdotH = 0.5: 0.04 + 0.96 * 0.5^5 = 0.04 + 0.96 * 0.03125 = 0.04 + 0.03 = 0.07.
    EXPECT_NEAR(an::f_schlick(0.04, 1.0, 0.5), 0.07, kTight);
    // VdotH = 1 -> F0; VdotH = 0 -> F90.
    EXPECT_NEAR(an::f_schlick(0.04, 1.0, 1.0), 0.04, kTight);
    EXPECT_NEAR(an::f_schlick(0.04, 0.8, 0.0), 0.8, kTight);
    // Micro-occlusion: F0 = 0.01 -> F90 = 0.5; 0.01 + 0.49 * 0.03125 = 0.01 + 0.0153125 = 0.0253125.
    EXPECT_NEAR(an::f_schlick_f0_micro_occlusion(0.01, 0.5), 0.0253125, kTight);
}

TEST(AnalyticSchlick, MicroOcclusionFix) {
    for (double v_dot_h : grid(0.0, 1.0, 20)) {
        // F0 >= 0.02: saturate(50 F0) = 1, identical to F90 = 1.
        for (double f0 : {0.02, 0.04, 0.1, 0.5, 1.0})
            EXPECT_EQ(an::f_schlick_f0_micro_occlusion(f0, v_dot_h), an::f_schlick(f0, 1.0, v_dot_h)) << f0;
        // F0 = 0: no specular at any angle.
        EXPECT_EQ(an::f_schlick_f0_micro_occlusion(0.0, v_dot_h), 0.0);
        // Below 2% the grazing response is reduced.
        EXPECT_LE(an::f_schlick_f0_micro_occlusion(0.01, v_dot_h), an::f_schlick(0.01, 1.0, v_dot_h));
    }
    // At grazing (VdotH = 0) the response is F90 = 50 F0: F0 = 0.01 -> 0.5.
    EXPECT_NEAR(an::f_schlick_f0_micro_occlusion(0.01, 0.0), 0.5, kTight);
}

// ---------------------------------------------------------------------------------------------------
// Registry

TEST(AnalyticRegistry, NamesRoundTrip) {
    const char* expected[] = {"reference-step", "naughty-dog", "naughty-dog-ao-fresnel",
                              "activision",     "activision-adjusted", "pz-analytic"};
    ASSERT_EQ(an::kAllAnalyticTerms.size(), 6u);
    for (size_t i = 0; i < an::kAllAnalyticTerms.size(); ++i) {
        const an::AnalyticTerm t = an::kAllAnalyticTerms[i];
        EXPECT_EQ(an::to_string(t), expected[i]);
        EXPECT_EQ(an::parse_analytic_term(an::to_string(t)), t);
    }
    EXPECT_THROW(an::parse_analytic_term("naughty_dog"), std::invalid_argument);
    EXPECT_THROW(an::parse_analytic_term(""), std::invalid_argument);
    try {
        an::parse_analytic_term("bogus");
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("pz-analytic"), std::string::npos);  // lists the valid names
    }
}

TEST(AnalyticRegistry, EvaluateDispatches) {
    for (AoWeighting w : {AoWeighting::cosine, AoWeighting::uniform})
        for (double v : grid(0.0, 1.0, 8))
            for (double n_dot_l : grid(-0.2, 1.0, 8))
                for (double n_dot_v : grid(0.0, 1.0, 4))
                    for (double r : {0.2, 0.6, 1.0}) {
                        const an::AnalyticInputs in{v, n_dot_l, n_dot_v, r, w};
                        EXPECT_EQ(an::evaluate(an::AnalyticTerm::reference_step, in), an::reference_step(v, n_dot_l, w));
                        EXPECT_EQ(an::evaluate(an::AnalyticTerm::naughty_dog, in), an::naughty_dog(v, n_dot_l));
                        EXPECT_EQ(an::evaluate(an::AnalyticTerm::naughty_dog_ao_fresnel, in),
                                  an::naughty_dog_with_ao_fresnel(v, n_dot_l, n_dot_v));
                        EXPECT_EQ(an::evaluate(an::AnalyticTerm::activision, in), an::activision(v, n_dot_l, w));
                        EXPECT_EQ(an::evaluate(an::AnalyticTerm::activision_adjusted, in),
                                  an::activision_with_cone_adjustment(v, r, n_dot_l, n_dot_v, w));
                        EXPECT_EQ(an::evaluate(an::AnalyticTerm::pz_analytic, in), an::pz_analytic(v, n_dot_l));
                    }
}

}  // namespace
