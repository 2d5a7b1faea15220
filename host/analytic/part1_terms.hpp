// Part 1's analytic micro-shadowing terms ("Improving Direct Lighting Material Occlusion - Part 1"),
// written in plain double precision as comparators for the studies. Each function transcribes the
// HLSL shown in part 1, including its special cases; where part 1's prose or formula and its code
// differ, the code is followed and the difference is noted on the function.
//
// Conventions shared by every function here:
// - visibility is the baked AO value in [0, 1]. Inputs are NOT clamped (the paper's code does not
//   clamp either); visibility > 1 makes the cosine cone NaN, as sqrt of a negative would in HLSL.
// - saturate(x) = clamp(x, 0, 1) with saturate(NaN) = 0, as in HLSL/D3D.
// - step(a, x) = x >= a ? 1 : 0 and lerp(x, y, s) = x + s (y - x), as in HLSL.
// - frac(x) = x - floor(x), as in HLSL.
//
// Note on name lookup: ms::cone_cos_theta (core/cone.hpp) has the same signature as
// ms::analytic::cone_cos_theta, and AoWeighting lives in namespace ms, so an unqualified call with an
// AoWeighting argument from inside ms::analytic would be ambiguous through ADL. Call it qualified.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/types.hpp"

namespace ms::analytic {

// Cosine of the visibility cone half-angle, part 1 "Reference Implementation" (Jimenez et al. 2016,
// eq. 18): cos_theta = sqrt(1 - v) for a cosine-weighted AO bake, cos_theta = 1 - v for a
// uniform-weighted bake (Substance, Marmoset option). Unlike ms::cone_cos_theta, v is not clamped.
double cone_cos_theta(double visibility, AoWeighting weighting);

// MicroShadowingTermReference: step(cos_theta, NdotL), i.e. 1 when NdotL >= cos_theta, else 0.
// Part 1's formula says "1 if cos_theta < N.L" (strict); the code's step() is inclusive, so on the
// boundary this returns 1. Notably v = 0, NdotL = 1 gives 1 (cos_theta = 1), and v = 1, NdotL = 0
// gives 1 (cos_theta = 0); the strict formula gives 0 in both cases.
double reference_step(double visibility, double n_dot_l, AoWeighting weighting);

// MicroShadowingTermNaughtyDog (Brinck et al. 2016): saturate(NdotL + 2 v^2 - 1).
// Properties (part 1): v = 0 is fully shadowed for NdotL <= 1; for v < sqrt(1/2) the term is < 1
// even at NdotL = 1; for v > sqrt(1/2) it is > 0 for every NdotL in [0, 1] (it can still reach 0 for
// NdotL <= 1 - 2 v^2 < 0, below the horizon). Independent of the AO weighting.
double naughty_dog(double visibility, double n_dot_l);

// VisibilityFadeNaughtyDog, the "AO Fresnel" fade: lerp(1, v, saturate(NdotV)) = 1 + s (v - 1).
// Part 1's formula writes N.V; its code uses dot(vertexN, V), the geometric (vertex) normal rather
// than the normal-mapped one, so pass that cosine here. Naughty Dog apply it only on surfaces with
// baked lighting.
double naughty_dog_ao_fresnel_visibility(double visibility, double n_dot_v);

// Naughty Dog's term on the faded visibility:
// naughty_dog(naughty_dog_ao_fresnel_visibility(v, NdotV), NdotL).
double naughty_dog_with_ao_fresnel(double visibility, double n_dot_l, double n_dot_v);

// MicroShadowingTermActivision (Chan 2018): saturate(NdotL / cos_theta)^2, and 1 when v == 1 exactly
// (the code's guard against division by 0; it returns 1 for every NdotL, also NdotL < 0, while the
// formula is undefined there). The term is 1 exactly where the reference is (NdotL >= cos_theta) and
// at v = 0 (cos_theta = 1) it is saturate(NdotL)^2 > 0 for NdotL > 0: "a light will still be visible
// even when Visibility = 0". The paper's code uses the cosine cone; `weighting` selects the cone.
double activision(double visibility, double n_dot_l, AoWeighting weighting);

// AdjustCosConeAngle, exactly as part 1's listing of the paper's code:
//   g = saturate(1.5 gloss) (the paper: "Optionally, omit this line" -> scale_gloss = false),
//   t = (1 - g^8) (1 - (1 - NdotV)^4),  result = lerp(0, cos_cone, t) = t cos_cone.
// g = 1 (gloss >= 2/3, i.e. roughness <= 1/3) or NdotV = 0 give t = 0: a cone of 90 degrees.
double activision_adjust_cos_cone(double cos_cone, double gloss, double n_dot_v, bool scale_gloss = true);

// GetVisibilityFromMaterialOcclusion with part 1's "gloss = 1 - roughness" line:
//   c = max(AdjustCosConeAngle(cos_theta(v), 1 - roughness, NdotV), 0.001); saturate(NdotL / c)^2.
// The paper's code uses the cosine cone sqrt(1 - v); `weighting` selects the cone (cosine reproduces
// the paper). Part 1's formula omits the max(.., 0.001). Because of it, "no micro-shadowing for
// roughness <= 0.33" holds precisely as: for roughness <= 1/3 the result is 1 for NdotL >= 0.001 and
// (1000 NdotL)^2 for NdotL in [0, 0.001), whatever v and NdotV. `roughness` is Activision's
// non-standard one (see activision_alpha_from_roughness).
double activision_with_cone_adjustment(double visibility, double roughness, double n_dot_l, double n_dot_v,
                                       AoWeighting weighting);

// The GGX alpha of Activision's non-standard roughness (part 1):
//   alpha = sqrt(2 / (1 + 2^(18 (1 - roughness)))).
// roughness 1 -> alpha 1, roughness 0.5 -> sqrt(2/513) ~ 0.0624, roughness 0 -> sqrt(2/262145)
// ~ 0.00276. It is strictly increasing and tends to sqrt(2) as roughness -> -infinity. Use it with
// activision_roughness_from_alpha to put Activision's adjusted term and the other terms at the same
// GGX alpha in a study: alpha here is the ordinary GGX width, not perceptual roughness squared.
double activision_alpha_from_roughness(double roughness);

// Inverse of activision_alpha_from_roughness: roughness = 1 - log2(2 / alpha^2 - 1) / 18, defined for
// alpha in (0, sqrt(2)); alpha in [sqrt(2/262145), 1] maps to roughness in [0, 1]. Outside
// (0, sqrt(2)) it throws std::domain_error.
double activision_roughness_from_alpha(double alpha);

// MicroShadowingTermPZAnalytical (part 1's "Analytical Alternative"):
//   cos_theta' = sqrt(1 - v^5),  saturate(NdotL / cos_theta')^(0.75 / v),
// and v itself when frac(v) == 0 (v = 0 -> 0, v = 1 -> 1, the code's guard against divisions by 0;
// the formula has no such case). The v = 0 value comes only from that guard: for NdotL = 1 the
// formula's limit as v -> 0+ is 1, so the term jumps from 0 to 1 there. Uses no AO weighting.
double pz_analytic(double visibility, double n_dot_l);

// F_Schlick (part 1, micro-occlusion): F0 + (F90 - F0) (1 - VdotH)^5. Scalar version of the float3
// listing.
double f_schlick(double f0, double f90, double v_dot_h);

// F_SchlickF0WithMicroOcclusion: F_Schlick(F0, saturate(50 F0), VdotH). Equals F90 = 1 for
// F0 >= 0.02 (no real material reflects less than 2%) and fades the specular out to 0 at F0 = 0.
double f_schlick_f0_micro_occlusion(double f0, double v_dot_h);

// Registry so a parameter sweep can pick part 1's comparators by name.
enum class AnalyticTerm {
    reference_step,          // "reference-step"          reference_step(v, NdotL, w)
    naughty_dog,             // "naughty-dog"             naughty_dog(v, NdotL)
    naughty_dog_ao_fresnel,  // "naughty-dog-ao-fresnel"  naughty_dog_with_ao_fresnel(v, NdotL, NdotV)
    activision,              // "activision"              activision(v, NdotL, w)
    activision_adjusted,     // "activision-adjusted"     activision_with_cone_adjustment(v, r, NdotL, NdotV, w)
    pz_analytic,             // "pz-analytic"             pz_analytic(v, NdotL)
};

// Every term, in declaration order.
inline constexpr std::array<AnalyticTerm, 6> kAllAnalyticTerms = {
    AnalyticTerm::reference_step, AnalyticTerm::naughty_dog, AnalyticTerm::naughty_dog_ao_fresnel,
    AnalyticTerm::activision,     AnalyticTerm::activision_adjusted, AnalyticTerm::pz_analytic,
};

std::string to_string(AnalyticTerm);
// Every term's name, in declaration order (what a scene compares against by default, what help lists).
std::vector<std::string> analytic_term_names();
// Parse the names above; throws std::invalid_argument listing the valid names.
AnalyticTerm parse_analytic_term(const std::string&);

// Everything any term may read. Terms ignore the fields they do not use (see the enum). roughness is
// Activision's non-standard roughness; n_dot_v is the vertex-normal cosine for the AO Fresnel fade and
// the shading-normal cosine for Activision's adjustment.
struct AnalyticInputs {
    double visibility = 1;
    double n_dot_l = 1;
    double n_dot_v = 1;
    double roughness = 0.5;
    AoWeighting ao_weighting = AoWeighting::cosine;
};

double evaluate(AnalyticTerm, const AnalyticInputs&);

}  // namespace ms::analytic
