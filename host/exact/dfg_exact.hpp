// The DFG LUT's integrals by deterministic quadrature to ~1e-12: the split-sum GGX scale and bias, and
// the cloth (Charlie sheen) albedo. It is the `ibl dfg --method exact` path; its checks are the
// independent quadrature in integrands/dfg/dfg_quadrature.* (other variables, the other order of
// integration, its own Smith and Charlie code) and the VNDF-sampled kernel kernels/dfg/dfg.cl.
//
// GGX (alpha = roughness^2, height-correlated Smith G2, Schlick Fc = (1 - VdotH)^5, V = (sin_v, 0, v)):
//     scale = int f (1 - Fc) NdotL dL,   bias = int f Fc NdotL dL,   f = D G2 / (4 NdotL NdotV).
// Sheen (Estevez & Kulla's Charlie NDF with Neubelt & Pettineo's visibility, the pair Filament's cmgen
// and the glTF IBL sampler bake; its "roughness" parameter is alpha here too, as in cmgen's DFG):
//     sheen = int D_C(h) V_N(v, l) NdotL dL,  D_C = (2 + 1/alpha) sin(t_h)^(1/alpha) / (2 pi),
//     V_N = 1 / (4 (NdotL + NdotV - NdotL NdotV)).
//
// Variables: the half vector's azimuth phi (outer, [0, pi] by symmetry) and its polar angle t (inner).
// For a fixed phi the reflected L = 2 (V.h) h - V has L.z = sin_v sin 2t cos phi + v cos 2t, which is
// positive exactly for t < t*(phi) = pi/4 + atan(tan_v cos phi) / 2: one smooth boundary, no clipping
// inside the rule. dL = 4 (V.h) dw_h. The GGX inner variable is s = sqrt(u), u = tan^2 t / (alpha^2 +
// tan^2 t) the GGX CDF in t (D cos t dw_h = du dphi / 2 pi absorbs the peak; the square root removes
// sin t ~ sqrt(u) at u = 0); the sheen inner variable is t itself.
#pragma once

namespace ms::exact {

struct DfgExact {
    double scale = 0, bias = 0, sheen = 0;
    // |rule(order) - rule(order - 4)| on the same panels: the lower rule's error, so a bound on the
    // higher one's in practice (Gauss-Legendre converges geometrically on these analytic pieces).
    double scale_error = 0, bias_error = 0, sheen_error = 0;
};

// n_dot_v in (0, 1], alpha in (0, 1]; order: Gauss-Legendre nodes per panel (>= 8). Throws
// std::invalid_argument outside the domain. sheen: also integrate the Charlie channel.
DfgExact dfg_exact(double n_dot_v, double alpha, bool sheen = true, int order = 16);

}  // namespace ms::exact
