#include "jobs/area.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>

#include "exact/exact_term.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "io/csv.hpp"

namespace ms::area {

const std::vector<std::string> kSphereColumns = {"visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z",
                                                 "light_x", "light_y", "light_z", "half_angle_deg"};
const std::vector<std::string> kRectColumns = {"visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z",
                                               "p0_x", "p0_y", "p0_z", "p1_x", "p1_y", "p1_z",
                                               "p2_x", "p2_y", "p2_z", "p3_x", "p3_y", "p3_z"};

std::vector<AreaQuery> read_area_csv(const std::string& path, LightShape shape, Lobe lobe,
                                     std::vector<std::vector<double>>* raw) {
    const NumericCsv table = read_numeric_csv(path, shape == LightShape::sphere ? kSphereColumns : kRectColumns);
    std::vector<AreaQuery> queries;
    queries.reserve(table.rows.size());
    for (std::size_t i = 0; i < table.rows.size(); ++i) {
        const auto& r = table.rows[i];
        const std::string where = path + ":" + std::to_string(table.lines[i]) + " (row " + std::to_string(i + 1) + "): ";
        AreaQuery q;
        q.visibility = r[0];
        q.alpha_x = r[1];
        q.alpha_y = r[2];
        q.wi = {r[3], r[4], r[5]};
        q.lobe = lobe;
        q.light.shape = shape;
        if (shape == LightShape::sphere) {
            q.light.sphere.centre = {r[6], r[7], r[8]};
            // Checked in degrees as written, so the message quotes the file's value.
            if (!(r[9] > 0 && r[9] < 90))
                throw CsvError(where + "column 'half_angle_deg': " + format_number(r[9]) + " must be in (0, 90) degrees");
            q.light.sphere.half_angle = radians(r[9]);
        } else {
            for (int k = 0; k < 4; ++k) q.light.rect.corners[k] = {r[6 + 3 * k], r[7 + 3 * k], r[8 + 3 * k]};
        }
        try {
            validate(q);
        } catch (const std::invalid_argument& e) {
            throw CsvError(where + e.what());
        }
        queries.push_back(q);
    }
    if (raw) *raw = table.rows;
    return queries;
}

std::vector<AreaEstimate> evaluate_area(TermBackend& backend, const std::vector<AreaQuery>& queries,
                                        const TermOptions& options, const SamplingPlan& plan, AreaRoutineConfig config,
                                        AreaEvalStats* stats, const std::function<void(std::size_t, std::size_t)>& progress) {
    const auto start = std::chrono::steady_clock::now();
    if (queries.empty()) return {};
    if (!config.inner_term) config.build = backend.config().build;
    const std::size_t per_item = area_queries_per_item(backend.scheduler().is_oracle(), plan, config);
    AreaIntegrand integrand(queries, options, plan, config, per_item);
    schedule::RunCallbacks callbacks;
    if (progress)
        callbacks.progress = [&](std::uint64_t done, std::uint64_t) {
            progress(std::min<std::size_t>(queries.size(), std::size_t(done * per_item)), queries.size());
        };
    const schedule::RunReport report = backend.scheduler().run(integrand, {}, callbacks);
    if (stats) {
        stats->sampled = integrand.stats().sampled;
        stats->below_horizon = integrand.stats().below_horizon;
        stats->zero_region = integrand.stats().zero_region;
        stats->visibility_one = integrand.stats().visibility_one;
        stats->rerun = report.rerun;
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return integrand.results();
}

InnerTerm exact_inner_term(AoWeighting weighting, double tolerance) {
    return [weighting, tolerance](const Query& q) {
        const exact::ExactValue v = exact::exact_term(q, weighting, tolerance);
        return InnerValue(v.term, v.error);
    };
}

namespace {
double angle_between(const Vec3& a, const Vec3& b) {
    const Vec3 c = cross(a, b);
    return std::atan2(std::hypot(c.x, c.y, c.z), dot(a, b));
}
// The unit direction at angle t from unit a on the great circle towards unit b (slerp by angle).
Vec3 towards(const Vec3& a, const Vec3& b, double t) {
    const double total = angle_between(a, b);
    if (!(total > 0)) return a;
    const double sa = std::sin(total - t) / std::sin(total), sb = std::sin(t) / std::sin(total);
    return unit({sa * a.x + sb * b.x, sa * a.y + sb * b.y, sa * a.z + sb * b.z});
}
}  // namespace

TapCone tap_cone(const AreaQuery& query) {
    const AreaQuery q = normalised(query);
    const Vec3 c = q.light.sphere.centre;
    const double gamma = q.light.sphere.half_angle;
    if (q.lobe == Lobe::lambert) return {c, gamma};
    // 80 % of GGX's half vectors lie within atan(2 alpha) of the normal (P = tan^2 / (alpha^2 + tan^2));
    // the reflected lobe is about twice as wide.
    // When the mirror direction R is outside the light, the light sees the lobe's tail, which falls
    // off over the angle d between R and the light (D ~ d^-4): the tap cone is then at least d wide.
    const Vec3 wi = q.wi;
    const Vec3 mirror{-wi.x, -wi.y, wi.z};
    const double outside = std::max(0.0, angle_between(c, mirror) - gamma);
    const double lobe = std::max(2 * std::atan(2 * std::sqrt(q.alpha_x * q.alpha_y)), outside);
    if (lobe >= gamma) return {c, gamma};
    // From Karis's point, pulled towards the centre until the tap cone lies inside the light.
    const Vec3 r = representative_direction(q);
    const double off = angle_between(c, r), limit = gamma - lobe;
    return {off <= limit ? r : towards(c, r, limit), lobe};
}

std::vector<Tap> sphere_taps(const AreaQuery& query) {
    if (query.light.shape != LightShape::sphere) throw std::invalid_argument("the tap approximation is for sphere lights");
    const AreaQuery q = normalised(query);
    const TapCone cone = tap_cone(q);
    const Vec3 c = cone.centre;
    const Vec3 helper = std::fabs(c.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
    const Vec3 t1 = unit(cross(helper, c)), t2 = cross(c, t1);
    // Equal-area map of the unit disc onto the cone: disc radius rho -> 1 - cos(theta) = rho^2 (1 - cos radius).
    const double sh = std::sin(cone.half_angle / 2);
    const double one_minus_cos_radius = 2 * sh * sh;
    const Vec3 light = q.light.sphere.centre;
    const double cos_gamma = std::cos(q.light.sphere.half_angle);
    std::vector<Tap> taps;
    auto add = [&](double rho, double phi, double rule_weight) {
        const double one_minus_cos = rho * rho * one_minus_cos_radius;
        const double sin_t = std::sqrt(std::max(0.0, one_minus_cos * (2 - one_minus_cos)));
        const double cos_t = 1 - one_minus_cos;
        const Vec3 wo = unit({sin_t * (std::cos(phi) * t1.x + std::sin(phi) * t2.x) + cos_t * c.x,
                              sin_t * (std::cos(phi) * t1.y + std::sin(phi) * t2.y) + cos_t * c.y,
                              sin_t * (std::cos(phi) * t1.z + std::sin(phi) * t2.z) + cos_t * c.z});
        // The tap cone lies inside the light up to rounding; a tap outside it would not be the light's.
        const bool inside = dot(wo, light) >= cos_gamma - 1e-12;
        taps.push_back({wo, inside ? rule_weight * lobe_weight(q, wo) : 0.0});
    };
    add(0, 0, 0.25);
    for (int k = 0; k < 6; ++k) add(std::sqrt(2.0 / 3.0), k * kPi / 3, 0.125);
    return taps;
}

std::vector<Tap> rect_taps(const AreaQuery& query) {
    if (query.light.shape != LightShape::rect) throw std::invalid_argument("rect_taps is for rectangle lights");
    const AreaQuery q = normalised(query);
    const auto& k = q.light.rect.corners;
    const Vec3 p0 = k[0];
    const Vec3 e1{k[1].x - k[0].x, k[1].y - k[0].y, k[1].z - k[0].z}, e2{k[3].x - k[0].x, k[3].y - k[0].y, k[3].z - k[0].z};
    auto at = [&](double u, double v) { return Vec3{p0.x + u * e1.x + v * e2.x, p0.y + u * e1.y + v * e2.y, p0.z + u * e1.z + v * e2.z}; };
    const Vec3 n = unit(cross(e1, e2));
    double u0 = 0, u1 = 1, v0 = 0, v1 = 1;
    if (q.lobe == Lobe::ggx) {
        // As tap_cone: the lobe's angle (or the angle from the mirror direction to the light, when it misses).
        const Vec3 wi = q.wi;
        const Vec3 mirror{-wi.x, -wi.y, wi.z};
        const Vec3 r = representative_direction(q);
        const double lobe = std::max(2 * std::atan(2 * std::sqrt(q.alpha_x * q.alpha_y)), angle_between(r, mirror));
        const Vec3 c = centre_direction(q.light);
        double radius = 0;
        for (int j = 0; j < 4; ++j) radius = std::max(radius, angle_between(c, unit(k[j])));
        if (lobe < radius) {
            // The representative point's rectangle coordinates, and the half-extents d tan(lobe) / side.
            const double t = std::fabs(dot(n, p0)) / std::fabs(dot(n, r));
            const Vec3 hit{r.x * t - p0.x, r.y * t - p0.y, r.z * t - p0.z};
            const double ur = dot(hit, e1) / dot(e1, e1), vr = dot(hit, e2) / dot(e2, e2);
            const double reach = t * std::tan(lobe);
            const double hu = std::min(0.5, reach / std::sqrt(dot(e1, e1))), hv = std::min(0.5, reach / std::sqrt(dot(e2, e2)));
            const double uc = std::clamp(ur, hu, 1 - hu), vc = std::clamp(vr, hv, 1 - hv);
            u0 = uc - hu, u1 = uc + hu, v0 = vc - hv, v1 = vc + hv;
        }
    }
    // Gauss-Legendre, 3 points on [0, 1]: nodes 1/2 -+ sqrt(3/5)/2, weights 5/18, 8/18, 5/18.
    const double nodes[3] = {0.5 - 0.5 * std::sqrt(0.6), 0.5, 0.5 + 0.5 * std::sqrt(0.6)};
    const double weights[3] = {5.0 / 18, 8.0 / 18, 5.0 / 18};
    std::vector<Tap> taps;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            const Vec3 p = at(u0 + (u1 - u0) * nodes[a], v0 + (v1 - v0) * nodes[b]);
            const double d2 = dot(p, p);
            const Vec3 wo = unit(p);
            const double solid_angle_per_area = std::fabs(dot(n, wo)) / d2;
            taps.push_back({wo, weights[a] * weights[b] * solid_angle_per_area * lobe_weight(q, wo)});
        }
    return taps;
}

std::vector<StudyPoint> grid_points(const StudyGrid& g) {
    std::vector<StudyPoint> points;
    for (Lobe lobe : g.lobes)
        for (double gamma : g.half_angles_deg)
            for (double rough : g.roughness)
                for (double v : g.visibility)
                    for (double nv : g.n_dot_v)
                        for (double e : g.elevations_deg)
                            for (double phi : g.azimuths_deg) {
                                StudyPoint p;
                                p.n_dot_v = nv, p.elevation_deg = e, p.azimuth_deg = phi, p.roughness = rough, p.half_angle_deg = gamma;
                                AreaQuery& q = p.query;
                                q.lobe = lobe;
                                q.visibility = v;
                                q.alpha_x = q.alpha_y = rough * rough;
                                q.wi = {std::sqrt(std::max(0.0, 1 - nv * nv)), 0, nv};
                                const double el = radians(e), az = radians(phi);
                                q.light.shape = LightShape::sphere;
                                q.light.sphere.centre = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
                                q.light.sphere.half_angle = radians(gamma);
                                points.push_back(p);
                            }
    return points;
}

std::vector<StudyPoint> random_points(std::size_t count, double max_half_angle_deg, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<StudyPoint> points;
    for (std::size_t i = 0; i < count; ++i) {
        StudyGrid g;
        g.lobes = {u(rng) < 0.5 ? Lobe::lambert : Lobe::ggx};
        g.half_angles_deg = {std::max(1e-3, max_half_angle_deg * u(rng))};
        g.roughness = {0.1 + 0.9 * u(rng)};
        g.visibility = {0.05 + 0.93 * u(rng)};
        g.n_dot_v = {0.1 + 0.9 * u(rng)};
        g.elevations_deg = {-g.half_angles_deg[0] + (90 + g.half_angles_deg[0]) * u(rng)};
        g.azimuths_deg = {360 * u(rng)};
        points.push_back(grid_points(g).front());
    }
    return points;
}

std::vector<StudyPoint> random_rect_points(std::size_t count, double max_half_angle_deg, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<StudyPoint> points;
    for (std::size_t i = 0; i < count; ++i) {
        StudyPoint p;
        AreaQuery& q = p.query;
        q.lobe = u(rng) < 0.5 ? Lobe::lambert : Lobe::ggx;
        p.half_angle_deg = std::max(1e-3, max_half_angle_deg * u(rng));
        p.roughness = 0.1 + 0.9 * u(rng);
        q.visibility = 0.05 + 0.93 * u(rng);
        p.n_dot_v = 0.1 + 0.9 * u(rng);
        p.elevation_deg = -p.half_angle_deg + (90 + p.half_angle_deg) * u(rng);
        p.azimuth_deg = 360 * u(rng);
        q.alpha_x = q.alpha_y = p.roughness * p.roughness;
        q.wi = {std::sqrt(std::max(0.0, 1 - p.n_dot_v * p.n_dot_v)), 0, p.n_dot_v};
        const double el = radians(p.elevation_deg), az = radians(p.azimuth_deg);
        const Vec3 c{std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
        const Vec3 helper = std::fabs(c.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
        const Vec3 t1 = unit(cross(helper, c)), t2 = cross(c, t1);
        const double tilt = radians(60) * u(rng), turn = 2 * kPi * u(rng), spin = 2 * kPi * u(rng);
        const double ct = std::cos(tilt), st = std::sin(tilt);
        const Vec3 n{ct * c.x + st * (std::cos(turn) * t1.x + std::sin(turn) * t2.x),
                     ct * c.y + st * (std::cos(turn) * t1.y + std::sin(turn) * t2.y),
                     ct * c.z + st * (std::cos(turn) * t1.z + std::sin(turn) * t2.z)};
        const Vec3 h2 = std::fabs(n.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
        const Vec3 b1 = unit(cross(h2, n)), b2 = cross(n, b1);
        const Vec3 a1{std::cos(spin) * b1.x + std::sin(spin) * b2.x, std::cos(spin) * b1.y + std::sin(spin) * b2.y,
                      std::cos(spin) * b1.z + std::sin(spin) * b2.z};
        const Vec3 a2 = cross(n, a1);
        const double ratio = 1 + 2 * u(rng);
        auto corners = [&](double s) {
            std::array<Vec3, 4> k;
            const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
            for (int j = 0; j < 4; ++j)
                k[j] = {c.x + s * (sx[j] * ratio * a1.x + sy[j] * a2.x), c.y + s * (sx[j] * ratio * a1.y + sy[j] * a2.y),
                        c.z + s * (sx[j] * ratio * a1.z + sy[j] * a2.z)};
            return k;
        };
        auto widest = [&](double s) {
            double w = 0;
            for (const Vec3& k : corners(s)) w = std::max(w, angle_between(c, unit(k)));
            return w;
        };
        // The widest corner angle grows with the scale (towards 90 degrees): bisection for gamma.
        const double gamma = radians(p.half_angle_deg);
        double lo = 0, hi = 1;
        while (widest(hi) < gamma) hi *= 2;
        for (int it = 0; it < 80; ++it) (widest(0.5 * (lo + hi)) < gamma ? lo : hi) = 0.5 * (lo + hi);
        q.light.shape = LightShape::rect;
        q.light.rect.corners = corners(0.5 * (lo + hi));
        points.push_back(p);
    }
    return points;
}

std::vector<StudyRow> run_study(TermBackend& backend, const std::vector<StudyPoint>& points, const TermOptions& options,
                                const SamplingPlan& plan, const std::function<void(std::size_t, std::size_t)>& progress) {
    std::vector<AreaQuery> area_queries;
    for (const StudyPoint& p : points) area_queries.push_back(p.query);
    const std::vector<AreaEstimate> area = evaluate_area(backend, area_queries, options, plan, {}, nullptr, progress);
    // Point terms: centre, representative point, seven taps per point (a light below the horizon is a
    // legal point query and gives 0).
    std::vector<Query> point_queries;
    std::vector<std::vector<Tap>> taps;
    std::vector<std::size_t> first_query;  // of each point: centre, representative point, then its taps
    for (const StudyPoint& p : points) {
        const AreaQuery q = normalised(p.query);
        first_query.push_back(point_queries.size());
        Query base;
        base.visibility = q.visibility;
        base.alpha_x = q.alpha_x;
        base.alpha_y = q.alpha_y;
        base.wi = q.wi;
        base.wo = centre_direction(q.light);
        point_queries.push_back(base);
        base.wo = representative_direction(q);
        point_queries.push_back(base);
        taps.push_back(q.light.shape == LightShape::sphere ? sphere_taps(q) : rect_taps(q));
        for (const Tap& t : taps.back()) {
            base.wo = t.wo;
            point_queries.push_back(base);
        }
    }
    const std::vector<Estimate> terms = evaluate(backend, point_queries, options, plan);
    std::vector<StudyRow> rows(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        const Estimate* t = &terms[first_query[i]];
        StudyRow& row = rows[i];
        row.point = points[i];
        row.area = area[i];
        row.centre = t[0];
        row.representative = t[1];
        double num = 0, den = 0, se = 0;
        const std::size_t count = taps[i].size();
        for (std::size_t k = 0; k < count; ++k) den += taps[i][k].weight;
        for (std::size_t k = 0; k < count; ++k) {
            num += taps[i][k].weight * t[2 + k].term;
            // The taps share one point set, so their errors are correlated: sum w_k se_k bounds the
            // standard error of the weighted mean whatever the correlation (Cauchy-Schwarz).
            se += (den > 0 ? taps[i][k].weight / den : 0.0) * t[2 + k].std_error;
        }
        row.taps = {den > 0 ? num / den : 0.0, se};
    }
    return rows;
}

}  // namespace ms::area
