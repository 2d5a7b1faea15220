#include "integrands/dfg/dfg_quadrature.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>

#include "oracle/oracle.hpp"

namespace ms::dfg {

void gauss_legendre(int n, std::vector<double>& nodes, std::vector<double>& weights) {
    if (n < 1) throw std::invalid_argument("gauss_legendre: n >= 1");
    nodes.assign(n, 0.0);
    weights.assign(n, 0.0);
    const double pi = 3.14159265358979323846;
    for (int i = 0; i < n; ++i) {
        double x = std::cos(pi * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1, p1 = x;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2.0 * k - 1) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            if (n == 1) p0 = 1, p1 = x;
            dp = n * (x * p1 - p0) / (x * x - 1);
            const double dx = p1 / dp;
            x -= dx;
            if (std::abs(dx) < 1e-16) break;
        }
        // Recompute the derivative at the converged node.
        double p0 = 1, p1 = x;
        for (int k = 2; k <= n; ++k) {
            const double p2 = ((2.0 * k - 1) * x * p1 - (k - 1.0) * p0) / k;
            p0 = p1;
            p1 = p2;
        }
        dp = n == 1 ? 1.0 : n * (x * p1 - p0) / (x * x - 1);
        nodes[i] = x;
        weights[i] = 2 / ((1 - x * x) * dp * dp);
    }
}

namespace {

// A rule on [0, 1]: composite Gauss-Legendre on panels graded geometrically towards both ends
// (edges q^k, k = levels .. 1, mirrored), which resolves end layers down to a width of q^levels.
struct Rule {
    std::vector<double> x, w;
};

const Rule& graded_rule(int order, int levels) {
    static std::mutex mutex;
    static std::map<std::pair<int, int>, Rule> cache;
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find({order, levels});
    if (it != cache.end()) return it->second;
    const double q = 0.25;
    std::vector<double> edges{0.0};
    for (int k = levels; k >= 1; --k) edges.push_back(0.5 * std::pow(q, k));
    // edges so far: 0, 0.5 q^levels, ..., 0.5 q; then the middle, mirrored.
    std::vector<double> half = edges;
    edges.clear();
    for (double e : half) edges.push_back(e);
    edges.push_back(0.5);
    for (auto r = half.rbegin(); r != half.rend(); ++r) edges.push_back(1.0 - *r);
    std::vector<double> gx, gw;
    gauss_legendre(order, gx, gw);
    Rule rule;
    for (std::size_t p = 0; p + 1 < edges.size(); ++p) {
        const double a = edges[p], b = edges[p + 1];
        for (int i = 0; i < order; ++i) {
            rule.x.push_back(a + (b - a) * 0.5 * (gx[i] + 1));
            rule.w.push_back((b - a) * 0.5 * gw[i]);
        }
    }
    return cache.emplace(std::make_pair(order, levels), std::move(rule)).first->second;
}

struct Pair {
    double scale = 0, bias = 0;
};

// The inner integral over phi in [0, phi_max] at polar angle (cos t, sin t), times 1 / pi (the
// symmetric half of the 1 / (2 pi) azimuth measure).
Pair inner(const Rule& rule, double cos_t, double sin_t, double phi_max, double n_dot_v, double sin_v,
           double alpha, double lambda_v) {
    Pair s;
    const Vec3 view{sin_v, 0, n_dot_v};
    for (std::size_t i = 0; i < rule.x.size(); ++i) {
        const double phi = phi_max * rule.x[i];
        const Vec3 h{sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
        const double vh = view.x * h.x + view.z * h.z;
        const Vec3 l{2 * vh * h.x - view.x, 2 * vh * h.y - view.y, 2 * vh * h.z - view.z};
        if (!(l.z > 0) || !(vh > 0)) continue;
        const double lambda_l = oracle::smith_lambda(l, alpha, alpha);
        const double g2 = 1 / (1 + lambda_v + lambda_l);
        const double value = g2 * vh / (n_dot_v * cos_t);
        const double fc = std::pow(1 - vh, 5);
        const double w = rule.w[i] * phi_max / kPi;
        s.scale += w * value * (1 - fc);
        s.bias += w * value * fc;
    }
    return s;
}

// u -> (cos t, sin t) for the GGX CDF u = tan^2 t / (alpha^2 + tan^2 t).
void polar(double u, double alpha, double& cos_t, double& sin_t) {
    const double d = (1 - u) + alpha * alpha * u;
    cos_t = std::sqrt((1 - u) / d);
    sin_t = std::sqrt(alpha * alpha * u / d);
}

double cdf(double t, double alpha) {
    const double s = std::sin(t), c = std::cos(t);
    return s * s / (alpha * alpha * c * c + s * s);
}

Pair integrate(double n_dot_v, double alpha, int order) {
    // End layers: about alpha wide in phi (L's height over the horizon), and about (alpha v)^2 wide in u
    // near u2 at grazing views (cos t falls from 1/sqrt 2 to ~v over that layer). Grade to 1/100 of both.
    const double layer = std::min(alpha, alpha * alpha * n_dot_v * n_dot_v);
    const int levels = std::clamp(int(std::ceil(std::log(layer * 1e-2) / std::log(0.25))), 4, 20);
    const Rule& rule = graded_rule(order, levels);
    const double sin_v = std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v));
    const double t_v = std::acos(n_dot_v);
    const double lambda_v = oracle::smith_lambda(Vec3{sin_v, 0, n_dot_v}, alpha, alpha);
    const double t1 = 0.5 * (kPi / 2 - t_v), t2 = 0.5 * (kPi / 2 + t_v);
    const double u1 = cdf(t1, alpha), u2 = cdf(t2, alpha);
    Pair total;
    // Segment 1: u in [0, u1], every azimuth.
    for (std::size_t j = 0; j < rule.x.size(); ++j) {
        const double u = u1 * rule.x[j];
        double c, s;
        polar(u, alpha, c, s);
        const Pair p = inner(rule, c, s, kPi, n_dot_v, sin_v, alpha, lambda_v);
        total.scale += u1 * rule.w[j] * p.scale;
        total.bias += u1 * rule.w[j] * p.bias;
    }
    // Segment 2: u in [u1, u2], |phi| < phi*(t).
    if (sin_v > 0 && u2 > u1) {
        for (std::size_t j = 0; j < rule.x.size(); ++j) {
            const double u = u1 + (u2 - u1) * rule.x[j];
            double c, s;
            polar(u, alpha, c, s);
            const double cos2t = c * c - s * s, sin2t = 2 * s * c;
            const double cstar = -cos2t * n_dot_v / (sin2t * sin_v);
            const double phi_max = std::acos(std::clamp(cstar, -1.0, 1.0));
            if (phi_max <= 0) continue;
            const Pair p = inner(rule, c, s, phi_max, n_dot_v, sin_v, alpha, lambda_v);
            total.scale += (u2 - u1) * rule.w[j] * p.scale;
            total.bias += (u2 - u1) * rule.w[j] * p.bias;
        }
    }
    return total;
}

// The sheen (Charlie) channel: D_C(h) V_N NdotL dL with D_C = (2 + 1/alpha) sin^(1/alpha) t / (2 pi) and
// V_N = 1 / (4 (NdotL + NdotV - NdotL NdotV)), over the same two segments as the GGX integrals but in
// the polar variable sigma = sin t (dw_h = sigma / cos t dsigma dphi; D_C = k sigma^(1/alpha) has no
// square-root end in sigma) and the azimuth inner, as above.
double charlie_integrate(double n_dot_v, double alpha, int order) {
    // D_C peaks at the largest admissible t for small alpha, a layer ~alpha wide in sigma; the azimuth
    // end phi* has its square-root end at t2, as for GGX.
    const double layer = std::min(alpha, n_dot_v * n_dot_v);
    const int levels = std::clamp(int(std::ceil(std::log(layer * 1e-2) / std::log(0.25))), 8, 20);
    const Rule& rule = graded_rule(order, levels);
    const double sin_v = std::sqrt(std::max(0.0, 1 - n_dot_v * n_dot_v));
    const double t_v = std::acos(n_dot_v);
    const double t1 = 0.5 * (kPi / 2 - t_v), t2 = 0.5 * (kPi / 2 + t_v);
    const double s1 = std::sin(t1), s2 = std::sin(t2);
    const double k = (2 + 1 / alpha) / (2 * kPi);
    const Vec3 view{sin_v, 0, n_dot_v};
    auto azimuths = [&](double sigma, double phi_max) {
        const double cos_t = std::sqrt(std::max(0.0, 1 - sigma * sigma));
        double sum = 0;
        for (std::size_t i = 0; i < rule.x.size(); ++i) {
            const double phi = phi_max * rule.x[i];
            const Vec3 h{sigma * std::cos(phi), sigma * std::sin(phi), cos_t};
            const double vh = view.x * h.x + view.z * h.z;
            const double lz = 2 * vh * h.z - view.z;
            if (!(lz > 0) || !(vh > 0)) continue;
            const double visibility = 0.25 / (lz + n_dot_v - lz * n_dot_v);
            // rule.x spans [0, phi_max]: dphi = phi_max dx, and x 2 for the mirror half [-phi_max, 0].
            sum += rule.w[i] * 2 * phi_max * visibility * lz * 4 * vh;
        }
        return k * std::pow(sigma, 1 / alpha) * sigma / cos_t * sum;
    };
    double total = 0;
    for (std::size_t j = 0; j < rule.x.size(); ++j) total += s1 * rule.w[j] * azimuths(s1 * rule.x[j], kPi);
    if (sin_v > 0 && s2 > s1) {
        for (std::size_t j = 0; j < rule.x.size(); ++j) {
            const double sigma = s1 + (s2 - s1) * rule.x[j];
            const double c = std::sqrt(1 - sigma * sigma);
            const double cos2t = c * c - sigma * sigma, sin2t = 2 * sigma * c;
            const double phi_max = std::acos(std::clamp(-cos2t * n_dot_v / (sin2t * sin_v), -1.0, 1.0));
            if (phi_max > 0) total += (s2 - s1) * rule.w[j] * azimuths(sigma, phi_max);
        }
    }
    return total;
}

}  // namespace

DfgQuadrature dfg_quadrature(double n_dot_v, double alpha, int order, bool sheen) {
    if (!(n_dot_v > 0 && n_dot_v <= 1)) throw std::invalid_argument("dfg_quadrature: NdotV must be in (0, 1]");
    if (!(alpha > 0 && alpha <= 1)) throw std::invalid_argument("dfg_quadrature: alpha must be in (0, 1]");
    if (order < 6) throw std::invalid_argument("dfg_quadrature: order >= 6");
    const Pair hi = integrate(n_dot_v, alpha, order);
    const Pair lo = integrate(n_dot_v, alpha, order - 4);
    DfgQuadrature q;
    q.scale = hi.scale;
    q.bias = hi.bias;
    q.scale_error = std::abs(hi.scale - lo.scale);
    q.bias_error = std::abs(hi.bias - lo.bias);
    if (sheen) {
        q.sheen = charlie_integrate(n_dot_v, alpha, order);
        q.sheen_error = std::abs(q.sheen - charlie_integrate(n_dot_v, alpha, order - 4));
    }
    return q;
}

}  // namespace ms::dfg
