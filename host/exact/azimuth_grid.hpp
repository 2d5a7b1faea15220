// The isotropic term on a LUT row's grid: every NdotV and every relative azimuth of one (visibility,
// alpha, NdotL), from one precomputation.
//
// An isotropic surface is invariant under rotation about e_z, so T(NdotV, NdotL, phi) equals the term
// with the light fixed at wo = (sin_l, 0, NdotL) and the view rotated by -phi, wi = (sin_v cos phi,
// -sin_v sin phi, NdotV). Then the cone's caps {m.z > c} and {m.wo > c} are the same for the whole row:
// only the support's great circle {m.wi > 0} moves. The circle round wo is the only one whose arcs need
// the quartic of |v|^2 (the circle round e_z has constant |v|^2 and the great circles close in
// angles), and the quartic does not depend on wi: the integrand's numerator a.(v x dv) is linear in
// a = normalize(S wi), so the quartic's roots and the reciprocal derivatives at them (the partial
// fractions' residues up to that linear numerator) are computed once per row and serve every wi.
// The two cone circles also meet each other's caps the same way for the whole row, so only the great
// circle's meetings are found per value. What remains per value is finding those arcs and a few complex
// logarithms at their ends.
//
// The values are the C++ evaluator's (exact_term.hpp) to within both estimates: the same boundary
// integrals, the same arc rule and fallback (pole-aware Gauss-Legendre where the closed form's bound
// does not meet an arc's share of the tolerance) and the same azimuth quadrature; only the frame (the
// rotation) and the reuse differ.
#pragma once

#include "core/types.hpp"
#include "exact/cap_region.hpp"
#include "exact/exact_term.hpp"

namespace ms::exact {

class AzimuthGrid {
public:
    // visibility in [0, 1], alpha in (0, 1], NdotL in (0, 1] (values outside give the term's limits, as
    // exact_azimuth_mean does).
    AzimuthGrid(double visibility, double alpha, double n_dot_l, AoWeighting weighting);

    bool same_row(double visibility, double alpha, double n_dot_l, AoWeighting weighting) const {
        return visibility == visibility_ && alpha == alpha_ && n_dot_l == n_dot_l_ && weighting == weighting_;
    }

    // exact_term_at_azimuth of this row at (NdotV, phi radians).
    ExactValue term(double n_dot_v, double phi, double tolerance = kDefaultTolerance) const;
    // exact_azimuth_mean of this row at NdotV.
    ExactValue mean(double n_dot_v, double tolerance = kDefaultTolerance) const;

private:
    double visibility_, alpha_, n_dot_l_;
    AoWeighting weighting_;
    double c_ = 0, s_ = 1;
    Vec3 wo_;
    // What the row's every value is when the cone is empty or the whole hemisphere (-1: neither).
    double constant_ = -1;
    PreparedCircle wo_circle_;
    CircleInCap fixed_pairs_[2];  // the circle round e_z in the cap round wo, and the other way round
};

}  // namespace ms::exact
