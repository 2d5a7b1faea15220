// LUT lookups as a renderer does them, used as sweep comparators: a baked LUT (lut/exr_lut.hpp) read
// once, then sampled with linear filtering and clamp-to-edge addressing.
//
// Per axis (visibility, NdotL, NdotV) the parameter p maps to a continuous texel coordinate
//   centres:   t = (p - min) / (max - min) * n - 0.5      (GPU texture convention)
//   endpoints: t = (p - min) / (max - min) * (n - 1)
// clamped to [0, n - 1]; the value is the linear blend of texels floor(t) and floor(t) + 1 with
// weight frac(t). Over (visibility, NdotL) this is bilinear; with several NdotV slices it is
// trilinear (a 3D texture); a 2D LUT (one NdotV slice) ignores NdotV: it stands for NdotV = 1 only.
//
// Roughness: channels hold roughness values r_0 < r_1 < ... (R, G, B, A). The lookup clamps r to
// [r_0, r_last] and blends linearly between the two channels that bracket it, i.e. the way a shader
// lerps the RGBA sample by roughness. The LUT knows no azimuth: its "azimuth" policy (mean or fixed)
// is part of what a study measures.
//
// Before any texel is read the lookup answers exactly 0 where the term is 0 for every roughness and
// view (lookup_zero_region below: the light at or below the horizon, or inside the zero region of the
// LUT's AO weighting, its metadata's "ao_weighting", cosine when absent), as the generated shader's
// early-out does (lut/shader/shader_gen.hpp): the texels' linear blend across the region's edge
// would otherwise answer up to a few hundredths there. tests/gpu/shader_test.cpp runs the shaders
// against this lookup, zero region and its edge included.
#pragma once

#include <string>
#include <vector>

#include "core/lookup_domain.hpp"
#include "core/types.hpp"
#include "lut/exr_lut.hpp"

namespace ms {

// The early-out every lookup (LUT and representation, C++ and generated GLSL/HLSL) applies first: true
// where the term is exactly 0 whatever the roughness, view and azimuth: NdotL <= 0, or NdotL at or below
// the zero region's edge 2 cos_t^2 - 1 (cosine AO, cos_t^2 = 1 - v: 2 v + NdotL <= 1; uniform AO,
// cos_t = 1 - v: NdotL + 1 <= 2 cos_t^2). Decided as the shaders decide it, in binary32 arithmetic on
// the inputs rounded to binary32, in forms no compiler can fuse into a different rounding (2 v is exact,
// and the uniform test compares a sum with a product): so a point within a rounding of the edge gets
// the same answer from the C++ lookup and from every shader.
bool lookup_zero_region(AoWeighting weighting, double visibility, double n_dot_l);

class LutLookup {
public:
    explicit LutLookup(LutFile lut);
    // Reads the file (lut/exr_lut.hpp's read_lut) and checks it can be sampled. Throws std::runtime_error.
    static LutLookup open(const std::string& path);

    // Throws std::domain_error where the lookup touches a texel a partial bake left unbaked (NaN), or
    // lies outside a "refused" domain (a LUT fitted to one scene: bake --scene; core/lookup_domain.hpp).
    double operator()(double visibility, double n_dot_l, double n_dot_v, double roughness) const;
    const LutFile& file() const { return lut_; }
    // The metadata's "domain", or for a file without one its axes' and roughness channels' ranges
    // (visibility and NdotV axes as baked; a 2D LUT, made to stand in at every view, NdotV [0, 1]).
    const LookupDomain& domain() const { return domain_; }
    // The AO weighting whose zero region the lookup answers 0 in (the metadata's "ao_weighting").
    AoWeighting ao_weighting() const { return weighting_; }

private:
    double blend(double visibility, double n_dot_l, double n_dot_v, double roughness) const;
    LutFile lut_;
    std::vector<std::uint32_t> order_;  // channel indices by increasing roughness
    LookupDomain domain_;
    AoWeighting weighting_ = AoWeighting::cosine;
};

}  // namespace ms
