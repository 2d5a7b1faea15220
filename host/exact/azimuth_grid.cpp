#include "exact/azimuth_grid.hpp"

#include <algorithm>
#include <cmath>

#include "core/cone.hpp"

namespace ms::exact {

AzimuthGrid::AzimuthGrid(double visibility, double alpha, double n_dot_l, AoWeighting weighting)
    : visibility_(visibility), alpha_(alpha), n_dot_l_(n_dot_l), weighting_(weighting) {
    c_ = cone_cos_theta(visibility, weighting);
    s_ = std::sqrt(cone_sin2_theta(visibility, weighting));
    const double sl = std::sqrt(std::max(0.0, 1 - n_dot_l * n_dot_l));
    wo_ = {sl, 0, n_dot_l};
    // The same early answers as exact_azimuth_mean (light at or below the horizon, no cone, the whole
    // hemisphere, no normal satisfying both cone conditions).
    if (!(n_dot_l > 0) || visibility <= 0) constant_ = 0;
    else if (visibility >= 1) constant_ = 1;
    else if (in_zero_region(c_, n_dot_l)) constant_ = 0;
    else {
        const Cap round_z{{0, 0, 1}, c_, s_}, round_wo{wo_, c_, s_};
        wo_circle_ = prepare_circle(alpha, alpha, round_wo);
        // The two cone circles meet each other's caps the same way for the whole row.
        fixed_pairs_[0] = circle_in_cap(round_z, round_wo);
        fixed_pairs_[1] = circle_in_cap(round_wo, round_z);
    }
}

ExactValue AzimuthGrid::term(double n_dot_v, double phi, double tolerance) const {
    ExactValue out;
    if (constant_ >= 0) {
        out.term = constant_;
        return out;
    }
    // The view rotated by -phi about e_z (the light stays at azimuth 0).
    const double sv = std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v));
    const Vec3 wi{sv * std::cos(phi), -sv * std::sin(phi), n_dot_v};
    const Microsurface surface = make_microsurface(alpha_, alpha_, wi);
    const ArcRule rule = arc_rule_for(tolerance);
    const Vec3 ez{0, 0, 1};
    const BoundaryIntegral hemisphere = hemisphere_integral(surface, ez, wo_, wi);
    if (!(hemisphere.value > 0)) return out;
    Cap cone_caps[3] = {{ez, c_, s_}, {wo_, c_, s_}, {wi, 0, 1}};
    const BoundaryIntegral cone =
        boundary_integral(surface, cone_caps, 3, rule, tolerance * hemisphere.value, &wo_circle_, fixed_pairs_, 2);
    const double t = cone.value / hemisphere.value;
    out.term = std::clamp(t, 0.0, 1.0);
    out.error = (cone.error + std::fabs(t) * hemisphere.error) / hemisphere.value;
    out.quadrature_pieces = cone.quadrature_pieces + hemisphere.quadrature_pieces;
    return out;
}

ExactValue AzimuthGrid::mean(double n_dot_v, double tolerance) const {
    if (constant_ >= 0) {
        ExactValue out;
        out.term = constant_;
        return out;
    }
    // Each value's own tolerance is a quarter of the mean's, as in exact_azimuth_mean.
    const double value_tolerance = 0.25 * tolerance;
    return azimuth_mean_of([&](double phi) { return term(n_dot_v, phi, value_tolerance); }, c_, s_, n_dot_v, n_dot_l_,
                           tolerance);
}

}  // namespace ms::exact
