// The representations' texel grid: warped axes and their inverses (representation.hpp states them).
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "repr/representation.hpp"

namespace ms::repr {

std::string to_string(NdotVWarp w) { return w == NdotVWarp::sqrt ? "sqrt" : "linear"; }
std::string to_string(NdotLWarp w) {
    return w == NdotLWarp::shadow_edge      ? "shadow-edge"
           : w == NdotLWarp::sqrt_top       ? "sqrt-top"
           : w == NdotLWarp::edge_roughness ? "edge-roughness"
                                            : "linear";
}
std::string to_string(VisibilityWarp w) {
    return w == VisibilityWarp::sqrt_top ? "sqrt-top" : w == VisibilityWarp::edge_roughness ? "edge-roughness" : "linear";
}
std::string to_string(TexelPlacement p) { return p == TexelPlacement::ends ? "ends" : "centres"; }

TexelPlacement parse_texel_placement(const std::string& s) {
    if (s == "centres") return TexelPlacement::centres;
    if (s == "ends") return TexelPlacement::ends;
    throw std::invalid_argument("texel placement must be centres or ends, not '" + s + "'");
}

VisibilityWarp parse_visibility_warp(const std::string& s) {
    if (s == "linear") return VisibilityWarp::linear;
    if (s == "sqrt-top") return VisibilityWarp::sqrt_top;
    if (s == "edge-roughness") return VisibilityWarp::edge_roughness;
    throw std::invalid_argument("visibility warp must be linear or sqrt-top, not '" + s + "'");
}

NdotVWarp parse_n_dot_v_warp(const std::string& s) {
    if (s == "linear") return NdotVWarp::linear;
    if (s == "sqrt") return NdotVWarp::sqrt;
    throw std::invalid_argument("NdotV warp must be linear or sqrt, not '" + s + "'");
}

NdotLWarp parse_n_dot_l_warp(const std::string& s) {
    if (s == "linear") return NdotLWarp::linear;
    if (s == "shadow-edge") return NdotLWarp::shadow_edge;
    if (s == "sqrt-top") return NdotLWarp::sqrt_top;
    if (s == "edge-roughness") return NdotLWarp::edge_roughness;
    throw std::invalid_argument("NdotL warp must be linear, shadow-edge, sqrt-top or edge-roughness, not '" + s + "'");
}

namespace {

// Texel centre i of n over [0, 1].
double centre(std::uint32_t i, std::uint32_t n) { return (i + 0.5) / n; }
// Texel i of n at the placement's warped coordinate: a cell centre, or i / (n - 1) from end to end.
double placed(std::uint32_t i, std::uint32_t n, TexelPlacement p) {
    return p == TexelPlacement::ends && n > 1 ? double(i) / (n - 1) : centre(i, n);
}
// The NdotV warp w(NdotV) before the placement's start is taken off.
double n_dot_v_warped(double nv, NdotVWarp w) { return w == NdotVWarp::sqrt ? std::sqrt(std::max(nv, 0.0)) : nv; }
// The smallest NdotL above the zero region's edge l0 a texel on it is baked at: the term's limit from
// above (at NdotL = 0 the horizon makes the term 0 by rule, while just above it need not be).
constexpr double kAboveEdge = 1e-6;

// The sqrt-top warp u = 1 - sqrt(1 - x) and its inverse x = 1 - (1 - u)^2.
double sqrt_top(double x) { return 1 - std::sqrt(std::max(1 - x, 0.0)); }
double sqrt_top_inverse(double u) { return 1 - (1 - u) * (1 - u); }

// Where the shadow edge starts at visibility v: NdotL at or below edge(v) is the provable zero region
// (cosine AO: the cone's half-angle has cos^2 = 1 - v, the edge is cos(2 theta) = 1 - 2v; uniform AO:
// cos = 1 - v, edge 2 (1 - v)^2 - 1), and the horizon bounds it below.
double shadow_edge(double visibility, AoWeighting weighting) {
    const double edge = weighting == AoWeighting::cosine ? 1 - 2 * visibility
                                                         : 2 * (1 - visibility) * (1 - visibility) - 1;
    return std::max(edge, 0.0);
}

// The visibility cone's cosine c(v), where a smooth surface's shadow edge lies (NdotL = c).
double cone_cos(double visibility, AoWeighting weighting) {
    return weighting == AoWeighting::cosine ? std::sqrt(std::max(0.0, 1 - visibility)) : 1 - visibility;
}

// The edge_roughness warp at visibility v and roughness r: g(x) = asinh((x - c) / w), and its range
// [g(l0), g(1)] over the NdotL that are not provably 0. The width w = k alpha max(sin theta_c, alpha):
// a normal tilted by ~alpha moves m.L by ~alpha sin(theta_l), and at the edge theta_l = theta_c (the
// floor alpha keeps w > 0 for a vanishing cone, where the zero region covers nearly every NdotL).
// With a view factor kappa > 0 the width is at most kappa (NdotV + c) (ReprGrid::n_dot_l_edge_view).
struct EdgeWarp {
    double c, w, g0, g1;
    EdgeWarp(double v, double r, double k, AoWeighting weighting, double view, double nv)
        : c(cone_cos(v, weighting)), w(width(c, r, k, view, nv)),
          g0(std::asinh((shadow_edge(v, weighting) - c) / w)),
          g1(std::asinh((1 - c) / w)) {}
    static double width(double c, double r, double k, double view, double nv) {
        const double w = k * r * r * std::max(std::sqrt(std::max(0.0, 1 - c * c)), r * r);
        return view > 0 ? std::min(w, view * (std::max(nv, kViewFloor) + c)) : w;
    }
    double u(double l) const { return (std::asinh((l - c) / w) - g0) / (g1 - g0); }
    double at(double u) const { return c + w * std::sinh(g0 + u * (g1 - g0)); }
};

// The edge-roughness visibility warp of one roughness node at one NdotV (representation.hpp derives
// it): of the cone's cosine c, H(c) = 1 - sqrt(1 - c) + beta asinh(c / s) / asinh(1 / s),
// s = b min(alpha, kappa NdotV), increasing from H(0) = 0 at v = 1 to H(1) = 1 + beta at v = 0. Texel t
// of n sits where H = H(c0) (1 - t / (n - 1)), c0 the first texel's cosine (the visibility start's, else
// 1): the last texel at v = 1.
struct VisibilityEdgeWarp {
    AoWeighting weighting;
    double s, a1, beta, h0;
    VisibilityEdgeWarp(const ReprGrid& g, std::uint32_t ir, double nv)
        : weighting(g.weighting),
          s(g.visibility_edge_width * std::min(g.roughness.at(ir) * g.roughness.at(ir),
                                                g.visibility_edge_view > 0 ? g.visibility_edge_view * std::max(nv, kViewFloor) : 1.0)),
          a1(std::asinh(1 / s)), beta(g.visibility_edge_share), h0(h(g.edge_cos(g.visibility_start))) {}
    double h(double c) const { return 1 - std::sqrt(std::max(1 - c, 0.0)) + beta * std::asinh(c / s) / a1; }
    // The continuous texel coordinate of a cone cosine on an n-texel axis (unclamped).
    double texel(double c, std::uint32_t n) const { return (1 - h(c) / h0) * (n - 1.0); }
    // dH/dc, positive on [0, 1).
    double slope(double c) const { return 0.5 / std::sqrt(std::max(1 - c, 1e-300)) + beta / (a1 * std::hypot(s, c)); }
    // The visibility of texel t: H is increasing, so Newton's method on c kept inside a bracket that
    // every step narrows (a step leaving it bisects instead); a few steps reach double precision, which
    // matters as the bake asks for every texel's visibility several times.
    double visibility_at(double t, std::uint32_t n) const {
        const double target = n > 1 ? h0 * (1 - t / (n - 1.0)) : h0;
        double lo = 0, hi = 1, c = 0.5;
        for (int i = 0; i < 100 && hi - lo > 1e-15; ++i) {
            const double f = h(c) - target;
            if (f == 0) break;
            (f < 0 ? lo : hi) = c;
            const double next = c - f / slope(c);
            c = next > lo && next < hi ? next : 0.5 * (lo + hi);
            if (std::abs(f) < 1e-15 * h0) break;
        }
        if (t >= n - 1.0) c = 0;  // the last texel: v = 1 exactly
        return weighting == AoWeighting::cosine ? 1 - c * c : 1 - c;
    }
};

}  // namespace

double ReprGrid::visibility_at(std::uint32_t iv, std::uint32_t ir, double nv) const {
    if (warps.visibility == VisibilityWarp::edge_roughness) {
        return VisibilityEdgeWarp(*this, ir, nv).visibility_at(iv, visibility);
    }
    double u = centre(iv, visibility);
    if (visibility_start > 0 && visibility > 1) {
        // From the start's warped coordinate to the last cell centre, evenly.
        const double u0 = visibility_u(visibility_start), u1 = centre(visibility - 1, visibility);
        u = u0 + (u1 - u0) * iv / (visibility - 1);
    }
    return warps.visibility == VisibilityWarp::sqrt_top ? sqrt_top_inverse(u) : u;
}

double ReprGrid::visibility_texel_of(double v, std::uint32_t ir, double nv) const {
    const double last = visibility - 1.0;
    if (warps.visibility == VisibilityWarp::edge_roughness) {
        return std::clamp(VisibilityEdgeWarp(*this, ir, nv).texel(edge_cos(v), visibility), 0.0, last);
    }
    const double u = visibility_u(v);
    if (visibility_start > 0 && visibility > 1) {
        const double u0 = visibility_u(visibility_start), u1 = centre(visibility - 1, visibility);
        return std::clamp((u - u0) * (last / (u1 - u0)), 0.0, last);
    }
    return std::clamp(u * visibility - 0.5, 0.0, last);
}

double ReprGrid::edge_cos(double v) const { return cone_cos(std::clamp(v, 0.0, 1.0), weighting); }

double ReprGrid::visibility_u(double v) const {
    if (warps.visibility == VisibilityWarp::edge_roughness) throw std::logic_error("visibility_u: the edge-roughness warp is per roughness node");
    return warps.visibility == VisibilityWarp::sqrt_top ? sqrt_top(v) : v;
}

double ReprGrid::n_dot_l_at(std::uint32_t iv, std::uint32_t il, std::uint32_t ir, double nv) const {
    const double u = placed(il, n_dot_l, placement);
    // The first texel of an axis placed from end to end sits on the zero region's edge (or the horizon).
    const double floor = placement == TexelPlacement::ends ? shadow_edge(visibility_at(iv, ir, nv), weighting) + kAboveEdge : 0.0;
    double l;
    if (warps.n_dot_l == NdotLWarp::linear) l = u;
    else if (warps.n_dot_l == NdotLWarp::sqrt_top) l = sqrt_top_inverse(u);
    else if (warps.n_dot_l == NdotLWarp::edge_roughness) l = EdgeWarp(visibility_at(iv, ir, nv), roughness.at(ir), edge_width, weighting, n_dot_l_edge_view, nv).at(u);
    else {
        const double l0 = shadow_edge(visibility_at(iv, ir, nv), weighting);
        l = l0 + u * (1 - l0);
    }
    return std::clamp(l, std::min(floor, 1.0), 1.0);
}

double ReprGrid::n_dot_v_at(std::uint32_t ivv) const {
    const double u = placed(ivv, n_dot_v, placement);
    if (placement == TexelPlacement::ends) {
        // u = (w(NdotV) - w(start)) / (1 - w(start)), inverted.
        const double w0 = n_dot_v_warped(n_dot_v_start, warps.n_dot_v), w = w0 + u * (1 - w0);
        return warps.n_dot_v == NdotVWarp::sqrt ? w * w : w;
    }
    return warps.n_dot_v == NdotVWarp::sqrt ? u * u : u;
}

double ReprGrid::texel_of(double u, std::uint32_t n) const {
    const double t = placement == TexelPlacement::ends ? u * (n - 1.0) : u * n - 0.5;
    return std::clamp(t, 0.0, double(n - 1));
}

double ReprGrid::n_dot_l_u(double v, double l, std::uint32_t ir, double nv) const {
    if (warps.n_dot_l == NdotLWarp::linear) return l;
    if (warps.n_dot_l == NdotLWarp::sqrt_top) return sqrt_top(l);
    const double l0 = shadow_edge(std::clamp(v, 0.0, 1.0), weighting);
    if (warps.n_dot_l == NdotLWarp::edge_roughness)
        return l0 >= 1 ? -1.0 : EdgeWarp(std::clamp(v, 0.0, 1.0), roughness.at(ir), edge_width, weighting, n_dot_l_edge_view, nv).u(l);
    // l0 = 1 only at v = 0 (cosine) where every NdotL is in the zero region: report "below the edge".
    return l0 >= 1 ? -1.0 : (l - l0) / (1 - l0);
}

double ReprGrid::n_dot_v_u(double nv) const {
    const double w = n_dot_v_warped(nv, warps.n_dot_v);
    if (placement != TexelPlacement::ends) return w;
    const double w0 = n_dot_v_warped(n_dot_v_start, warps.n_dot_v);
    return (w - w0) / (1 - w0);
}

}  // namespace ms::repr

namespace ms::repr {

double ReprGrid::azimuth_tau(double nv, double l) const {
    const double d = std::max(nv, 0.0) + std::max(l, 0.0);
    return std::max(azimuth_warp * d * d / 2, 1e-6);
}

double ReprGrid::azimuth_coordinate(double cos_phi, double nv, double l) const {
    const double x = std::clamp(cos_phi, -1.0, 1.0);
    if (!(azimuth_warp > 0)) return x;
    const double tau = azimuth_tau(nv, l);
    return 2 * std::asinh((1 + x) / tau) / std::asinh(2 / tau) - 1;
}

double ReprGrid::azimuth_node(std::uint32_t k, std::uint32_t nodes, double nv, double l) const {
    const double t = nodes <= 1 ? 0.0 : M_PI * double(k) / double(nodes - 1);
    if (!(azimuth_warp > 0)) return t;
    // y = cos t, inverted: 1 + cos phi = tau sinh((y + 1) / 2 asinh(2 / tau)).
    const double tau = azimuth_tau(nv, l);
    return std::acos(std::clamp(tau * std::sinh((std::cos(t) + 1) / 2 * std::asinh(2 / tau)) - 1, -1.0, 1.0));
}

}  // namespace ms::repr
