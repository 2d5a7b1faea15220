// The DFG oracle: the split-sum integrals of GGX by deterministic quadrature in double, written apart
// from kernels/dfg/dfg.cl (different variables, no sampling), so one mistake cannot pass both.
//
// Integrals (height-correlated Smith G2, Schlick's Fc = (1 - VdotH)^5, V = (sqrt(1 - v^2), 0, v)):
//     scale = integral f (1 - Fc) NdotL dL,   bias = integral f Fc NdotL dL,   f = D G2 / (4 NdotL NdotV).
// Variables: the half vector h, its polar angle through the GGX NDF's CDF u = tan^2 t / (alpha^2 + tan^2 t)
// (so D(h) cos t dw_h = du dphi / 2 pi) and its azimuth phi. With dL = 4 (V.h) dw_h:
//     f NdotL dL = G2(V, L) (V.h) / (v cos t) du dphi / (2 pi),   L = 2 (V.h) h - V.
// L is above the horizon for every phi while t < t1 = (pi/2 - t_v)/2, for |phi| < phi*(t) with
// cos phi* = -cot(2t) cot(t_v) while t1 < t < t2 = (pi/2 + t_v)/2, and never beyond t2 (t_v = acos v).
// The integral is split there so each piece is smooth inside; both variables use composite
// Gauss-Legendre on panels graded geometrically towards both ends (the integrand varies on a scale of
// alpha near L's horizon, and phi* has a square-root end). Two orders give the error estimate.
#pragma once

#include <vector>

namespace ms::dfg {

struct DfgQuadrature {
    double scale = 0, bias = 0;
    double scale_error = 0, bias_error = 0;  // |high order - low order|, a bound on the high order's error in practice
    // The cloth (Charlie sheen) albedo: int D_C V_N NdotL dL (Estevez & Kulla's NDF with alpha as its
    // roughness, Neubelt & Pettineo's visibility), and its two-order error estimate.
    double sheen = 0, sheen_error = 0;
};

// n_dot_v in (0, 1], alpha in (0, 1]. order: Gauss-Legendre nodes per panel of the higher order (the
// lower order uses order - 4). sheen: also the cloth channel. Throws std::invalid_argument outside the domain.
DfgQuadrature dfg_quadrature(double n_dot_v, double alpha, int order = 12, bool sheen = false);

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre recurrence), exposed for tests.
void gauss_legendre(int n, std::vector<double>& nodes, std::vector<double>& weights);

}  // namespace ms::dfg
