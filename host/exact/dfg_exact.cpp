#include "exact/dfg_exact.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/types.hpp"
#include "exact/gauss_legendre.hpp"

namespace ms::exact {

namespace {

// Panels shrink by this ratio towards a graded end: with it a panel's nearest singularity is at least
// 2/3 of its half-width away, so a 16-point rule gains ~32 bits per panel (Bernstein ellipse rho ~ 3).
constexpr double kGrading = 0.25;

// Nodes and weights of composite Gauss-Legendre on [a, b]: `order` nodes per panel, panels graded
// geometrically towards a (levels_a levels) and towards b (levels_b), the two gradings meeting at the
// middle. Resolves features of width ~ (b - a) kGrading^levels at either end.
void graded_rule(double a, double b, int levels_a, int levels_b, int order, std::vector<double>& x, std::vector<double>& w) {
    x.clear();
    w.clear();
    const GaussRule& g = gauss_legendre(order);
    const double mid = 0.5 * (a + b), half = 0.5 * (b - a);
    std::vector<double> edges{a};
    for (int k = levels_a; k >= 1; --k) edges.push_back(a + half * std::pow(kGrading, k));
    edges.push_back(mid);
    for (int k = 1; k <= levels_b; ++k) edges.push_back(b - half * std::pow(kGrading, k));
    edges.push_back(b);
    for (std::size_t p = 0; p + 1 < edges.size(); ++p) {
        const double lo = edges[p], hi = edges[p + 1];
        if (!(hi > lo)) continue;
        for (std::size_t i = 0; i < g.nodes.size(); ++i) {
            x.push_back(lo + (hi - lo) * 0.5 * (g.nodes[i] + 1));
            w.push_back((hi - lo) * 0.5 * g.weights[i]);
        }
    }
}

// Levels of grading that bring the end panel down to `width` on an interval of length `length`.
int levels_for(double width, double length) {
    if (!(width < length)) return 1;
    return std::clamp(int(std::ceil(std::log(width / (0.5 * length)) / std::log(kGrading))), 1, 60);
}

// Height-correlated Smith G2 of isotropic GGX in the form without Lambda (Heitz 2014 eq. 99 rewritten
// as Filament's visibility times 4 NdotL NdotV): finite and linear in NdotL as NdotL -> 0.
double smith_g2(double n_dot_v, double n_dot_l, double alpha) {
    const double a2 = alpha * alpha;
    const double gv = n_dot_l * std::sqrt(n_dot_v * n_dot_v * (1 - a2) + a2);
    const double gl = n_dot_v * std::sqrt(n_dot_l * n_dot_l * (1 - a2) + a2);
    return 2 * n_dot_l * n_dot_v / (gv + gl);
}

struct Sums {
    double scale = 0, bias = 0, sheen = 0;
};

Sums integrate(double v, double alpha, bool with_sheen, int order) {
    const double sin_v = std::sqrt(std::max(0.0, (1 - v) * (1 + v)));
    const double tan_v = sin_v / v;
    // The azimuth integrand is analytic except near phi = pi/2 +- i / tan_v (where t*'s arctangent has
    // its branch points), so the phi panels are graded towards pi/2 down to a fraction of that distance.
    const double branch = 1 / std::max(tan_v, 1e-300);
    const int phi_levels = levels_for(std::min(1.0, branch) / 8, kPi / 2);
    std::vector<double> px, pw, pxr, pwr;
    graded_rule(0, kPi / 2, 1, phi_levels, order, px, pw);
    graded_rule(kPi / 2, kPi, phi_levels, 1, order, pxr, pwr);
    px.insert(px.end(), pxr.begin(), pxr.end());
    pw.insert(pw.end(), pwr.begin(), pwr.end());
    const double a2 = alpha * alpha;
    const double sheen_norm = (2 + 1 / alpha) / (2 * kPi);
    std::vector<double> sx, sw;
    Sums total;
    for (std::size_t j = 0; j < px.size(); ++j) {
        const double phi = px[j], cos_phi = std::cos(phi);
        // The horizon: L.z = sin_v sin 2t cos phi + v cos 2t = 0 at 2t = pi/2 + atan(tan_v cos phi).
        const double t_star = kPi / 4 + 0.5 * std::atan(tan_v * cos_phi);
        const double tan_star = std::tan(t_star);
        // L.z and V.h at (t, phi) from cos t and sin t.
        auto l_z = [&](double c, double s) { return sin_v * 2 * s * c * cos_phi + v * (c - s) * (c + s); };
        auto v_h = [&](double c, double s) { return sin_v * s * cos_phi + v * c; };

        // GGX, inner variable s = sqrt(u) on [0, s*].
        const double u_star = tan_star * tan_star / (a2 + tan_star * tan_star);
        const double s_star = std::sqrt(u_star);
        const double gap = 1 - s_star;  // to the 1 / cos t near-singularity at s = 1
        // The boundary layer where G2 falls to 0: L.z below ~alpha / 2, i.e. t within ~alpha / 4 of t*
        // (dL.z/dt ~ 2), mapped to s by ds/dt = alpha^2 tan t sec^2 t / ((alpha^2 + tan^2 t)^2 s).
        const double sec2 = 1 + tan_star * tan_star;
        const double ds_dt = a2 * tan_star * sec2 / ((a2 + tan_star * tan_star) * (a2 + tan_star * tan_star) * s_star);
        const double layer = std::min(1.0, alpha) * 0.25 * ds_dt;
        graded_rule(0, s_star, 1, levels_for(std::min({layer, gap, s_star}) / 8, s_star), order, sx, sw);
        Sums inner;
        for (std::size_t i = 0; i < sx.size(); ++i) {
            const double s = sx[i], u = s * s;
            const double d = (1 - u) + a2 * u;
            const double cos_t = std::sqrt((1 - s) * (1 + s) / d), sin_t = alpha * s / std::sqrt(d);
            const double nl = l_z(cos_t, sin_t), vh = v_h(cos_t, sin_t);
            if (!(nl > 0) || !(vh > 0)) continue;
            // f NdotL dL = G2 (V.h) / (v cos t) du dphi / 2 pi; du = 2 s ds; x 2 for phi in [pi, 2 pi].
            const double value = smith_g2(v, nl, alpha) * vh / (v * cos_t) * (2 * s) / kPi;
            const double fc = std::pow(1 - vh, 5);
            inner.scale += sw[i] * value * (1 - fc);
            inner.bias += sw[i] * value * fc;
        }
        if (with_sheen) {
            // Charlie, inner variable t on [0, t*]: D_C sin^(1/alpha) t peaks at t* for small alpha
            // (d ln D / dt = cot t / alpha), a layer ~alpha tan t* wide, and V_N NdotL =
            // NdotL / (4 (NdotL + v (1 - NdotL))) has its pole ~v / 2 beyond t* (dNdotL/dt <= 2);
            // sin^(1/alpha + 1) t has a branch point at t = 0 (graded to 1e-4 of the interval: its
            // share there is < 1e-12).
            const double peak = std::min({1.0, alpha * tan_star, 0.5 * v});
            graded_rule(0, t_star, levels_for(1e-4 * t_star, t_star), levels_for(peak * t_star / 8, t_star), order, sx, sw);
            for (std::size_t i = 0; i < sx.size(); ++i) {
                const double t = sx[i], c = std::cos(t), s = std::sin(t);
                const double nl = l_z(c, s), vh = v_h(c, s);
                if (!(nl > 0) || !(vh > 0)) continue;
                const double d = sheen_norm * std::pow(s, 1 / alpha);
                const double vis = 1 / (4 * (nl + v - nl * v));
                // D V_N NdotL dL, dL = 4 (V.h) sin t dt dphi; x 2 for phi in [pi, 2 pi].
                inner.sheen += sw[i] * d * vis * nl * 4 * vh * s * 2;
            }
        }
        total.scale += pw[j] * inner.scale;
        total.bias += pw[j] * inner.bias;
        total.sheen += pw[j] * inner.sheen;
    }
    return total;
}

}  // namespace

DfgExact dfg_exact(double n_dot_v, double alpha, bool sheen, int order) {
    if (!(n_dot_v > 0 && n_dot_v <= 1)) throw std::invalid_argument("dfg_exact: NdotV must be in (0, 1]");
    if (!(alpha > 0 && alpha <= 1)) throw std::invalid_argument("dfg_exact: alpha must be in (0, 1]");
    if (order < 8 || order > 64) throw std::invalid_argument("dfg_exact: order in 8..64");
    const Sums hi = integrate(n_dot_v, alpha, sheen, order);
    const Sums lo = integrate(n_dot_v, alpha, sheen, order - 4);
    DfgExact r;
    r.scale = hi.scale;
    r.bias = hi.bias;
    r.sheen = hi.sheen;
    r.scale_error = std::abs(hi.scale - lo.scale);
    r.bias_error = std::abs(hi.bias - lo.bias);
    r.sheen_error = std::abs(hi.sheen - lo.sheen);
    return r;
}

}  // namespace ms::exact
