// Irradiance by direct convolution: E(n) = integral L(l) max(0, n.l) dl over the sphere, the
// clamped-cosine convolution of the environment, computed texel by texel instead of through order-2 SH.
// This file is the oracle side (plain double): the exact integral of max(0, n.l) over one cubemap texel,
// the exact irradiance of a cubemap read as piecewise constant per texel, and the solid-angle-weighted
// reduction of a cubemap that the kernel convolves (with what that reduction can cost, as a bound).
//
// The texel integral, in the coordinates of the face plane: a direction is l = p / |p|, p = s e_s + t e_t + e_w
// (env/sphere.hpp's face frames, orthonormal), q = |p|^2 = 1 + s^2 + t^2 and dl = ds dt / q^(3/2), so
//     integral_T (n.l) dl = integral_T (a s + b t + w) / q^2 ds dt,   a = n.e_s, b = n.e_t, w = n.e_w.
// Antiderivatives: s / q^2 = d/ds (-1 / (2q)), t / q^2 = d/dt (-1 / (2q)), and with k^2 = 1 + t^2,
//     1 / q^2 = d/ds [ s / (2 k^2 q) + atan(s / k) / (2 k^3) ];
// over a whole rectangle the last one integrates to the corner function (the parallel-rectangle form factor)
//     P(s, t) = 1/2 [ s / sqrt(1 + s^2) atan(t / sqrt(1 + s^2)) + t / sqrt(1 + t^2) atan(s / sqrt(1 + t^2)) ].
// A texel the horizon n.l = 0 crosses is clipped by the line a s + b t + w = 0 in its face plane (a convex
// polygon) and integrated by Green's theorem, integral (dG/ds + dH/dt) = loop integral (G dt - H ds) with
// G = -a / (2q) + w (s / (2 k^2 q) + atan(s / k) / (2 k^3)), H = -b / (2q): Gauss-Legendre on each edge
// of a smooth integrand (q >= 1), exact to rounding. So a constant environment gives E = pi L to rounding.
#pragma once

#include <array>
#include <vector>

#include "env/cubemap.hpp"
#include "env/sphere.hpp"

namespace ms::env {

// integral over texel (x, y) of face `face` (size n) of max(0, n.l) dl (n unit).
double clamped_cosine_texel_integral(const Dir& n, int face, std::uint32_t x, std::uint32_t y, std::uint32_t size);

// E(n) = sum over every texel of L_texel * clamped_cosine_texel_integral: exact for the cubemap read as
// piecewise constant per texel (no quadrature error; the irradiance, not E / pi).
std::array<double, 3> irradiance_exact(const Cubemap& source, const Dir& n);

// A cubemap reduced to `size` (a power of two dividing the source's) by solid-angle-weighted means,
//     Lbar_T = sum_i L_i Omega_i / Omega_T over the source texels i inside coarse texel T,
// so every coarse texel keeps the power of its source texels exactly, and its spread
//     deviation_T = sum_i |L_i - Lbar_T| Omega_i  (per channel),
// which bounds what convolving the reduced map costs: for any n,
//     |E_source(n) - E_reduced(n)| <= sum_{T touching n.l > 0} diameter_T * deviation_T,
// because max(0, n.l) is 1-Lipschitz in the angle and varies by at most diameter_T (the texel's largest
// corner-to-corner angle) over T: E_source - E_reduced = sum_T sum_i (L_i - Lbar_T)(c_i - cbar_T) Omega_i,
// with c_i, cbar_T the means of max(0, n.l) over texel i and over T.
struct ReducedCubemap {
    Cubemap mean;
    std::vector<std::array<double, 3>> deviation;  // [face][y][x] of `mean`, per channel
};
ReducedCubemap reduce_cubemap(const Cubemap& source, std::uint32_t size);

}  // namespace ms::env
