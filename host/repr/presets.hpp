// Named representations a renderer can ship without choosing a layout: each preset is a kind, a grid,
// azimuth nodes and the domain its measured errors hold for (docs/representations.md, "Presets", gives
// their memory, fetches, ALU, errors on random queries of that domain and the max an adversarial search
// finds there; tests/repr hold each preset to that stated max).
//   realistic:  roughness 0.3-0.9, visibility 0.5-1, NdotV 0.2-1 (content whose roughness stays there)
//   full-range: roughness 0.05-1, visibility 0.02-1, NdotV 0.02-1 (the whole isotropic domain)
//   anisotropic: alpha_x, alpha_y 0.0025-1 (roughness 0.05-1 per axis) with ratio <= 25, any
//               tangent-relative azimuths, visibility 0.02-1, NdotV 0.02-1 (anisotropic GGX)
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/lookup_domain.hpp"
#include "repr/representation.hpp"

namespace ms::repr {

struct Preset {
    std::string name;
    std::string summary;  // one line for help and metadata
    std::string kind;     // "azimuth-harmonics", "azimuth-axis", "anisotropic-mapped-harmonics" or "anisotropic-corrected-harmonics"
    ReprGrid grid;
    std::uint32_t azimuth_nodes = 9;
    // The largest alpha ratio of the anisotropic preset's domain (alpha_ratio) and correction queries.
    double max_ratio = 25;
    // anisotropic-corrected-harmonics: the random anisotropic queries of the domain its correction is
    // fitted to, their seed, and the fit's conjugate-gradient iterations (jobs/repr_bake.cpp).
    std::uint64_t correction_queries = 0, correction_seed = 1;
    std::uint32_t correction_iterations = 0;
    LookupDomain domain;
};

std::vector<std::string> preset_names();
// True for a preset's name.
bool is_preset(const std::string& name);
// The preset of that name for an AO weighting (the grid's); std::invalid_argument naming the valid ones.
Preset preset(const std::string& name, AoWeighting weighting = AoWeighting::cosine);

}  // namespace ms::repr
