#include "approx/approximation.hpp"

#include <cmath>

namespace ms::approx {

double isotropic_roughness(double alpha_x, double alpha_y) { return std::sqrt(std::sqrt(alpha_x * alpha_y)); }

Inputs inputs_of(const Query& q, AoWeighting weighting) {
    const Query n = normalised(q);
    Inputs in;
    in.visibility = q.visibility;
    in.n_dot_l = n.wo.z;
    in.n_dot_v = n.wi.z;
    in.roughness = isotropic_roughness(q.alpha_x, q.alpha_y);
    in.weighting = weighting;
    // atan2 of the cross and dot products of the projections: robust for any lengths, in [0, pi].
    const double dot = n.wi.x * n.wo.x + n.wi.y * n.wo.y;
    const double cross = n.wi.x * n.wo.y - n.wi.y * n.wo.x;
    in.relative_azimuth = (dot == 0 && cross == 0) ? 0.0 : std::atan2(std::fabs(cross), dot);
    in.alpha_x = q.alpha_x;
    in.alpha_y = q.alpha_y;
    // A direction along the normal has no azimuth: the term does not depend on it, so 0 stands for it.
    in.view_azimuth = (n.wi.x == 0 && n.wi.y == 0) ? 0.0 : std::atan2(n.wi.y, n.wi.x);
    in.light_azimuth = (n.wo.x == 0 && n.wo.y == 0) ? 0.0 : std::atan2(n.wo.y, n.wo.x);
    return in;
}

}  // namespace ms::approx
