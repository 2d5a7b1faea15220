// Part 1's analytic micro-shadowing terms by name (included by <microshadow/microshadow.hpp>), as
// `eval --compare NAME` and the sweeps evaluate them.
#pragma once

#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// What a term reads. roughness is the perceptual roughness (alpha = roughness^2); only
// "activision-adjusted" reads it (converted to Activision's own roughness of the same alpha), and
// n_dot_v only "naughty-dog-ao-fresnel" and "activision-adjusted".
struct AnalyticInputs {
    double visibility = 1;
    double n_dot_l = 1;
    double n_dot_v = 1;
    double roughness = 0.5;
};

// "reference-step", "naughty-dog", "naughty-dog-ao-fresnel", "activision", "activision-adjusted",
// "pz-analytic".
std::vector<std::string> analytic_term_names();

// The term `name` at each input. std::invalid_argument for an unknown name (listing the valid ones);
// std::domain_error naming the input index where a term cannot take it.
std::vector<double> analytic_term(const std::string& name, const std::vector<AnalyticInputs>& inputs,
                                  AoWeighting ao_weighting = AoWeighting::cosine);

}  // namespace microshadow
