// Host-side cone bookkeeping: the visibility -> cone mapping the host hands to the kernels, and the
// provable zero region used to skip work. The oracle derives its cone on its own (host/oracle/).
#pragma once

#include "core/types.hpp"

namespace ms {

// Cosine of the visibility cone half-angle (part 1): sqrt(1 - v) for cosine-weighted AO bakes
// (the cone subtends projected solid angle v), 1 - v for uniform-weighted ones (solid angle v).
double cone_cos_theta(double visibility, AoWeighting weighting);

// Squared sine of the same half-angle, v (cosine) or v (2 - v) (uniform), without the cancellation of
// 1 - cos^2: the kernels need it for cones so narrow that cos_theta rounds to 1 in float.
double cone_sin2_theta(double visibility, AoWeighting weighting);

// The generic term is exactly 0 when no microfacet can satisfy both cone conditions:
// angle(wg, wm) < theta and angle(wm, wo) < theta imply angle(wg, wo) < 2 theta, so
// NdotL <= cos(2 theta) = 2 cos^2(theta) - 1 forces 0. For cosine weighting this is part 2's
// early-out 2 v + NdotL <= 1. A light at or below the horizon is fully shadowed (Smith G1(wo) = 0).
bool in_zero_region(double cos_theta, double n_dot_l);

}  // namespace ms
