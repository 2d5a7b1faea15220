#include "integrands/area_light/light_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ms::area {

namespace {

Vec3 rect_centre(const RectLight& r) { return scale(add(r.corners[0], r.corners[2]), 0.5); }

// Largest z on the minor great-circle arc from unit a to unit b.
double arc_max_height(const Vec3& a, const Vec3& b) {
    double best = std::max(a.z, b.z);
    const Vec3 n = cross(a, b);
    const double ln = length(n);
    if (!(ln > 0)) return best;
    const Vec3 un = scale(n, 1.0 / ln);
    // The great circle's highest point is z projected onto its plane; it counts if it lies on the arc.
    const Vec3 p = sub(Vec3{0, 0, 1}, scale(un, un.z));
    const double lp = length(p);
    if (!(lp > 0)) return best;
    const Vec3 top = scale(p, 1.0 / lp);
    if (dot(cross(a, top), un) >= 0 && dot(cross(top, b), un) >= 0) best = std::max(best, top.z);
    return best;
}

// GGX pieces for the host estimator (the same definitions as core/area_light.hpp states).
double ggx_d(const Vec3& h, double ax, double ay) {
    const double ex = h.x / ax, ey = h.y / ay;
    const double s = ex * ex + ey * ey + h.z * h.z;
    return 1.0 / (kPi * ax * ay * s * s);
}
// z Lambda(w) = (|(ax wx, ay wy, wz)| - wz) / 2, written as s2 / (2 (wz + r)) so it neither cancels nor
// divides by wz: the BRDF's denominator 4 wz (1 + Lambda) stays finite and positive as wz -> 0 (a
// normalised wi can be denormal), where Lambda alone overflows.
double z_lambda(const Vec3& w, double ax, double ay) {
    const double s2 = ax * ax * w.x * w.x + ay * ay * w.y * w.y;
    return s2 / (2.0 * (w.z + std::sqrt(w.z * w.z + s2)));
}
double lambda(const Vec3& w, double ax, double ay) {
    if (!(w.z > 0)) return std::numeric_limits<double>::infinity();
    return z_lambda(w, ax, ay) / w.z;
}
// 4 wi.z (1 + Lambda(wi) + Lambda(wo)) with wi.z Lambda(wi) taken in product form (wo.z > 0).
double ggx_denominator(const Vec3& wi, const Vec3& wo, double ax, double ay) {
    return 4 * (wi.z + z_lambda(wi, ax, ay) + wi.z * lambda(wo, ax, ay));
}

// Density of the light's own sampler at unit wo (0 outside).
double light_pdf(const Light& light, const Vec3& wo) {
    if (light.shape == LightShape::sphere) {
        const Vec3& c = light.sphere.centre;
        const Vec3 x = cross(wo, c);
        const double s = std::sin(light.sphere.half_angle);
        return dot(wo, c) > 0 && dot(x, x) < s * s ? 1.0 / solid_angle(light) : 0.0;
    }
    const RectLight& r = light.rect;
    const Vec3 e1 = sub(r.corners[1], r.corners[0]), e2 = sub(r.corners[3], r.corners[0]);
    Vec3 n = cross(e1, e2);
    const double area = length(n);
    n = scale(n, 1.0 / area);
    double d = dot(n, r.corners[0]);
    if (d < 0) n = scale(n, -1.0), d = -d;
    const double facing = dot(n, wo);
    if (!(facing > 0)) return 0.0;
    const double t = d / facing;
    const Vec3 p = sub(scale(wo, t), r.corners[0]);
    const double x = dot(p, e1) / dot(e1, e1), y = dot(p, e2) / dot(e2, e2);
    if (x < 0 || x > 1 || y < 0 || y > 1) return 0.0;
    return t * t / (area * facing);
}

}  // namespace

Vec3 centre_direction(const Light& light) {
    return light.shape == LightShape::sphere ? unit(light.sphere.centre) : unit(rect_centre(light.rect));
}

double solid_angle(const Light& light) {
    if (light.shape == LightShape::sphere) {
        const double s = std::sin(light.sphere.half_angle / 2);
        return 4 * kPi * s * s;  // 2 pi (1 - cos gamma), without cancellation
    }
    // A convex spherical quadrilateral: two triangles, each by Van Oosterom & Strackee's formula.
    Vec3 v[4];
    for (int k = 0; k < 4; ++k) v[k] = unit(light.rect.corners[k]);
    auto triangle = [](const Vec3& a, const Vec3& b, const Vec3& c) {
        const double num = std::fabs(dot(a, cross(b, c)));
        const double den = 1 + dot(a, b) + dot(b, c) + dot(c, a);
        return 2 * std::atan2(num, den);
    };
    return triangle(v[0], v[1], v[2]) + triangle(v[0], v[2], v[3]);
}

double max_height(const Light& light) {
    if (light.shape == LightShape::sphere) {
        const Vec3 c = unit(light.sphere.centre);
        const double theta_c = std::atan2(std::hypot(c.x, c.y), c.z);
        return theta_c <= light.sphere.half_angle ? 1.0 : std::cos(theta_c - light.sphere.half_angle);
    }
    Vec3 v[4];
    for (int k = 0; k < 4; ++k) v[k] = unit(light.rect.corners[k]);
    // The normal is inside the (convex) spherical quadrilateral when it is on the same side of all four
    // edges' great circles.
    int positive = 0, negative = 0;
    for (int k = 0; k < 4; ++k) {
        const double s = cross(v[k], v[(k + 1) % 4]).z;
        positive += s > 0, negative += s < 0;
    }
    if (positive == 4 || negative == 4) return 1.0;
    double best = -1;
    for (int k = 0; k < 4; ++k) best = std::max(best, arc_max_height(v[k], v[(k + 1) % 4]));
    return best;
}

bool is_point_limit(const Light& light) { return !(solid_angle(light) >= kPointLimitSolidAngle); }

bool uses_cosine_technique(const AreaQuery& q) {
    return q.lobe == Lobe::lambert && solid_angle(q.light) > kCosineTechniqueSolidAngle;
}

Vec3 representative_direction(const AreaQuery& q) {
    if (q.lobe == Lobe::lambert) return centre_direction(q.light);
    const Vec3 wi = unit(q.wi);
    const Vec3 r{-wi.x, -wi.y, wi.z};  // reflect(-wi, z)
    if (q.light.shape == LightShape::sphere) {
        const Vec3 c = unit(q.light.sphere.centre);
        const Vec3 to_ray = sub(scale(r, dot(c, r)), c);
        const double l = length(to_ray);
        const double t = l > 0 ? std::min(1.0, std::sin(q.light.sphere.half_angle) / l) : 0.0;
        return unit(add(c, scale(to_ray, t)));
    }
    const RectLight& rect = q.light.rect;
    const Vec3 e1 = sub(rect.corners[1], rect.corners[0]), e2 = sub(rect.corners[3], rect.corners[0]);
    Vec3 n = unit(cross(e1, e2));
    const double d = dot(n, rect.corners[0]);
    if (d < 0) n = scale(n, -1.0);
    const double facing = dot(n, r);
    Vec3 p;
    if (facing > 1e-12) {
        p = sub(scale(r, std::fabs(d) / facing), rect.corners[0]);
    } else {
        // R never reaches the plane: walk from the centre along R's in-plane direction, then clamp.
        const Vec3 in_plane = sub(r, scale(n, facing));
        p = add(sub(rect_centre(rect), rect.corners[0]), scale(in_plane, 1e6 * (length(e1) + length(e2))));
    }
    const double x = std::clamp(dot(p, e1) / dot(e1, e1), 0.0, 1.0);
    const double y = std::clamp(dot(p, e2) / dot(e2, e2), 0.0, 1.0);
    return unit(add(rect.corners[0], add(scale(e1, x), scale(e2, y))));
}

double lobe_weight(const AreaQuery& q, const Vec3& wo) {
    if (!(wo.z > 0)) return 0.0;
    if (q.lobe == Lobe::lambert) return wo.z / kPi;
    const Vec3 wi = unit(q.wi);
    const Vec3 h = unit(add(wi, wo));
    const double d = ggx_d(h, q.alpha_x, q.alpha_y);
    return d / ggx_denominator(wi, wo, q.alpha_x, q.alpha_y);
}

LightSample sample_light(const AreaQuery& q, double u, double v) {
    LightSample s;
    // ggx (and lambert with the cosine technique): u < 1/2 picks the light's sampler, else the lobe's,
    // u stretched back onto [0, 1).
    const bool cosine = uses_cosine_technique(q);
    const bool two_techniques = q.lobe == Lobe::ggx || cosine;
    const bool lobe_technique = two_techniques && u >= 0.5;
    if (two_techniques) u = lobe_technique ? 2 * u - 1 : 2 * u;
    const Vec3 wi = unit(q.wi);
    double pdf_light = 0;
    if (!lobe_technique) {
        if (q.light.shape == LightShape::sphere) {
            const Vec3 c = unit(q.light.sphere.centre);
            // A frame around c: t1 perpendicular to c, t2 = c x t1.
            const Vec3 helper = std::fabs(c.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
            const Vec3 t1 = unit(cross(helper, c)), t2 = cross(c, t1);
            const double sh = std::sin(q.light.sphere.half_angle / 2);
            const double one_minus_cos = u * 2 * sh * sh;
            const double sin_t = std::sqrt(std::max(0.0, one_minus_cos * (2 - one_minus_cos)));
            const double phi = 2 * kPi * v;
            s.wo = add(add(scale(t1, sin_t * std::cos(phi)), scale(t2, sin_t * std::sin(phi))), scale(c, 1 - one_minus_cos));
            pdf_light = 1.0 / solid_angle(q.light);
        } else {
            const RectLight& r = q.light.rect;
            const Vec3 p = add(r.corners[0], add(scale(sub(r.corners[1], r.corners[0]), u), scale(sub(r.corners[3], r.corners[0]), v)));
            s.wo = unit(p);
            pdf_light = light_pdf(q.light, s.wo);
            if (!(pdf_light > 0)) {  // an edge sample the containment test rounds out: same density
                const Vec3 n = cross(sub(r.corners[1], r.corners[0]), sub(r.corners[3], r.corners[0]));
                pdf_light = dot(p, p) / (length(n) * std::fabs(dot(unit(n), s.wo)));
            }
        }
    } else if (cosine) {
        // The cosine lobe: radius sqrt(u) on the unit disc, lifted to the hemisphere.
        const double r = std::sqrt(u), phi = 2 * kPi * v;
        s.wo = {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u))};
        pdf_light = light_pdf(q.light, s.wo);
    } else {
        // Reflect wi about a visible normal (the spherical-cap sampler, Dupuy & Benyoub 2023).
        const Vec3 ws = unit({q.alpha_x * wi.x, q.alpha_y * wi.y, wi.z});
        const double phi = 2 * kPi * u;
        const double z = (1 - v) * (1 + ws.z) - ws.z;
        const double sr = std::sqrt(std::max(0.0, 1 - z * z));
        const Vec3 h{sr * std::cos(phi) + ws.x, sr * std::sin(phi) + ws.y, z + ws.z};
        const Vec3 m = unit({q.alpha_x * h.x, q.alpha_y * h.y, h.z});
        s.wo = sub(scale(m, 2 * dot(wi, m)), wi);
        pdf_light = light_pdf(q.light, s.wo);
    }
    if (!(s.wo.z > 0) || !(pdf_light > 0)) return s;
    if (cosine) {
        const double f_cos = s.wo.z / kPi;
        s.weight = f_cos / (0.5 * (pdf_light + f_cos));
        return s;
    }
    if (q.lobe == Lobe::lambert) {
        s.weight = s.wo.z / (kPi * pdf_light);
        return s;
    }
    const Vec3 h = unit(add(wi, s.wo));
    const double d = ggx_d(h, q.alpha_x, q.alpha_y);
    const double f_cos = d / ggx_denominator(wi, s.wo, q.alpha_x, q.alpha_y);
    const double p_lobe = d / (4 * (wi.z + z_lambda(wi, q.alpha_x, q.alpha_y)));
    s.weight = f_cos / (0.5 * (pdf_light + p_lobe));
    return s;
}

}  // namespace ms::area
