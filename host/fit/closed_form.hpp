// A closed-form approximation of the generic term: no texture, a few ALU per light.
//
// Model. For a smooth surface the term is a step at the shadow edge NdotL = c, with c = cos of the
// visibility cone's half-angle (cosine AO: c = sqrt(1 - v); uniform AO: c = 1 - v): the light is
// either inside the cone or not. Roughness blurs the step over a width that grows with roughness, and
// the view tilts the visible normals towards V, which moves the edge with the relative azimuth. So
// the model is a smooth step of a low-order polynomial in edge-relative variables:
//
//   term ~ S(z),  S(z) = 1/2 + z / (2 sqrt(1 + z^2))      (an algebraic sigmoid: one rsqrt, no exp)
//   z = sum_k c_k m_k(u, t, n_dot_v, r, c)
//   u = (NdotL - c) / r^2    signed distance to the shadow edge in units of the GGX alpha = r^2
//                            (r = roughness; alpha is the slope spread that blurs the step: on the
//                            reference sets it fits better than NdotL - c over r, docs/study.md)
//   t = VdotL - NdotV NdotL  = sin(theta_v) sin(theta_l) cos(relative azimuth): where L lies
//                            around V's side (the only azimuth-dependent quantity, 1 FMA in a shader)
//
// m_k are the monomials of the order's variables up to its degree:
//   order 1: 1, u                                   (2 coefficients: the blurred step alone)
//   order 2: 1, u, t, n_dot_v, r, c                 (6: degree 1 in all five variables)
//   order 3: every monomial of degree <= 2           (21)
//   order 4: every monomial of degree <= 3           (56)
// The coefficients are fitted by Gauss-Newton (fit/least_squares.hpp) to a reference set, weighted by
// NdotL (jobs/design_closed_form.hpp). A renderer evaluates exactly what generate_closed_form_shader
// writes; operator() is the same arithmetic in double.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "core/types.hpp"

namespace ms::fit {

inline constexpr unsigned kMaxClosedFormOrder = 4;

// The five model variables at a point (see above).
struct ClosedFormVariables {
    double u = 0, t = 0, n_dot_v = 1, roughness = 0.5, c = 0;
};
// relative_azimuth in radians; the directions' sines from NdotV and NdotL.
ClosedFormVariables closed_form_variables(double visibility, double n_dot_l, double n_dot_v, double roughness,
                                          double relative_azimuth, AoWeighting weighting);

// The monomials of an order: each a list of variable indices (0 u, 1 t, 2 n_dot_v, 3 roughness, 4 c),
// sorted, [] being the constant. Throws std::invalid_argument for an order outside 1..kMaxClosedFormOrder.
std::vector<std::vector<int>> closed_form_monomials(unsigned order);
// The monomials' values at a point, in closed_form_monomials order.
std::vector<double> closed_form_basis(unsigned order, const ClosedFormVariables& x);

// The provable zero region, where the term is exactly 0 and the closed form returns 0 without its
// polynomial: NdotL <= 0, or NdotL <= cos(2 theta_c) = 2 c^2 - 1, the light beyond twice the cone's
// half-angle (cosine AO: 1 - 2 v; uniform AO: 2 (1 - v)^2 - 1), as the representations' lookups test it.
bool closed_form_zero_region(double visibility, double n_dot_l, AoWeighting weighting);

// The sigmoid and its derivative.
double closed_form_link(double z);
double closed_form_link_derivative(double z);

struct ClosedForm {
    unsigned order = 1;
    AoWeighting weighting = AoWeighting::cosine;
    std::vector<double> coefficients;  // one per monomial
    nlohmann::json provenance = nlohmann::json::object();  // reference set, fit errors, command line

    // 0 in the zero region (closed_form_zero_region), else S(z).
    double operator()(double visibility, double n_dot_l, double n_dot_v, double roughness, double relative_azimuth) const;
    // S(z) from the model variables (no zero-region test: the caller's).
    double at(const ClosedFormVariables& x) const;
};

enum class ClosedFormLanguage { glsl, hlsl };

// ms_micro_shadowing_fit(visibility, n_dot_l, n_dot_v, roughness, v_dot_l): the function a renderer
// pastes in (v_dot_l = dot(V, L), which shading code has at hand; roughness > 0). It returns 0 in the
// zero region before the polynomial, as operator() does.
std::string generate_closed_form_shader(const ClosedForm& form, ClosedFormLanguage language, const std::string& source_name);

// The JSON file: format, model description, order, AO weighting, monomials, coefficients, provenance.
nlohmann::json to_json(const ClosedForm& form);
// Throws std::invalid_argument naming the file and the field (unknown format, wrong count, non-finite).
ClosedForm closed_form_from_json(const nlohmann::json& j, const std::string& source);
ClosedForm read_closed_form(const std::string& path);

}  // namespace ms::fit
