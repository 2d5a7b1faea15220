#include "oracle/area_light_oracle.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/cancel.hpp"
#include "core/estimate.hpp"
#include "oracle/oracle.hpp"

namespace ms::oracle {

namespace {

double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross(const Vec3& a, const Vec3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec3 normalize(const Vec3& v) {
    const double inv = 1.0 / std::sqrt(dot(v, v));
    return {v.x * inv, v.y * inv, v.z * inv};
}

// An orthonormal basis around unit n (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
void basis(const Vec3& n, Vec3& b1, Vec3& b2) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double b = n.x * n.y * a;
    b1 = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    b2 = {b, sign + n.y * n.y * a, -n.y};
}

// A sampled direction and 1 / (its solid-angle density) relative to the sampler's `measure` (below): the
// estimate is a ratio, so a factor common to every sample cancels, and dividing it out keeps the weights
// of a light of 1e-40 sr (whose densities overflow) finite. The lobe integral is multiplied back.
struct Direction {
    Vec3 wo;
    double inv_density = 0;
};

// Uniform in the cone; measure = its solid angle 2 pi (1 - cos gamma), so inv_density = 1.
Direction sample_sphere_light(const area::SphereLight& s, double u, double v) {
    const Vec3 c = normalize(s.centre);
    Vec3 b1, b2;
    basis(c, b1, b2);
    // 1 - cos(theta) = u (1 - cos gamma) with 1 - cos gamma = 2 sin^2(gamma / 2): no cancellation for a
    // narrow cone, where 1 - cos(gamma) in double is 0 below gamma ~ 1e-8.
    const double half_sin = std::sin(s.half_angle / 2);
    const double one_minus_cos_t = u * 2.0 * half_sin * half_sin;
    const double cos_t = 1.0 - one_minus_cos_t;
    const double sin_t = std::sqrt(std::fmax(0.0, one_minus_cos_t * (2.0 - one_minus_cos_t)));
    const double phi = 2.0 * kPi * v;
    Direction d;
    d.wo = normalize({sin_t * std::cos(phi) * b1.x + sin_t * std::sin(phi) * b2.x + cos_t * c.x,
                      sin_t * std::cos(phi) * b1.y + sin_t * std::sin(phi) * b2.y + cos_t * c.y,
                      sin_t * std::cos(phi) * b1.z + sin_t * std::sin(phi) * b2.z + cos_t * c.z});
    d.inv_density = 1.0;
    return d;
}

double sphere_measure(const area::SphereLight& s) {
    const double half_sin = std::sin(s.half_angle / 2);
    return 4.0 * kPi * half_sin * half_sin;
}

// The rectangle's unit normal and area, from the unit edges (the edges' own cross product underflows for
// sides of ~1e-160).
Vec3 rect_unit_normal(const area::RectLight& r, double* area) {
    const auto& p = r.corners;
    const Vec3 e1{p[1].x - p[0].x, p[1].y - p[0].y, p[1].z - p[0].z};
    const Vec3 e2{p[3].x - p[0].x, p[3].y - p[0].y, p[3].z - p[0].z};
    const double l1 = std::sqrt(dot(e1, e1)), l2 = std::sqrt(dot(e2, e2));
    const Vec3 n = cross({e1.x / l1, e1.y / l1, e1.z / l1}, {e2.x / l2, e2.y / l2, e2.z / l2});
    const double ln = std::sqrt(dot(n, n));
    if (area) *area = l1 * l2 * ln;
    return {n.x / ln, n.y / ln, n.z / ln};
}

// A rectangle far larger than its distance: uniform area sampling puts almost every sample at grazing
// directions of tiny weight and misses the few that carry it. Such a light is sampled by the cosine lobe
// of the hemisphere instead, keeping the directions that meet it (measure 1, inv_density pi / wo.z).
bool rect_is_wide(const area::RectLight& r) {
    const auto& p = r.corners;
    const Vec3 e1{p[1].x - p[0].x, p[1].y - p[0].y, p[1].z - p[0].z};
    const Vec3 e2{p[3].x - p[0].x, p[3].y - p[0].y, p[3].z - p[0].z};
    const Vec3 n = rect_unit_normal(r, nullptr);
    const double distance = std::fabs(dot(n, p[0]));
    return std::sqrt(std::fmax(dot(e1, e1), dot(e2, e2))) > 4.0 * distance;
}

Direction sample_wide_rect_light(const area::RectLight& r, double u, double v) {
    const double radius = std::sqrt(u), phi = 2.0 * kPi * v;
    Direction d;
    d.wo = {radius * std::cos(phi), radius * std::sin(phi), std::sqrt(std::fmax(0.0, 1.0 - u))};
    if (!(d.wo.z > 0)) return d;
    // The ray t wo meets the plane n.x = n.p0 at t = n.p0 / n.wo; inside when its edge coordinates are in [0, 1].
    const auto& p = r.corners;
    const Vec3 n = rect_unit_normal(r, nullptr);
    const double facing = dot(n, d.wo);
    const double t = dot(n, p[0]) / facing;
    if (!(t > 0)) return d;
    const Vec3 e1{p[1].x - p[0].x, p[1].y - p[0].y, p[1].z - p[0].z};
    const Vec3 e2{p[3].x - p[0].x, p[3].y - p[0].y, p[3].z - p[0].z};
    const Vec3 x{t * d.wo.x - p[0].x, t * d.wo.y - p[0].y, t * d.wo.z - p[0].z};
    const double a = dot(x, e1) / dot(e1, e1), b = dot(x, e2) / dot(e2, e2);
    if (a >= 0 && a <= 1 && b >= 0 && b <= 1) d.inv_density = kPi / d.wo.z;
    return d;
}

Direction sample_rect_light(const area::RectLight& r, double u, double v) {
    // Bilinear in the corners (a rectangle, so it is the affine map p0 + u e1 + v e2).
    const auto& p = r.corners;
    Vec3 x;
    x.x = (1 - u) * (1 - v) * p[0].x + u * (1 - v) * p[1].x + u * v * p[2].x + (1 - u) * v * p[3].x;
    x.y = (1 - u) * (1 - v) * p[0].y + u * (1 - v) * p[1].y + u * v * p[2].y + (1 - u) * v * p[3].y;
    x.z = (1 - u) * (1 - v) * p[0].z + u * (1 - v) * p[1].z + u * v * p[2].z + (1 - u) * v * p[3].z;
    const Vec3 n = rect_unit_normal(r, nullptr);
    const double r2 = dot(x, x);
    Direction d;
    d.wo = normalize(x);
    // dA = r^2 dw / |cos| at the light: 1 / density_w = A |cos| / r^2; measure = the area A.
    d.inv_density = std::fabs(dot(n, d.wo)) / r2;
    return d;
}

}  // namespace

double lobe_weight(const area::AreaQuery& q, const Vec3& wo) {
    if (!(wo.z > 0)) return 0.0;
    if (q.lobe == area::Lobe::lambert) return wo.z / kPi;
    const Vec3 wi = normalize(q.wi);
    const Vec3 h = normalize({wi.x + wo.x, wi.y + wo.y, wi.z + wo.z});
    const double d = ggx_ndf(h, q.alpha_x, q.alpha_y);
    const double g2 = 1.0 / (1.0 + smith_lambda(wi, q.alpha_x, q.alpha_y) + smith_lambda(wo, q.alpha_x, q.alpha_y));
    return d * g2 / (4.0 * wi.z * wo.z) * wo.z;
}

AreaTerm area_term(const area::AreaQuery& query, const TermOptions& options, const PointSet& light_points,
                   const PointSet& normal_points) {
    area::validate(query);
    if (light_points.replicates != normal_points.replicates)
        throw std::invalid_argument("oracle area term: the light and normal point sets need the same replicates");
    const area::AreaQuery q = area::normalised(query);
    const std::size_t R = light_points.replicates, J = light_points.points_per_replicate;
    const std::size_t M = normal_points.points_per_replicate;
    std::vector<double> numerator(R, 0.0), denominator(R, 0.0);
    const bool sphere = q.light.shape == area::LightShape::sphere;
    const bool wide = !sphere && rect_is_wide(q.light.rect);
    double measure = 1.0;
    if (sphere) measure = sphere_measure(q.light.sphere);
    else if (!wide) rect_unit_normal(q.light.rect, &measure);
    for (std::size_t r = 0; r < R; ++r) {
        // Replicate r of the inner points as a point set of its own.
        PointSet inner;
        inner.sequence = normal_points.sequence;
        inner.replicates = 1;
        inner.points_per_replicate = std::uint32_t(M);
        inner.u1.assign(normal_points.u1.begin() + r * M, normal_points.u1.begin() + (r + 1) * M);
        inner.u2.assign(normal_points.u2.begin() + r * M, normal_points.u2.begin() + (r + 1) * M);
        for (std::size_t j = 0; j < J; ++j) {
            throw_if_cancelled();
            const double u = light_points.u1[r * J + j], v = light_points.u2[r * J + j];
            const Direction d = sphere ? sample_sphere_light(q.light.sphere, u, v)
                                : wide ? sample_wide_rect_light(q.light.rect, u, v) : sample_rect_light(q.light.rect, u, v);
            const double w = lobe_weight(q, d.wo) * d.inv_density;
            if (!(w > 0)) continue;
            Query point;
            point.visibility = q.visibility;
            point.alpha_x = q.alpha_x;
            point.alpha_y = q.alpha_y;
            point.wi = q.wi;
            point.wo = d.wo;
            const Tally t = tally(point, options, inner);
            const double term = t.hemisphere[0] > 0 ? t.cone[0] / t.hemisphere[0] : 0.0;
            numerator[r] += w * term;
            denominator[r] += w;
        }
    }
    AreaTerm out;
    out.term = reduce_replicates(numerator.data(), denominator.data(), R);
    std::vector<double> ones(R, double(J));
    out.lobe_integral = reduce_replicates(denominator.data(), ones.data(), R);
    out.lobe_integral.term *= measure;
    out.lobe_integral.std_error *= measure;
    return out;
}

}  // namespace ms::oracle
