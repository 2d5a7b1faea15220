// Directions of environment maps: the equirectangular (latitude-longitude) mapping and the cubemap
// faces, with exact texel solid angles. Plain double; no formulas shared with kernels.
//
// Equirectangular (cmgen's and glTF-IBL-Sampler's latlong, +Y up): pixel (x, y) of a w x h image has
// u = (x + 0.5) / w, v = (y + 0.5) / h, phi = 2 pi (u - 0.5), theta = pi v and
//     dir = (sin theta sin phi, cos theta, -sin theta cos phi),
// so the image centre looks down -Z and the top row is +Y. Texel solid angle: (2 pi / w)(cos theta0 - cos theta1).
// Cubemap faces in the OpenGL / KTX2 / DDS order +X, -X, +Y, -Y, +Z, -Z; on a face, s (right) and t
// (down) in [-1, 1]:  +X (1, -t, -s)  -X (-1, -t, s)  +Y (s, 1, t)  -Y (s, -1, -t)  +Z (s, -t, 1)  -Z (-s, -t, -1).
#pragma once

#include <array>
#include <cstdint>

namespace ms::env {

struct Dir {
    double x = 0, y = 0, z = 1;
};

Dir equirect_direction(double u, double v);  // u, v in [0, 1]
void equirect_uv(const Dir& d, double& u, double& v);  // d unit; u in [0, 1), v in [0, 1]
double equirect_texel_solid_angle(std::uint32_t y, std::uint32_t width, std::uint32_t height);

// Unit direction through face coordinates (s, t) in [-1, 1].
Dir cube_direction(int face, double s, double t);
// Face and (s, t) of a direction (the major axis picks the face).
void cube_face_st(const Dir& d, int& face, double& s, double& t);
// Exact solid angle of texel (x, y) on a face of size n (the area formula of the projected square).
double cube_texel_solid_angle(std::uint32_t x, std::uint32_t y, std::uint32_t n);

}  // namespace ms::env
