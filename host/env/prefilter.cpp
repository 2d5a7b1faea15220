#include "env/prefilter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "core/estimate.hpp"

namespace ms::env {

namespace {

struct Frame {
    Dir t, b, n;
};
Frame frame_of(const Dir& n) {
    // Duff et al. 2017 branchless orthonormal basis.
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z), b = n.x * n.y * a;
    return {{1 + sign * n.x * n.x * a, sign * b, -sign * n.x}, {b, sign + n.y * n.y * a, -n.y}, n};
}
}  // namespace

RoughnessMapping parse_roughness_mapping(const std::string& s) {
    if (s == "cmgen") return RoughnessMapping::cmgen;
    if (s == "linear") return RoughnessMapping::linear;
    throw std::invalid_argument("roughness mapping must be cmgen or linear, not '" + s + "'");
}
std::string to_string(RoughnessMapping m) { return m == RoughnessMapping::cmgen ? "cmgen" : "linear"; }

double mip_roughness(std::uint32_t mip, std::uint32_t levels, RoughnessMapping mapping) {
    if (levels < 2) return 0;
    const double t = double(mip) / double(levels - 1);
    return mapping == RoughnessMapping::cmgen ? 1 - std::sqrt(std::max(0.0, 1 - t)) : t;
}

double ggx_d(double c, double alpha) {
    const double a2 = alpha * alpha;
    const double d = (a2 - 1) * c * c + 1;
    return a2 / (kPi * d * d);
}

void PrefilterSums::add(const PrefilterSums& other) {
    if (other.den.size() != den.size()) throw std::invalid_argument("PrefilterSums::add: replicate counts differ");
    for (std::size_t i = 0; i < num.size(); ++i) num[i] += other.num[i];
    for (std::size_t i = 0; i < den.size(); ++i) den[i] += other.den[i];
}

PrefilterValue prefilter_value(const PrefilterSums& sums, const std::array<double, 3>& exact_part) {
    const std::uint32_t R = sums.replicates();
    std::vector<double> num(R);
    PrefilterValue out;
    for (int k = 0; k < 3; ++k) {
        for (std::uint32_t r = 0; r < R; ++r) num[r] = sums.num[3 * std::size_t(r) + k];
        const Estimate e = reduce_replicates(num.data(), sums.den.data(), R);
        out.value[k] = e.term + exact_part[k];
        out.std_error[k] = e.std_error;
    }
    return out;
}

PrefilterValue prefilter_direction(const std::vector<Cubemap>& chain, const Dir& n, double roughness, const PointSet& points,
                                   const PrefilterOptions& options) {
    PrefilterSums sums(points.replicates);
    prefilter_sums(chain, n, roughness, points, options, sums);
    return prefilter_value(sums);
}

void prefilter_sums(const std::vector<Cubemap>& chain, const Dir& n, double roughness, const PointSet& points,
                    const PrefilterOptions& options, PrefilterSums& sums) {
    if (!(roughness > 0)) throw std::invalid_argument("prefilter_direction: roughness > 0 (roughness 0 is the source)");
    if (sums.replicates() != points.replicates) throw std::invalid_argument("prefilter_sums: replicate counts differ");
    const double alpha = roughness * roughness, a2 = alpha * alpha;
    const Frame f = frame_of(n);
    const std::uint32_t R = points.replicates, np = points.points_per_replicate;
    const double omega_p = 4.0 / (double(chain[0].size) * chain[0].size);  // a texel at a face's centre
    const double total = double(points.total());
    for (std::uint32_t r = 0; r < R; ++r)
        for (std::uint32_t i = 0; i < np; ++i) {
            const double u1 = points.u1[std::size_t(r) * np + i], u2 = points.u2[std::size_t(r) * np + i];
            // h from D(h) (n.h): cos^2 = (1 - u2) / (1 + (alpha^2 - 1) u2), phi = 2 pi u1.
            const double c2 = (1 - u2) / (1 + (a2 - 1) * u2);
            const double c = std::sqrt(c2), s = std::sqrt(std::max(0.0, 1 - c2));
            const double n_dot_l = 2 * c2 - 1;
            if (n_dot_l <= 0) continue;
            const double phi = 2 * kPi * u1;
            const double lx = 2 * c * s * std::cos(phi), ly = 2 * c * s * std::sin(phi);
            const Dir l{lx * f.t.x + ly * f.b.x + n_dot_l * n.x, lx * f.t.y + ly * f.b.y + n_dot_l * n.y,
                        lx * f.t.z + ly * f.b.z + n_dot_l * n.z};
            double lod = 0;
            if (options.filtered) {
                // Omega_p: the solid angle of a full-resolution texel where l lands, (2/n)^2 / (1 + s^2 + t^2)^(3/2)
                // on its face (1.9x the mean at a face's centre, 0.37x at its corners).
                int face;
                double fs, ft;
                cube_face_st(l, face, fs, ft);
                const double q = 1 + fs * fs + ft * ft;
                const double omega_l = omega_p / (q * std::sqrt(q));
                const double pdf = ggx_d(c, alpha) / 4;
                lod = std::max(0.0, 0.5 * std::log2(1 / (total * pdf) / omega_l) + options.lod_bias);
            }
            const auto v = sample_trilinear(chain, l, lod);
            for (int k = 0; k < 3; ++k) sums.num[3 * std::size_t(r) + k] += v[k] * n_dot_l;
            sums.den[r] += n_dot_l;
        }
}

namespace {
double luminance(const float* v) { return (double(v[0]) + v[1] + v[2]) / 3; }

// Every source texel's luminance and solid angle, and the brightest `max_texels` of them, brightest first.
struct TexelStats {
    std::vector<double> omega;  // per (y, x) of a face
    double power = 0, second_moment = 0;  // int lum dl, int lum^2 dl
    std::vector<std::pair<double, BrightTexel>> brightest;
};
TexelStats texel_stats(const Cubemap& source, double min_luminance, std::size_t max_texels) {
    TexelStats s;
    const std::uint32_t n = source.size;
    s.omega.resize(std::size_t(n) * n);
    for (std::uint32_t y = 0; y < n; ++y)
        for (std::uint32_t x = 0; x < n; ++x) s.omega[std::size_t(y) * n + x] = cube_texel_solid_angle(x, y, n);
    std::vector<std::pair<double, BrightTexel>> candidates;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const float* v = source.texel(f, x, y);
                const double l = luminance(v), w = s.omega[std::size_t(y) * n + x];
                s.power += l * w;
                s.second_moment += l * l * w;
                if (l > min_luminance) candidates.push_back({l, {f, x, y, {v[0], v[1], v[2]}}});
            }
    // The brightest first, so a cap keeps the texels that matter most (ties in scan order: deterministic).
    const std::size_t keep = std::min(max_texels, candidates.size());
    std::partial_sort(candidates.begin(), candidates.begin() + std::ptrdiff_t(keep), candidates.end(), [](const auto& a, const auto& b) {
        if (a.first != b.first) return a.first > b.first;
        if (a.second.face != b.second.face) return a.second.face < b.second.face;
        return a.second.y != b.second.y ? a.second.y < b.second.y : a.second.x < b.second.x;
    });
    candidates.resize(keep);
    s.brightest = std::move(candidates);
    return s;
}

void add_bright_texel_geometry(BrightTexelGeometry& g, const BrightTexel& t, std::uint32_t size) {
    const Dir c = cube_direction(t.face, 2 * (t.x + 0.5) / size - 1, 2 * (t.y + 0.5) / size - 1);
    g.x[0].push_back(c.x), g.y[0].push_back(c.y), g.z[0].push_back(c.z);
    g.weight[0].push_back(cube_texel_solid_angle(t.x, t.y, size));
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
            // A quarter's centre in the face plane; its solid angle (1/size)^2 / (1 + s^2 + t^2)^(3/2).
            const double ps = 2 * (t.x + 0.25 + 0.5 * i) / size - 1, pt = 2 * (t.y + 0.25 + 0.5 * j) / size - 1;
            const double q = 1 + ps * ps + pt * pt;
            const Dir d = cube_direction(t.face, ps, pt);
            const int p = 1 + 2 * j + i;
            g.x[p].push_back(d.x), g.y[p].push_back(d.y), g.z[p].push_back(d.z);
            g.weight[p].push_back(1.0 / (double(size) * size) / (q * std::sqrt(q)));
        }
}

BrightSplit split_off(const Cubemap& source, const TexelStats& stats, std::size_t count, double threshold) {
    BrightSplit split;
    split.size = source.size;
    split.threshold = threshold;
    split.mean_radiance = stats.power / (4 * kPi);
    Cubemap rest = source;
    double bright_power = 0;
    for (std::size_t i = 0; i < count && i < stats.brightest.size(); ++i) {
        const BrightTexel& b = stats.brightest[i].second;
        split.texels.push_back(b);
        add_bright_texel_geometry(split.geometry, b, source.size);
        float* t = rest.texel(b.face, b.x, b.y);
        bright_power += luminance(t) * stats.omega[std::size_t(b.y) * source.size + b.x];
        t[0] = t[1] = t[2] = 0;
    }
    split.bright_power_fraction = stats.power > 0 ? bright_power / stats.power : 0;
    split.rest_chain = mip_chain(rest);
    // The bright texels alone, and every texel a bilinear read of one can reach: its 3 x 3 neighbourhood, a
    // neighbour past the face's edge found through its direction (as sample_bilinear finds it).
    split.bright_only = Cubemap(source.size);
    std::set<std::array<std::uint32_t, 3>> support;
    const std::uint32_t n = source.size;
    for (const BrightTexel& b : split.texels) {
        float* t = split.bright_only.texel(b.face, b.x, b.y);
        for (int c = 0; c < 3; ++c) t[c] = b.value[c];
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const int x = int(b.x) + dx, y = int(b.y) + dy;
                if (x >= 0 && y >= 0 && x < int(n) && y < int(n)) {
                    support.insert({std::uint32_t(b.face), std::uint32_t(x), std::uint32_t(y)});
                    continue;
                }
                const Dir e = cube_direction(b.face, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                int face;
                double es, et;
                cube_face_st(e, face, es, et);
                const auto clampi = [&](double v) { return std::uint32_t(std::clamp(int(std::floor((v + 1) * 0.5 * n)), 0, int(n) - 1)); };
                support.insert({std::uint32_t(face), clampi(es), clampi(et)});
            }
    }
    for (const auto& s : support) {
        SupportTexel t;
        t.face = int(s[0]);
        t.x = s[1];
        t.y = s[2];
        t.centre = cube_direction(t.face, 2 * (t.x + 0.5) / n - 1, 2 * (t.y + 0.5) / n - 1);
        split.support.push_back(t);
    }
    return split;
}
}  // namespace

BrightSplit split_bright_texels(const Cubemap& source, double threshold, std::size_t max_texels) {
    // The mean radiance first (the threshold is relative to it), then the texels above threshold x mean.
    const TexelStats all = texel_stats(source, std::numeric_limits<double>::infinity(), 0);
    const double mean = all.power / (4 * kPi);
    const TexelStats stats = threshold > 0 ? texel_stats(source, threshold * mean, max_texels) : all;
    return split_off(source, stats, stats.brightest.size(), threshold);
}

BrightSplit choose_bright_split(const Cubemap& source, double tolerance, std::size_t max_texels, double explicit_cost_ratio) {
    if (!(tolerance > 0)) throw std::invalid_argument("choose_bright_split: tolerance must be > 0");
    const TexelStats stats = texel_stats(source, 0.0, max_texels);
    const double mean = stats.power / (4 * kPi);
    // cost(k) over k = 0 .. the candidates, the rest's moments by running subtraction (in long double: the
    // moments of the rest are differences of nearly equal sums once most of the power is removed).
    long double power = stats.power, second = stats.second_moment;
    std::size_t best_k = 0;
    double best_cost = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0;; ++k) {
        const double cv2 = power > 0 ? std::max(0.0, double(4 * kPi * second / (power * power)) - 1) : 0.0;
        const double cost = cv2 / (tolerance * tolerance) + explicit_cost_ratio * double(k);
        if (cost < best_cost) best_cost = cost, best_k = k;
        if (k == stats.brightest.size() || power <= 0) break;
        const BrightTexel& b = stats.brightest[k].second;
        const double l = stats.brightest[k].first, w = stats.omega[std::size_t(b.y) * source.size + b.x];
        power -= l * w;
        second -= l * l * w;
    }
    const double threshold = best_k > 0 && mean > 0 ? stats.brightest[best_k - 1].first / mean : 0.0;
    return split_off(source, stats, best_k, threshold);
}

double ggx_prefilter_normalisation(double alpha) {
    const double b = alpha * alpha - 1, us = 1 / (1 + alpha * alpha);
    if (std::abs(b) > 1e-3) return 4 * (-2 * us / b + 2 * (1 + 1 / b) * std::log1p(b * us) / b - us);
    // Near alpha = 1 the closed form cancels: the integrand is smooth there, 16-point Gauss-Legendre on [0, u*].
    static const double x[8] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274, 0.6178762444026438,
                                0.7554044083550030, 0.8656312023878318, 0.9445750230732326, 0.9894009349916499};
    static const double w[8] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025, 0.1495959888165767,
                                0.1246289712555339, 0.0951585116824928, 0.0622535239386479, 0.0271524594117541};
    double sum = 0;
    for (int i = 0; i < 8; ++i)
        for (double sign : {-1.0, 1.0}) {
            const double u = 0.5 * us * (1 + sign * x[i]);
            sum += w[i] * (2 * (1 - u) / (1 + b * u) - 1);
        }
    return 4 * 0.5 * us * sum;
}

PrefilterValue prefilter_direction_split(const BrightSplit& split, const Dir& n, double roughness, const PointSet& points,
                                         const PrefilterOptions& options) {
    PrefilterSums sums(points.replicates);
    prefilter_sums(split.rest_chain, n, roughness, points, options, sums);
    return prefilter_value(sums, bright_texel_share(split, n, roughness));
}

BrightShare bright_texel_share_bounded(const BrightSplit& split, const Dir& n, double roughness) {
    BrightShare out;
    if (split.texels.empty()) return out;
    const double alpha = roughness * roughness, a2 = alpha * alpha;
    const std::uint32_t size = split.size;
    // The same two regimes as the oracle (so the split is exact against it: oracle(L) = oracle(L_rest) +
    // oracle(L_bright)): while the lobe is narrow against a texel, texels whose centre is within
    // 3 (alpha + texel) of n are integrated on m x m sub-directions with bilinear reads (of the bright texels
    // alone, so the reads see them through their neighbours and across seams as the sampled part does); the
    // others take one point at their centre with their exact solid angle (a texel the horizon cuts is counted
    // wholly or not at all: the 2 x 2 check's difference shows it in the bound).
    const double texel_angle = 2.0 / size;
    const double near_cos = alpha < 8 * texel_angle ? std::cos(std::min(kPi / 2, 3 * (alpha + texel_angle))) : 2.0;
    const int m = 8;
    std::array<double, 3> rule_error{}, magnitude{};
    auto add = [&](double w, double w_check, const float* v) {
        for (int c = 0; c < 3; ++c) {
            out.share[c] += w * v[c];
            rule_error[c] += std::abs(w - w_check) * v[c];
            magnitude[c] += std::abs(w) * v[c];
        }
    };
    // Far part: the bright texels outside the near cap, centre rule, checked by the 2 x 2 midpoint rule (the
    // difference estimates the rule's error, the lobe's curvature across the texel). (n.l) D(h) with
    // (n.h)^2 = (1 + n.l) / 2, branch-free so the loop vectorises; a2 / pi applied after.
    const BrightTexelGeometry& g = split.geometry;
    auto weight = [&](int p, std::size_t b) {
        const double nl = n.x * g.x[p][b] + n.y * g.y[p][b] + n.z * g.z[p][b];
        const double d = (a2 - 1) * (1 + nl) * 0.5 + 1;
        return std::max(nl, 0.0) * g.weight[p][b] / (d * d);
    };
    for (std::size_t b = 0; b < split.texels.size(); ++b) {
        const double nl = n.x * g.x[0][b] + n.y * g.y[0][b] + n.z * g.z[0][b];
        if (nl > near_cos) continue;  // in the near part
        const double w = weight(0, b) * a2 / kPi;
        const double w_check = (weight(1, b) + weight(2, b) + weight(3, b) + weight(4, b)) * a2 / kPi;
        if (w != 0 || w_check != 0) add(w, w_check, split.texels[b].value.data());
    }
    // Near part: every texel a bilinear read of a bright texel can reach (the support), inside the near cap, on
    // m x m sub-directions (checked by the m/2 x m/2 rule).
    for (const SupportTexel& t : split.support) {
            const double nl = n.x * t.centre.x + n.y * t.centre.y + n.z * t.centre.z;
            if (nl <= near_cos) continue;
            double acc[3] = {0, 0, 0}, check[3] = {0, 0, 0};
            const double dw = cube_texel_solid_angle(t.x, t.y, size) / (double(m) * m);
            for (int j = 0; j < m; ++j)
                for (int i = 0; i < m; ++i) {
                    const Dir d = cube_direction(t.face, 2 * (t.x + (i + 0.5) / m) / size - 1, 2 * (t.y + (j + 0.5) / m) / size - 1);
                    const double c = n.x * d.x + n.y * d.y + n.z * d.z;
                    if (c <= 0) continue;
                    const double dd = (a2 - 1) * (1 + c) * 0.5 + 1;
                    const double w = c * a2 / (kPi * dd * dd) * dw;
                    const auto v = sample_bilinear(split.bright_only, d);
                    for (int k = 0; k < 3; ++k) acc[k] += w * v[k];
                }
            // The coarser rule: the (m/2)^2 sub-directions of the same texel.
            const int h = m / 2;
            const double dwh = cube_texel_solid_angle(t.x, t.y, size) / (double(h) * h);
            for (int j = 0; j < h; ++j)
                for (int i = 0; i < h; ++i) {
                    const Dir d = cube_direction(t.face, 2 * (t.x + (i + 0.5) / h) / size - 1, 2 * (t.y + (j + 0.5) / h) / size - 1);
                    const double c = n.x * d.x + n.y * d.y + n.z * d.z;
                    if (c <= 0) continue;
                    const double dd = (a2 - 1) * (1 + c) * 0.5 + 1;
                    const double w = c * a2 / (kPi * dd * dd) * dwh;
                    const auto v = sample_bilinear(split.bright_only, d);
                    for (int k = 0; k < 3; ++k) check[k] += w * v[k];
                }
            for (int k = 0; k < 3; ++k) {
                out.share[k] += acc[k];
                rule_error[k] += std::abs(acc[k] - check[k]);
                magnitude[k] += std::abs(acc[k]);
            }
        }
    const double z = ggx_prefilter_normalisation(alpha);
    // Rounding: a double sum of k terms is within (k - 1) u sum |terms| (Higham's gamma), u = 2^-53; the terms
    // themselves (a handful of double operations each) and the division by Z add a few u more.
    const double u = std::ldexp(1.0, -53), k = double(split.texels.size() + split.support.size() * m * m);
    for (int c = 0; c < 3; ++c) {
        out.share[c] /= z;
        out.bound[c] = (rule_error[c] + (k + 16) * u * magnitude[c]) / z;
    }
    return out;
}

std::array<double, 3> bright_texel_share(const BrightSplit& split, const Dir& n, double roughness) {
    return bright_texel_share_bounded(split, n, roughness).share;
}

std::array<double, 3> prefilter_oracle(const Cubemap& src, const Dir& n, double roughness, double* weight_sum) {
    const std::uint32_t size = src.size;
    std::array<double, 3> acc{};
    double wsum = 0;
    if (roughness <= 0) {
        const auto v = sample_bilinear(src, n);
        return {v[0], v[1], v[2]};
    }
    const double alpha = roughness * roughness;
    // While the lobe is narrow against a texel (alpha < 8 texel angles), texels whose direction is within
    // 3 (alpha + texel) of n are subdivided 8 x 8 (with bilinear reads) so D is resolved; wider lobes vary
    // by (texel / alpha)^2 / 24 < 1e-3 over a texel and take one value each.
    const double texel_angle = 2.0 / size;  // ~ the angular size of a texel at a face centre (radians)
    const double near_cos = alpha < 8 * texel_angle ? std::cos(std::min(kPi / 2, 3 * (alpha + texel_angle))) : 2.0;
    for (int face = 0; face < 6; ++face)
        for (std::uint32_t y = 0; y < size; ++y)
            for (std::uint32_t x = 0; x < size; ++x) {
                const Dir l = cube_direction(face, 2 * (x + 0.5) / size - 1, 2 * (y + 0.5) / size - 1);
                const double nl = n.x * l.x + n.y * l.y + n.z * l.z;
                if (nl > near_cos) {
                    const int m = 8;
                    const double dw = cube_texel_solid_angle(x, y, size) / (m * m);  // close enough within a texel
                    for (int j = 0; j < m; ++j)
                        for (int i = 0; i < m; ++i) {
                            const Dir d = cube_direction(face, 2 * (x + (i + 0.5) / m) / size - 1, 2 * (y + (j + 0.5) / m) / size - 1);
                            const double c = n.x * d.x + n.y * d.y + n.z * d.z;
                            if (c <= 0) continue;
                            const double hx = n.x + d.x, hy = n.y + d.y, hz = n.z + d.z;
                            const double nh = (n.x * hx + n.y * hy + n.z * hz) / std::sqrt(hx * hx + hy * hy + hz * hz);
                            const double w = c * ggx_d(nh, alpha) * dw;
                            const auto v = sample_bilinear(src, d);
                            for (int k = 0; k < 3; ++k) acc[k] += w * v[k];
                            wsum += w;
                        }
                    continue;
                }
                if (nl <= 0) continue;
                const double hx = n.x + l.x, hy = n.y + l.y, hz = n.z + l.z;
                const double nh = (n.x * hx + n.y * hy + n.z * hz) / std::sqrt(hx * hx + hy * hy + hz * hz);
                const double w = nl * ggx_d(nh, alpha) * cube_texel_solid_angle(x, y, size);
                const float* v = src.texel(face, x, y);
                for (int k = 0; k < 3; ++k) acc[k] += w * v[k];
                wsum += w;
            }
    for (auto& a : acc) a /= wsum;
    if (weight_sum) *weight_sum = wsum;
    return acc;
}

}  // namespace ms::env
