#include "env/sh.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <algorithm>
#include <vector>

#include "core/types.hpp"

namespace ms::env {

const std::array<double, 3> kClampedCosine = {kPi, 2 * kPi / 3, kPi / 4};

std::array<double, 9> sh_basis(const Dir& d) {
    const double c0 = 0.5 / std::sqrt(kPi), c1 = std::sqrt(3 / (4 * kPi)), c2 = std::sqrt(15 / (4 * kPi)),
                 c20 = std::sqrt(5 / (16 * kPi)), c22 = std::sqrt(15 / (16 * kPi));
    const double x = d.x, y = d.y, z = d.z;
    return {c0, c1 * y, c1 * z, c1 * x, c2 * x * y, c2 * y * z, c20 * (3 * z * z - 1), c2 * x * z, c22 * (x * x - y * y)};
}

std::array<double, 9> equirect_texel_sh_integrals(std::uint32_t x, std::uint32_t y, std::uint32_t w, std::uint32_t h) {
    // With u = cos theta (the direction's y) and s = sin theta: x = s sin phi, y = u, z = -s cos phi, dw = du dphi.
    const double p0 = 2 * kPi * (double(x) / w - 0.5), p1 = 2 * kPi * (double(x + 1) / w - 0.5);
    const double ua = std::cos(kPi * (y + 1.0) / h), ub = std::cos(kPi * double(y) / h);  // ua < ub
    auto F = [](double u) {  // antiderivatives in u of 1, u, u^2, sqrt(1 - u^2), u sqrt(1 - u^2)
        const double r = std::sqrt(std::max(0.0, 1 - u * u));
        return std::array<double, 5>{u, u * u / 2, u * u * u / 3, (u * r + std::asin(std::clamp(u, -1.0, 1.0))) / 2, -r * r * r / 3};
    };
    const auto fa = F(ua), fb = F(ub);
    const double U0 = fb[0] - fa[0], U1 = fb[1] - fa[1], U2 = fb[2] - fa[2], S = fb[3] - fa[3], US = fb[4] - fa[4];
    const double P = p1 - p0, C = std::sin(p1) - std::sin(p0), Sn = std::cos(p0) - std::cos(p1);
    const double C2 = P / 2 + (std::sin(2 * p1) - std::sin(2 * p0)) / 4, S2 = P / 2 - (std::sin(2 * p1) - std::sin(2 * p0)) / 4;
    const double SC = (std::sin(p1) * std::sin(p1) - std::sin(p0) * std::sin(p0)) / 2;
    const double c0 = 0.5 / std::sqrt(kPi), c1 = std::sqrt(3 / (4 * kPi)), c2 = std::sqrt(15 / (4 * kPi)),
                 c20 = std::sqrt(5 / (16 * kPi)), c22 = std::sqrt(15 / (16 * kPi));
    const double S2u = U0 - U2;  // int s^2 du
    return {c0 * U0 * P,
            c1 * U1 * P,                          // y
            -c1 * S * C,                          // z = -s cos
            c1 * S * Sn,                          // x = s sin
            c2 * US * Sn,                         // xy = u s sin
            -c2 * US * C,                         // yz = -u s cos
            c20 * (3 * S2u * C2 - U0 * P),        // 3 z^2 - 1 = 3 s^2 cos^2 - 1
            -c2 * S2u * SC,                       // xz = -s^2 sin cos
            c22 * (S2u * S2 - U1 * 0 - U2 * P)};  // x^2 - y^2 = s^2 sin^2 - u^2
}

Sh9 sh_project_equirect(const Image& img) {
    if (img.channels < 3 || img.width == 0 || img.height == 0) throw std::invalid_argument("sh_project_equirect: need an RGB image");
    Sh9 sh{};
    for (std::uint32_t y = 0; y < img.height; ++y)
        for (std::uint32_t x = 0; x < img.width; ++x) {
            const auto b = equirect_texel_sh_integrals(x, y, img.width, img.height);
            for (int c = 0; c < 3; ++c) {
                const double v = img.at(x, y, c);
                for (int k = 0; k < 9; ++k) sh[k][c] += v * b[k];
            }
        }
    return sh;
}

Sh9 sh_project_cubemap(const Cubemap& cube) {
    Sh9 sh{};
    const std::uint32_t n = cube.size;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const double dw = cube_texel_solid_angle(x, y, n);
                const auto b = sh_basis(cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1));
                const float* t = cube.texel(f, x, y);
                for (int c = 0; c < 3; ++c)
                    for (int k = 0; k < 9; ++k) sh[k][c] += t[c] * dw * b[k];
            }
    return sh;
}

std::array<double, 3> irradiance_brute_force(const Cubemap& cube, const Dir& nrm) {
    std::array<double, 3> e{};
    const std::uint32_t n = cube.size;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const Dir d = cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                const double c = d.x * nrm.x + d.y * nrm.y + d.z * nrm.z;
                if (c <= 0) continue;
                const double w = c * cube_texel_solid_angle(x, y, n);
                const float* t = cube.texel(f, x, y);
                for (int k = 0; k < 3; ++k) e[k] += t[k] * w;
            }
    return e;
}

Sh9 sh_project_function(const std::function<std::array<double, 3>(const Dir&)>& f, int n) {
    // Gauss-Legendre nodes in z = cos theta (Newton on the recurrence).
    std::vector<double> zs(n), ws(n);
    for (int i = 0; i < n; ++i) {
        double x = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1, p1 = x;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2.0 * k - 1) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1, p1 = p2;
            }
            dp = n * (x * p1 - p0) / (x * x - 1);
            const double dx = p1 / dp;
            x -= dx;
            if (std::abs(dx) < 1e-16) break;
        }
        zs[i] = x;
        ws[i] = 2 / ((1 - x * x) * dp * dp);
    }
    Sh9 sh{};
    const int m = 2 * n;
    for (int i = 0; i < n; ++i) {
        const double z = zs[i], r = std::sqrt(std::max(0.0, 1 - z * z));
        for (int j = 0; j < m; ++j) {
            const double phi = 2 * kPi * (j + 0.5) / m;
            const Dir d{r * std::cos(phi), r * std::sin(phi), z};
            const auto v = f(d);
            const auto b = sh_basis(d);
            const double w = ws[i] * 2 * kPi / m;
            for (int k = 0; k < 9; ++k)
                for (int c = 0; c < 3; ++c) sh[k][c] += w * v[c] * b[k];
        }
    }
    return sh;
}

std::array<double, 3> sh_irradiance(const Sh9& sh, const Dir& n) {
    const auto b = sh_basis(n);
    std::array<double, 3> e{};
    for (int k = 0; k < 9; ++k) {
        const double a = kClampedCosine[k == 0 ? 0 : k < 4 ? 1 : 2];
        for (int c = 0; c < 3; ++c) e[c] += a * sh[k][c] * b[k];
    }
    return e;
}

std::array<double, 3> sh_evaluate(const Sh9& sh, const Dir& d) {
    const auto b = sh_basis(d);
    std::array<double, 3> e{};
    for (int k = 0; k < 9; ++k)
        for (int c = 0; c < 3; ++c) e[c] += sh[k][c] * b[k];
    return e;
}

std::array<double, 3> irradiance_brute_force(const Image& img, const Dir& n) {
    std::array<double, 3> e{};
    for (std::uint32_t y = 0; y < img.height; ++y) {
        const double dw = equirect_texel_solid_angle(y, img.width, img.height);
        for (std::uint32_t x = 0; x < img.width; ++x) {
            const Dir d = equirect_direction((x + 0.5) / img.width, (y + 0.5) / img.height);
            const double c = d.x * n.x + d.y * n.y + d.z * n.z;
            if (c <= 0) continue;
            for (int k = 0; k < 3; ++k) e[k] += img.at(x, y, k) * c * dw;
        }
    }
    return e;
}

}  // namespace ms::env
