#include "env/sphere.hpp"

#include <cmath>
#include <stdexcept>

#include "core/types.hpp"

namespace ms::env {

namespace {
Dir normalised(double x, double y, double z) {
    const double n = std::sqrt(x * x + y * y + z * z);
    return {x / n, y / n, z / n};
}
// Integral of the solid angle over [0, x] x [0, y] on the face plane at distance 1.
double area_element(double x, double y) { return std::atan2(x * y, std::sqrt(x * x + y * y + 1)); }
}  // namespace

Dir equirect_direction(double u, double v) {
    const double phi = 2 * kPi * (u - 0.5), theta = kPi * v;
    return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}

void equirect_uv(const Dir& d, double& u, double& v) {
    u = std::atan2(d.x, -d.z) / (2 * kPi) + 0.5;
    if (u >= 1) u -= 1;
    v = std::acos(std::fmax(-1.0, std::fmin(1.0, d.y))) / kPi;
}

double equirect_texel_solid_angle(std::uint32_t y, std::uint32_t width, std::uint32_t height) {
    const double t0 = kPi * y / height, t1 = kPi * (y + 1.0) / height;
    return 2 * kPi / width * (std::cos(t0) - std::cos(t1));
}

Dir cube_direction(int face, double s, double t) {
    switch (face) {
        case 0: return normalised(1, -t, -s);
        case 1: return normalised(-1, -t, s);
        case 2: return normalised(s, 1, t);
        case 3: return normalised(s, -1, -t);
        case 4: return normalised(s, -t, 1);
        case 5: return normalised(-s, -t, -1);
    }
    throw std::invalid_argument("cube_direction: face must be 0..5");
}

void cube_face_st(const Dir& d, int& face, double& s, double& t) {
    const double ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
    if (ax >= ay && ax >= az) {
        face = d.x > 0 ? 0 : 1;
        s = (d.x > 0 ? -d.z : d.z) / ax;
        t = -d.y / ax;
    } else if (ay >= az) {
        face = d.y > 0 ? 2 : 3;
        s = d.x / ay;
        t = (d.y > 0 ? d.z : -d.z) / ay;
    } else {
        face = d.z > 0 ? 4 : 5;
        s = (d.z > 0 ? d.x : -d.x) / az;
        t = -d.y / az;
    }
}

double cube_texel_solid_angle(std::uint32_t x, std::uint32_t y, std::uint32_t n) {
    const double x0 = 2.0 * x / n - 1, x1 = 2.0 * (x + 1) / n - 1;
    const double y0 = 2.0 * y / n - 1, y1 = 2.0 * (y + 1) / n - 1;
    return area_element(x0, y0) - area_element(x0, y1) - area_element(x1, y0) + area_element(x1, y1);
}

}  // namespace ms::env
