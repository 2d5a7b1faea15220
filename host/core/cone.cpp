#include "core/cone.hpp"

#include <algorithm>
#include <cmath>

namespace ms {

double cone_cos_theta(double visibility, AoWeighting weighting) {
    const double v = std::clamp(visibility, 0.0, 1.0);
    return weighting == AoWeighting::cosine ? std::sqrt(1.0 - v) : 1.0 - v;
}

double cone_sin2_theta(double visibility, AoWeighting weighting) {
    const double v = std::clamp(visibility, 0.0, 1.0);
    return weighting == AoWeighting::cosine ? v : v * (2.0 - v);
}

bool in_zero_region(double cos_theta, double n_dot_l) {
    return n_dot_l <= 0.0 || n_dot_l <= 2.0 * cos_theta * cos_theta - 1.0;
}

}  // namespace ms
