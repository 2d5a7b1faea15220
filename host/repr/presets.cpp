#include "repr/presets.hpp"

#include <cmath>
#include <stdexcept>

namespace ms::repr {

namespace {

// n nodes spaced evenly from lo to hi.
std::vector<double> even(double lo, double hi, int n) {
    std::vector<double> out;
    for (int i = 0; i < n; ++i) out.push_back(lo + (hi - lo) * i / (n - 1));
    return out;
}

// n nodes from lo to hi in geometric progression (equal ratios; the shader finds the slab by a logarithm).
std::vector<double> geometric(double lo, double hi, int n) {
    std::vector<double> out;
    for (int i = 0; i < n; ++i) out.push_back(lo * std::pow(hi / lo, double(i) / (n - 1)));
    out.back() = hi;
    return out;
}

}  // namespace

std::vector<std::string> preset_names() { return {"realistic", "full-range", "anisotropic"}; }

bool is_preset(const std::string& name) {
    for (const auto& n : preset_names())
        if (n == name) return true;
    return false;
}

Preset preset(const std::string& name, AoWeighting weighting) {
    Preset p;
    p.name = name;
    p.grid.weighting = weighting;
    if (name == "realistic") {
        // The best measured inside roughness 0.3-0.9 (docs/representations.md): harmonics, 32 visibility
        // texels dense near v = 1 x 16 NdotL x 8 NdotV x 8 roughness slabs over 0.3..0.9; 256 KiB, 2 fetches.
        p.summary = "roughness 0.3-0.9, visibility 0.5-1, NdotV 0.2-1: azimuth harmonics 32 v (sqrt-top) x 16 NdotL x 8 NdotV x 8 "
                    "roughness, 256 KiB, 2 fetches";
        p.kind = "azimuth-harmonics";
        p.grid.visibility = 32, p.grid.n_dot_l = 16, p.grid.n_dot_v = 8;
        p.grid.roughness = even(0.3, 0.9, 8);
        p.grid.warps.visibility = VisibilityWarp::sqrt_top;
        p.domain.roughness_min = 0.3, p.domain.roughness_max = 0.9;
        p.domain.visibility_min = 0.5, p.domain.visibility_max = 1;
        p.domain.n_dot_v_min = 0.2, p.domain.n_dot_v_max = 1;
        return p;
    }
    if (name == "full-range") {
        // The whole isotropic domain at 512 KiB and 2 fetches: the NdotL axis of each roughness slab
        // follows the shadow edge in units of its alpha (edge-roughness), so low roughness, a near-step,
        // gets the texels a linear axis spends where the term is flat (docs/representations.md).
        p.summary = "roughness 0.05-1, visibility 0.02-1, NdotV 0.02-1: azimuth harmonics (far-side warp) 32 v (edge-roughness, to 1) x "
                    "16 NdotL (edge-roughness, width 1 alpha) x 8 NdotV (sqrt) x 16 roughness (geometric), 512 KiB, 2 fetches";
        p.kind = "azimuth-harmonics";
        p.grid.visibility = 32, p.grid.n_dot_l = 16, p.grid.n_dot_v = 8;
        // Geometric nodes: alpha = r^2 changes by the same factor (1.49) from slab to slab, so adjacent
        // slabs' edge widths stay close down to roughness 0.05.
        p.grid.roughness = geometric(0.05, 1.0, 16);
        p.grid.warps.visibility = VisibilityWarp::sqrt_top;
        p.grid.warps.n_dot_l = NdotLWarp::edge_roughness;
        // Measured on random full-range queries (docs/representations.md): width 1 alpha beat 0.5, 2
        // and 4, and sqrt(NdotV) halves the grazing views' error for a little more at high roughness.
        p.grid.edge_width = 1.0;
        p.grid.warps.n_dot_v = NdotVWarp::sqrt;
        // NdotL and NdotV texels from end to end of the domain: at cell centres the last NdotL texel of
        // a slab sits as low as NdotL 0.8 and everything above repeats it (the largest errors found by
        // search were there and at NdotV = 1, 0.12-0.13); the NdotV axis starts at the domain's 0.02.
        p.grid.placement = TexelPlacement::ends;
        p.grid.n_dot_v_start = 0.02;
        // The far-side azimuth warp, kappa = 2: with the light near the horizon opposite a grazing view
        // the term falls to 0 within a few degrees of phi = 180, which the series in cos phi missed by up
        // to 0.46 (at the exact term's own nodes); in the warped coordinate by 0.03.
        p.grid.azimuth_warp = 2;
        // The first visibility texel at the domain's 0.02 (its first cell centre was 0.031: the search
        // found 0.13 at v = 0.02, clamped to it).
        p.grid.visibility_start = 0.02;
        // Up to v = 1 (docs/representations.md, "The top of the visibility axis"): each slab's visibility
        // axis is uniform in 1 - sqrt(1 - c) (the cone's angle near v = 0) plus 0.4 / 1.4 of its texels
        // logarithmic in c down to s = 0.125 min(alpha, NdotV / 2), where the term rises to 1 as the cone's
        // edge reaches the horizon, its last texel at v = 1; and the NdotL width is at most NdotV + c, the
        // scale of the shadow a grazing view meets there. Searched max above v = 0.998: 0.99 -> 0.07. The
        // scale was 0.5 min(alpha, NdotV / 4): the search then found 0.116 at v 0.99993 with the light
        // at the horizon, a grazing view and roughness 0.09, where the term changes over a few millionths of
        // c; reaching 4x closer to v = 1 (and the view's bound 2x) gives 0.0925, the random-query RMS
        // unchanged (docs/representations.md).
        p.grid.warps.visibility = VisibilityWarp::edge_roughness;
        p.grid.visibility_edge_share = 0.4, p.grid.visibility_edge_width = 0.125, p.grid.visibility_edge_view = 0.5;
        p.grid.n_dot_l_edge_view = 1;
        p.domain.roughness_min = 0.05, p.domain.roughness_max = 1;
        p.domain.visibility_min = 0.02, p.domain.visibility_max = 1;
        p.domain.n_dot_v_min = 0.02, p.domain.n_dot_v_max = 1;
        return p;
    }
    if (name == "anisotropic") {
        // Anisotropic GGX up to alpha ratio 25 (docs/representations.md, "Anisotropic surfaces"): the
        // full-range texture, looked up at the surface's isotropic equivalent (host/repr/harmonics.cpp),
        // which is exact on isotropic surfaces, plus the anisotropy correction per texel in a second
        // block of the same size: 1 MiB and 4 fetches, the budget allowed.
        p = preset("full-range", weighting);
        p.name = name;
        p.summary = "anisotropic, roughness 0.05-1 per axis, ratio <= 25, visibility 0.02-1, NdotV 0.02-1: the full-range azimuth "
                    "harmonics (32 v x 16 NdotL x 8 NdotV x 16 roughness) at the surface's isotropic equivalent plus an "
                    "anisotropy correction per texel, 1 MiB, 4 fetches";
        p.kind = "anisotropic-corrected-harmonics";
        p.domain.max_alpha_ratio = p.max_ratio;
        // The visibility axis's top as the correction was fitted and measured with (the full-range
        // preset's finer top was measured on isotropic surfaces only).
        p.grid.visibility_edge_width = 0.5, p.grid.visibility_edge_view = 0.25;
        // The correction's fit, measured on random anisotropic queries other than the figures' (RMS by
        // fitting queries / iterations): 500,000 / 40: 0.0259; 1,000,000 / 20, 40, 80: 0.0229, 0.0234,
        // 0.0246; 2,000,000 / 20, 40, 60: 0.0219, 0.0216, 0.0220; 3,000,000 / 40: 0.0206. More data
        // helps, more iterations beyond ~40 fit noise; 2,000,000 / 40 keeps the bake under a minute.
        p.correction_queries = 2000000;
        p.correction_iterations = 40;
        p.correction_seed = 7;
        return p;
    }
    std::string list;
    for (const auto& n : preset_names()) list += (list.empty() ? "" : ", ") + n;
    throw std::invalid_argument("no representation preset '" + name + "' (presets: " + list + ")");
}

}  // namespace ms::repr
