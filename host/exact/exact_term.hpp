// The generic VNDF-based micro-shadowing term without sampling: a deterministic evaluator that
// integrates the VNDF over the cone and hemisphere regions exactly along their boundaries (see
// cap_region.cpp), to a requested tolerance, with an estimated error.
//
// It is the third, independent way the project computes the term (beside the sampled kernels and the
// sampled scalar oracle) and shares no formula with them: it never samples, so its error is the
// quadrature's, estimated from a lower-order rule on every piece.
#pragma once

#include <functional>

#include "core/types.hpp"

namespace ms::exact {

// An exact-method value. `error` is the estimated absolute error of `term` (a conservative estimate:
// the difference to the lower-order rule, which is the lower rule's error, plus a rounding floor).
struct ExactValue {
    double term = 0;
    double error = 0;
    int quadrature_pieces = 0;  // Gauss pieces used (0 when every arc had a closed form)
};

// Default tolerance of a single value: 1e-10 (reached at a few microseconds per query).
inline constexpr double kDefaultTolerance = 1e-10;

// GenericM_g of one query: q.wi and q.wo need not be normalised (they are here); wi must be above the
// horizon and alpha > 0 (checked by the callers' query validation, as for the sampled method). The Smith
// form does not change the term (the weight G2/G1 is H(wo.wm) times a constant of the query, both
// forms), so only the AO weighting is needed.
ExactValue exact_term(const Query& q, AoWeighting weighting, double tolerance = kDefaultTolerance);

// The isotropic term as a LUT texel stores it by default: the mean over the relative azimuth phi in
// [0, pi] of the term at (visibility, alpha, NdotV, NdotL, phi), a mean of ratios. Integrated between the
// azimuths where the term is not analytic (the cone round wo touching the great circle normal to wi, the
// three circles meeting in a point, and the ends), each interval in a cosine substitution that makes a
// square-root onset at either end analytic, by Gauss-Kronrod pieces graded away from the same events'
// complex solutions and bisected until the Kronrod and Gauss sums on a piece agree to the piece's share
// of the tolerance. `error` sums, over the pieces, that difference (the Gauss rule's error, which bounds
// the Kronrod rule's), the values' own estimated errors and a rounding allowance.
ExactValue exact_azimuth_mean(double visibility, double alpha, double n_dot_v, double n_dot_l, AoWeighting weighting,
                              double tolerance = kDefaultTolerance);

// The mean over phi in [0, pi] of term(phi), a term of the LUT's parameters (cone cosine c and sine s,
// NdotV, NdotL) by exact_azimuth_mean's rule: the integrator both exact_azimuth_mean and the azimuth
// grid (azimuth_grid.hpp) use. term(phi) must carry its own estimated error, computed to at most a
// quarter of `tolerance`; the caller answers the cases with no cone (zero region, visibility 0 or 1).
ExactValue azimuth_mean_of(const std::function<ExactValue(double)>& term, double c, double s, double n_dot_v,
                           double n_dot_l, double tolerance);

// The rules on the azimuth pieces of a mean for a tolerance of the mean: the C++ evaluator takes the
// Gauss-Kronrod pair of `nodes` Gauss nodes (2 nodes + 1 points) on each piece, pieces kept clear of
// complex singularities by the Bernstein ellipse of parameter `rho`; the OpenCL kernel takes the same
// pair on pieces bisected in the azimuth itself.
struct AzimuthRule {
    int nodes;
    double rho;
};
AzimuthRule azimuth_rule_for(double tolerance);

// The term at one relative azimuth (radians) in the LUT's parameters: wi = (sqrt(1 - NdotV^2), 0, NdotV),
// wo = (sin_l cos phi, sin_l sin phi, NdotL).
ExactValue exact_term_at_azimuth(double visibility, double alpha, double n_dot_v, double n_dot_l, double phi,
                                 AoWeighting weighting, double tolerance = kDefaultTolerance);

}  // namespace ms::exact
