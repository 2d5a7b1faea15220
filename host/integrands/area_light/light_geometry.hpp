// Host-side geometry of area lights (double precision): what the integrand needs to classify a query
// before sampling (no direction above the horizon, every direction in the term's zero region), the
// directions engines use in place of the light (its centre, Karis's most representative point), and
// the light sampler of the host's own estimator (outer light sampling with a given inner term).
#pragma once

#include <cmath>

#include "core/area_light.hpp"
#include "core/types.hpp"

namespace ms::area {

// Vector arithmetic in double for the light geometry and the area-light integrand.
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 add(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 sub(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 scale(const Vec3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline Vec3 cross(const Vec3& a, const Vec3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double length(const Vec3& v) { return std::hypot(v.x, v.y, v.z); }
inline Vec3 unit(const Vec3& v) { return scale(v, 1.0 / length(v)); }

// The unit direction to the light's centre (a rectangle's centre of area).
Vec3 centre_direction(const Light& light);
// The largest wo.z over the light's directions (1 when the normal is inside the light). The light has
// a direction above the horizon exactly when this is > 0.
double max_height(const Light& light);
// Solid angle of the whole light (both sides of the horizon), steradians.
double solid_angle(const Light& light);

// A light of less than this solid angle (angular radius ~1e-12 radians) is evaluated at its limit, the
// point light at its centre direction: its directions are one to double's rounding of a direction's
// components (~1e-16 radians), the term changes over it by at most its variation over 1e-12 radians,
// and its density 1 / solid angle would overflow float (from ~1e-38 sr) and double (from ~1e-308 sr).
constexpr double kPointLimitSolidAngle = 1e-24;
bool is_point_limit(const Light& light);
// Lambert lights of more than 1 sr also sample the cosine lobe (the kernel's cosine_technique, below).
constexpr double kCosineTechniqueSolidAngle = 1.0;
bool uses_cosine_technique(const AreaQuery& q);

// Karis 2013's most representative point for a GGX lobe, as engines pick it: the point of the light
// closest to the mirror direction R = reflect(-wi, z). Sphere (unit distance, radius sin gamma):
// c + t (R (c.R) - c) with t = min(1, sin gamma / |R (c.R) - c|), normalised. Rectangle: R's hit point on
// the plane clamped to the rectangle (or, when R runs parallel to or away from the plane, the rectangle
// point furthest along R's in-plane direction), normalised. lambert lobes use the centre.
Vec3 representative_direction(const AreaQuery& q);

// f(wi, wo) cos(wo) of the query's lobe (core/area_light.hpp), 0 at or below the horizon; wi unit.
double lobe_weight(const AreaQuery& q, const Vec3& wo);

// The host's estimator of T_area over an outer set of light directions, with T(wo) supplied (a
// deterministic evaluator plugs in here). It samples the light exactly as the kernel does (the
// light's own sampler; for ggx, and lambert lights of over 1 sr, u < 1/2 the light's sampler, u >= 1/2
// the lobe's, balance heuristic), from (u, v) in [0,1)^2.
struct LightSample {
    Vec3 wo;
    double weight = 0;  // W(wo) / p(wo): f cos / density, 0 below the horizon or outside the light
};
LightSample sample_light(const AreaQuery& q, double u, double v);

}  // namespace ms::area
