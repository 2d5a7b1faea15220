// Spherical harmonics of order 2 (bands l = 0, 1, 2: nine coefficients per channel) and the irradiance
// of an environment through the clamped-cosine convolution (Ramamoorthi & Hanrahan 2001):
//     E(n) = sum_lm A_l L_lm Y_lm(n),   A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4.
// Real SH basis, index k = l (l + 1) + m: Y00 = 1/(2 sqrt pi); Y1-1, Y10, Y11 = sqrt(3/(4 pi)) (y, z, x);
// Y2-2 = sqrt(15/(4 pi)) xy, Y2-1 = sqrt(15/(4 pi)) yz, Y20 = sqrt(5/(16 pi)) (3 z^2 - 1),
// Y21 = sqrt(15/(4 pi)) xz, Y22 = sqrt(15/(16 pi)) (x^2 - y^2).
#pragma once

#include <array>
#include <functional>

#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/sphere.hpp"

namespace ms::env {

using Sh9 = std::array<std::array<double, 3>, 9>;  // [k][channel]

std::array<double, 9> sh_basis(const Dir& d);
extern const std::array<double, 3> kClampedCosine;  // A_0, A_1, A_2

// Projection of an equirectangular image as a piecewise-constant function: each texel's value times
// the exact integral of each basis function over the texel (closed forms), so a constant environment
// projects exactly onto Y00 and nothing leaks into the other bands.
std::array<double, 9> equirect_texel_sh_integrals(std::uint32_t x, std::uint32_t y, std::uint32_t width, std::uint32_t height);
Sh9 sh_project_equirect(const Image& equirect);
// Projection of a cubemap (exact texel solid angles).
Sh9 sh_project_cubemap(const Cubemap& cube);
// Projection of a function by a product rule (Gauss-Legendre in cos theta, uniform in phi) of n x 2n
// nodes, exact for band-limited functions of degree < n (tests use analytic functions).
Sh9 sh_project_function(const std::function<std::array<double, 3>(const Dir&)>& f, int n = 16);

// Irradiance E(n) from the coefficients (the clamped-cosine convolution), per channel.
std::array<double, 3> sh_irradiance(const Sh9& sh, const Dir& n);
// The environment's value reconstructed from its nine coefficients.
std::array<double, 3> sh_evaluate(const Sh9& sh, const Dir& d);

// Irradiance of an equirectangular image by brute force (every texel, exact solid angles): the oracle
// of the SH route for low-frequency environments.
std::array<double, 3> irradiance_brute_force(const Image& equirect, const Dir& n);
std::array<double, 3> irradiance_brute_force(const Cubemap& cube, const Dir& n);

}  // namespace ms::env
