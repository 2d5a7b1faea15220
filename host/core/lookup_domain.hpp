// The domain of a comparator a renderer would ship (a baked LUT, a representation, a fitted closed
// form): the ranges of visibility, NdotL, NdotV and roughness it was made to answer. Outside them a
// texture lookup clamps to its edge texels and a fit extrapolates, so the answer there is not what the
// file's measured errors describe. Files record it in their metadata as
//   "domain": {"visibility": [lo, hi], "n_dot_l": [lo, hi], "n_dot_v": [lo, hi], "roughness": [lo, hi],
//              "outside": "counted" | "refused"}
// and, for a representation of anisotropic surfaces, "alpha_ratio": [1, max]: then the roughness range
// holds for each axis (sqrt(alpha_x) and sqrt(alpha_y)) and alpha_max / alpha_min must not exceed max.
// "counted" (every bake): a lookup outside is answered and counted by the commands that use the
// comparator (eval --compare, sweeps, scenes, design), which refuse them with --strict-domain.
// "refused" (a LUT fitted to one scene; also a domain without "outside", as such LUTs were written):
// the lookup itself refuses (std::domain_error).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace ms {

struct LookupDomain {
    double visibility_min = 0, visibility_max = 1;
    double n_dot_l_min = -1, n_dot_l_max = 1;
    double n_dot_v_min = 0, n_dot_v_max = 1;
    double roughness_min = 0, roughness_max = 1;
    bool refuse_outside = false;
    // The largest alpha_x / alpha_y (either way) of an anisotropic domain; 0: an isotropic domain, whose
    // roughness range applies to the isotropic-equivalent roughness of any query.
    double max_alpha_ratio = 0;

    // Closed ranges; a NaN input is outside. alpha_x, alpha_y (0: not given) are read by anisotropic
    // domains only (max_alpha_ratio > 0): each axis's sqrt(alpha) within the roughness range and their
    // ratio within max_alpha_ratio; without them the roughness stands for both axes.
    bool contains(double visibility, double n_dot_l, double n_dot_v, double roughness, double alpha_x = 0,
                  double alpha_y = 0) const;
    // "roughness [0.3, 0.9], visibility [0, 1], NdotV [0, 1]" (NdotL only when narrower than [-1, 1]).
    std::string describe() const;
    // The first input outside, in words ("roughness 0.12 outside [0.3, 0.9]"), or "" when inside.
    std::string first_outside(double visibility, double n_dot_l, double n_dot_v, double roughness, double alpha_x = 0,
                              double alpha_y = 0) const;
    nlohmann::json to_json(const std::string& what = "") const;
    // Reads the metadata's "domain" object; std::runtime_error naming `source` and the field.
    static LookupDomain from_json(const nlohmann::json& j, const std::string& source);
};

// How many lookups a comparator made and how many fell outside its domain (commands report both).
struct DomainTally {
    std::size_t lookups = 0, outside = 0;
    void add(bool inside) {
        ++lookups;
        if (!inside) ++outside;
    }
};

}  // namespace ms
