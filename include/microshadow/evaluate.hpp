// Evaluating the term on queries (included by <microshadow/microshadow.hpp>).
#pragma once

#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// The term at each query, in order (the default method: exact, as `microshadow eval`). `progress` is
// told (queries done, queries) and may stop the call.
std::vector<Estimate> evaluate(const std::vector<Query>& queries, const SamplingOptions& options = {},
                               const Progress& progress = {});

// The query of an isotropic surface in the parameters of the LUTs and sweeps, in the order every
// isotropic call takes them (Lut::lookup, LookupFile::lookup, AnalyticInputs): alpha_x = alpha_y =
// roughness.alpha(), the view wi = (sqrt(1 - n_dot_v^2), 0, n_dot_v) and the light at the relative
// azimuth (degrees; 0: on the view's side) wo = (s cos phi, s sin phi, n_dot_l), s = sqrt(1 - n_dot_l^2)
// (the directions of a sweep point with phi_i = 0 and delta_phi = relative_azimuth_deg).
Query isotropic_query(double visibility, double n_dot_l, double n_dot_v, Roughness roughness,
                      double relative_azimuth_deg = 0);

}  // namespace microshadow
