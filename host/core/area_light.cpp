#include "core/area_light.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "core/query.hpp"

namespace ms::area {

namespace {

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 cross(const Vec3& a, const Vec3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double length(const Vec3& v) { return std::hypot(v.x, v.y, v.z); }
bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string number(double x) {
    std::ostringstream s;
    s.precision(9);
    s << x;
    return s.str();
}

void validate_rect(const RectLight& r) {
    for (int k = 0; k < 4; ++k)
        if (!finite(r.corners[k])) throw std::invalid_argument("rect light: corner p" + std::to_string(k) + " is not finite");
    const Vec3 e1 = sub(r.corners[1], r.corners[0]), e2 = sub(r.corners[3], r.corners[0]);
    const double l1 = length(e1), l2 = length(e2);
    if (!(l1 > 0) || !(l2 > 0) || !std::isfinite(l1) || !std::isfinite(l2))
        throw std::invalid_argument("degenerate rect light: a side (p1 - p0 or p3 - p0) has zero length");
    const double size = std::max(l1, l2);
    // p2 must close the parallelogram: p2 - p0 = e1 + e2.
    const Vec3 gap = sub(sub(r.corners[2], r.corners[0]), {e1.x + e2.x, e1.y + e2.y, e1.z + e2.z});
    if (length(gap) > kRectTolerance * size)
        throw std::invalid_argument("degenerate rect light: p2 is " + number(length(gap)) +
                                    " away from p1 + p3 - p0 (corners must be in order around a rectangle)");
    const double cos_corner = dot(e1, e2) / (l1 * l2);
    if (std::fabs(cos_corner) > kRectTolerance)
        throw std::invalid_argument("degenerate rect light: the corner at p0 is " + number(std::acos(std::fmax(-1.0, std::fmin(1.0, cos_corner))) * 180 / kPi) +
                                    " degrees, not a right angle");
    // The unit normal from the unit edges: the cross product of the edges themselves underflows for a
    // rectangle of sides ~1e-160, which is small but not degenerate.
    const Vec3 n = cross(Vec3{e1.x / l1, e1.y / l1, e1.z / l1}, Vec3{e2.x / l2, e2.y / l2, e2.z / l2});
    // The shaded point (the origin) in the rectangle's plane sees it edge-on: zero solid angle. Only a
    // distance lost in the rounding of n.p0 (~1e-16 of the corners' reach) is that: a rectangle far larger
    // than its distance covers nearly a hemisphere, which is no degeneracy.
    const double distance = std::fabs(dot(n, r.corners[0])) / length(n);
    const double reach = std::fmax(size, length(r.corners[0]));
    if (!(distance > kPlaneRounding * reach))
        throw std::invalid_argument("degenerate rect light: the shaded point lies in the rectangle's plane (distance " +
                                    number(distance) + "), so it covers no solid angle");
}

}  // namespace

void validate(const AreaQuery& q) {
    Query surface;
    surface.visibility = q.visibility;
    surface.alpha_x = q.alpha_x;
    surface.alpha_y = q.alpha_y;
    surface.wi = q.wi;
    surface.wo = q.wi;
    validate_query(surface);
    if (q.light.shape == LightShape::sphere) {
        const SphereLight& s = q.light.sphere;
        if (!finite(s.centre) || !(length(s.centre) > 0) || !std::isfinite(length(s.centre)))
            throw std::invalid_argument("sphere light: the centre direction must be a finite non-zero vector");
        if (!std::isfinite(s.half_angle) || !(s.half_angle > 0) || !(s.half_angle < kPi / 2))
            throw std::invalid_argument("sphere light: half-angle must be in (0, 90) degrees, got " +
                                        number(degrees(s.half_angle)));
    } else {
        validate_rect(q.light.rect);
    }
}

AreaQuery normalised(const AreaQuery& q) {
    AreaQuery out = q;
    const double li = length(q.wi);
    out.wi = {q.wi.x / li, q.wi.y / li, q.wi.z / li};
    if (q.light.shape == LightShape::sphere) {
        const double lc = length(q.light.sphere.centre);
        const Vec3& c = q.light.sphere.centre;
        out.light.sphere.centre = {c.x / lc, c.y / lc, c.z / lc};
    }
    return out;
}

std::string to_string(Lobe l) { return l == Lobe::lambert ? "lambert" : "ggx"; }
std::string to_string(LightShape s) { return s == LightShape::sphere ? "sphere" : "rect"; }

Lobe parse_lobe(const std::string& s) {
    if (s == "lambert") return Lobe::lambert;
    if (s == "ggx") return Lobe::ggx;
    throw std::invalid_argument("unknown lobe '" + s + "' (lambert or ggx)");
}

LightShape parse_light_shape(const std::string& s) {
    if (s == "sphere") return LightShape::sphere;
    if (s == "rect") return LightShape::rect;
    throw std::invalid_argument("unknown light '" + s + "' (sphere or rect)");
}

}  // namespace ms::area
