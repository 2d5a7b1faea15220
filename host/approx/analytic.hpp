// Part 1's terms (host/analytic/part1_terms.hpp) as approximations: no texture, no fetch, the ALU of the
// GLSL a shader writes for them.
#pragma once

#include <memory>
#include <string>

#include "analytic/part1_terms.hpp"
#include "approx/approximation.hpp"

namespace ms::approx {

// Part 1's term `t` at `in`. Activision's adjusted term reads its own non-standard roughness of the
// GGX alpha roughness^2 (analytic::activision_roughness_from_alpha; std::domain_error for alpha
// outside (0, sqrt 2)); the other terms ignore roughness.
double analytic_value(analytic::AnalyticTerm t, const Inputs& in);

// The term as a shader writes it (cosine AO): a GLSL function ms_part1(v, n_dot_l, n_dot_v, roughness).
std::string analytic_glsl(analytic::AnalyticTerm t);

std::shared_ptr<const Approximation> analytic_approximation(analytic::AnalyticTerm t);

// The term of that name, if any.
std::optional<analytic::AnalyticTerm> analytic_term_named(const std::string& name);
// The term names, comma-separated, and the closest one to `word` ("" when none is close).
std::string analytic_term_names();
std::string closest_analytic_term(const std::string& word);

}  // namespace ms::approx
