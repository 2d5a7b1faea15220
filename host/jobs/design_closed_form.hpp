// The closed-form approximation (fit/closed_form.hpp) as a design candidate: its fit to a cached
// reference set and its cost, bake and shader.
#pragma once

#include <string>

#include "fit/closed_form.hpp"
#include "jobs/design.hpp"
#include "jobs/reference_set.hpp"

namespace ms::design {

// Fits the order's coefficients to the set, minimising sum_i w_i (S(z_i) - term_i)^2 with
// w_i = weight_i x max(NdotL_i, 0): a linear least-squares start on S^-1 of the term (clamped to
// [0.005, 0.995], where S^-1 is finite) refined by at most 50 Gauss-Newton steps. The provenance
// records the set (name, hash, points), the fit's weighted RMS and max error on it, and the steps.
fit::ClosedForm fit_closed_form(const ReferenceSet& training, unsigned order);

// The candidate "closed-form-K": 0 bytes, 0 fetches, ALU counted from its GLSL; bake() writes the
// coefficients JSON and the GLSL and HLSL. `file` (when read from one) goes into the provenance.
Candidate closed_form_candidate(const fit::ClosedForm& form, const std::string& file);

}  // namespace ms::design
