// Area lights seen from a shaded point: a sphere light (a cone of directions of angular radius gamma
// around a centre direction) or a rectangle (four corners, positions relative to the shaded point), in
// the tangent frame (normal = +z). Plain data and the input checks every reader and job shares.
//
// The quantity computed for them (integrands/area_light/, oracle/area_light_oracle.hpp) is the
// micro-shadowing of the light as shading sees it,
//     T_area = Int_light f(wi, wo) cos(wo) T(wo) dwo / Int_light f(wi, wo) cos(wo) dwo,
// both integrals over the light's directions above the horizon (wo.z > 0), T the generic term of the
// surface (visibility, alpha_x, alpha_y, wi) towards wo, and f the BRDF lobe being shaded:
//   lambert: f = 1 / pi;
//   ggx:     f = D(h) G2(wi, wo) / (4 wi.z wo.z), Fresnel-free (F = 1), anisotropic GGX D at the
//            surface's alpha_x, alpha_y, h = normalize(wi + wo), G2 the height-correlated Smith form
//            1 / (1 + Lambda(wi) + Lambda(wo)).
// A light with no direction above the horizon gives T_area = 0 exactly.
#pragma once

#include <array>
#include <string>

#include "core/types.hpp"

namespace ms::area {

enum class LightShape { sphere, rect };
enum class Lobe { lambert, ggx };

struct SphereLight {
    Vec3 centre{0, 0, 1};     // direction to the centre (any length; normalised by normalised())
    double half_angle = 0.1;  // gamma, radians, in (0, pi/2)
};

// Corners in order around the rectangle (p0 -> p1 -> p2 -> p3), as positions relative to the shaded
// point. Emission is two-sided: the light is the set of directions towards the rectangle.
struct RectLight {
    std::array<Vec3, 4> corners{};
};

struct Light {
    LightShape shape = LightShape::sphere;
    SphereLight sphere;
    RectLight rect;
};

struct AreaQuery {
    double visibility = 1;
    double alpha_x = 0.5, alpha_y = 0.5;
    Vec3 wi{0, 0, 1};
    Light light;
    Lobe lobe = Lobe::ggx;
};

// Relative tolerance of the rectangle checks (planarity, right angles, p2 = p1 + p3 - p0): loose enough
// for corners written with 7 significant digits, tight enough that a visibly skewed quad is refused.
constexpr double kRectTolerance = 1e-5;
// Distance from the rectangle's plane, relative to its size or to the corners' distance, below which the
// shaded point counts as lying in the plane: the rounding of the distance computed from the corners
// (double keeps ~1e-16 of them; a margin of 1e4 above it).
constexpr double kPlaneRounding = 1e-12;

// Throws std::invalid_argument naming the field and the value: the surface as core/query.hpp checks it
// (visibility in [0, 1], alpha > 0, wi above the horizon); a sphere light's centre a finite non-zero
// vector and its half-angle in (0, 90) degrees; a rectangle's corners finite, its sides of non-zero
// length, planar, at right angles, p2 = p1 + p3 - p0, and the shaded point off the rectangle's plane
// (which would make it a line of directions, of zero solid angle).
void validate(const AreaQuery& q);
// wi and a sphere light's centre as unit vectors (in double; rectangle corners are positions, kept).
AreaQuery normalised(const AreaQuery& q);

std::string to_string(Lobe);
std::string to_string(LightShape);
Lobe parse_lobe(const std::string&);              // "lambert" | "ggx"; std::invalid_argument otherwise
LightShape parse_light_shape(const std::string&);  // "sphere" | "rect"

inline double degrees(double radians) { return radians * (180.0 / kPi); }
inline double radians(double degrees) { return degrees * (kPi / 180.0); }

}  // namespace ms::area
