#include "jobs/repr_bake.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <stdexcept>

#include "jobs/cache_keys.hpp"

namespace ms::repr {

namespace {

void validate(const AzimuthBakeSpec& s) {
    const auto& g = s.grid;
    for (auto n : {g.visibility, g.n_dot_l, g.n_dot_v})
        if (n < 2 || n > 256) throw std::invalid_argument("representation grid: every axis needs 2 to 256 texels");
    if (g.roughness.empty() || g.roughness.size() > 64) throw std::invalid_argument("representation grid: 1 to 64 roughness nodes");
    for (std::size_t i = 0; i < g.roughness.size(); ++i) {
        if (!(g.roughness[i] > 0 && g.roughness[i] <= 1)) throw std::invalid_argument("representation grid: roughness must be in (0, 1]");
        if (i && !(g.roughness[i] > g.roughness[i - 1])) throw std::invalid_argument("representation grid: roughness must increase");
    }
    if (s.azimuth_nodes < 2 || s.azimuth_nodes > 64) throw std::invalid_argument("representation bake: 2 to 64 azimuth nodes");
    if (g.warps.n_dot_l == NdotLWarp::edge_roughness && !(g.edge_width > 0 && g.edge_width <= 100))
        throw std::invalid_argument("representation grid: the edge-roughness warp's width factor must be in (0, 100]");
    if (!(g.azimuth_warp >= 0 && g.azimuth_warp <= 1000))
        throw std::invalid_argument("representation grid: the far-side azimuth warp must be in [0, 1000]");
    if (!(g.visibility_start >= 0 && g.visibility_start < 0.5))
        throw std::invalid_argument("representation grid: visibility_start must be in [0, 0.5)");
    if (!(g.n_dot_v_start >= 0 && g.n_dot_v_start < 1)) throw std::invalid_argument("representation grid: n_dot_v_start must be in [0, 1)");
    if (g.warps.visibility == VisibilityWarp::edge_roughness &&
        (g.warps.n_dot_l != NdotLWarp::edge_roughness || !(g.visibility_edge_width > 0 && g.visibility_edge_width <= 100) ||
         !(g.visibility_edge_share >= 0 && g.visibility_edge_share <= 100) || !(g.visibility_edge_view >= 0 && g.visibility_edge_view <= 100)))
        throw std::invalid_argument("representation grid: the edge-roughness visibility warp needs the edge-roughness NdotL warp, a width "
                                    "factor in (0, 100], a share and a view factor in [0, 100]");
    if (!(g.n_dot_l_edge_view >= 0 && g.n_dot_l_edge_view <= 100))
        throw std::invalid_argument("representation grid: the NdotL edge view factor must be in [0, 100]");
    if (s.term.ao_weighting != g.weighting) throw std::invalid_argument("representation bake: term and grid AO weightings differ");
    const std::uint64_t queries = std::uint64_t(g.visibility) * g.n_dot_l * g.n_dot_v * g.roughness.size() * s.azimuth_nodes;
    if (queries > (std::uint64_t(1) << 24)) throw std::invalid_argument("representation bake: more than 2^24 texels x nodes");
}

constexpr int kTerms = 4;  // a0 + a1 cos(dphi) + a2 cos(2 dphi) + a3 rho (repr/anisotropic.cpp)

bool is_geometric(const std::vector<double>& r) {
    if (r.size() < 2) return true;
    const double q = r[1] / r[0];
    for (std::size_t k = 1; k < r.size(); ++k)
        if (std::abs(r[k] / r[k - 1] - q) > 1e-6 * q) return false;
    return true;
}

// A surface with projected roughnesses alpha_v, alpha_l along V at azimuth 0 and L at azimuth dphi, and
// slope correlation rho along them: Sigma = B^-T M B^-1. Its roughness along its principal axes and the
// angle of the first axis from V's azimuth; false when Sigma is not positive or the ratio exceeds max_ratio.
struct Surface {
    double alpha_x, alpha_y, axis_angle;
};
bool surface_of(double alpha_v, double alpha_l, double rho, double dphi, double max_ratio, Surface& out) {
    const double b00 = 1, b10 = 0, b01 = std::cos(dphi), b11 = std::sin(dphi);  // columns u_v, u_l
    const double det = b00 * b11 - b01 * b10;
    if (!(std::abs(det) > 1e-9)) return false;
    const double i00 = b11 / det, i01 = -b01 / det, i10 = -b10 / det, i11 = b00 / det;  // B^-1
    const double m00 = alpha_v * alpha_v, m01 = rho * alpha_v * alpha_l, m11 = alpha_l * alpha_l;
    // Sigma = (B^-1)^T M B^-1.
    const double t00 = m00 * i00 + m01 * i10, t01 = m00 * i01 + m01 * i11, t10 = m01 * i00 + m11 * i10, t11 = m01 * i01 + m11 * i11;
    const double s00 = i00 * t00 + i10 * t10, s01 = i00 * t01 + i10 * t11, s11 = i01 * t01 + i11 * t11;
    const double half_trace = 0.5 * (s00 + s11), d = s00 * s11 - s01 * s01;
    const double disc = std::sqrt(std::max(0.0, half_trace * half_trace - d));
    const double l1 = half_trace + disc, l2 = half_trace - disc;
    if (!(l2 > 0) || l1 / l2 > max_ratio * max_ratio * (1 + 1e-12)) return false;
    out = {std::sqrt(l1), std::sqrt(l2), 0.5 * std::atan2(2 * s01, s00 - s11)};
    return true;
}

struct Config {
    double dphi, rho;
    Surface surface;
};

// The configurations of one slab: dphi at cell centres, rho spread evenly over its allowed values.
std::vector<Config> slab_configs(double alpha_v, double alpha_l, const AnisotropicBakeSpec& s) {
    std::vector<Config> out;
    // A surface's ratio is at least that of its projected alphas, so a slab whose nodes are further
    // apart than max_ratio holds no surface of the domain; the lookup still blends it in for surfaces
    // near the ratio limit, so it is fitted to the least anisotropic surfaces that reach it (ratio up to
    // twice its nodes' ratio) rather than left at 0.
    const double max_ratio = std::max(s.max_ratio, 2 * std::max(alpha_v / alpha_l, alpha_l / alpha_v));
    for (std::uint32_t a = 0; a < s.azimuth_configs; ++a) {
        const double dphi = kPi * (a + 0.5) / s.azimuth_configs;
        // The allowed correlations at this dphi, found on a fine scan (the ratio grows without bound
        // towards rho = +-1, so they form one interval around the isotropic cos(dphi) when alpha_v = alpha_l).
        double lo = 2, hi = -2;
        const int scan = 400;
        for (int k = 1; k < scan; ++k) {
            const double rho = -1 + 2.0 * k / scan;
            Surface sf;
            if (surface_of(alpha_v, alpha_l, rho, dphi, max_ratio, sf)) lo = std::min(lo, rho), hi = std::max(hi, rho);
        }
        if (lo > hi) continue;
        for (std::uint32_t b = 0; b < s.correlation_configs; ++b) {
            const double rho = s.correlation_configs == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * b / (s.correlation_configs - 1);
            Config c{dphi, rho, {}};
            if (surface_of(alpha_v, alpha_l, rho, dphi, max_ratio, c.surface)) out.push_back(c);
        }
    }
    return out;
}

// The ridge least-squares map P (kTerms x n) from the configurations' values to the coefficients.
std::vector<std::array<double, kTerms>> fit_map(const std::vector<Config>& configs) {
    const std::size_t n = configs.size();
    double A[kTerms][kTerms] = {};
    std::vector<std::array<double, kTerms>> basis(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double c = std::cos(configs[i].dphi);
        basis[i] = {1, c, 2 * c * c - 1, configs[i].rho};
        for (int a = 0; a < kTerms; ++a)
            for (int b = 0; b < kTerms; ++b) A[a][b] += basis[i][a] * basis[i][b];
    }
    // The ridge: 1e-3 of the mean squared basis value on the higher terms keeps the fit defined on
    // slabs whose configurations leave cos(dphi) and rho nearly collinear.
    for (int a = 1; a < kTerms; ++a) A[a][a] += 1e-3 * double(std::max<std::size_t>(n, 1));
    if (n == 0) A[0][0] = 1;
    // Invert A (symmetric positive definite) by Gauss-Jordan.
    double inv[kTerms][kTerms] = {};
    for (int a = 0; a < kTerms; ++a) inv[a][a] = 1;
    for (int col = 0; col < kTerms; ++col) {
        const double p = A[col][col];
        for (int k = 0; k < kTerms; ++k) A[col][k] /= p, inv[col][k] /= p;
        for (int row = 0; row < kTerms; ++row) {
            if (row == col) continue;
            const double f = A[row][col];
            for (int k = 0; k < kTerms; ++k) A[row][k] -= f * A[col][k], inv[row][k] -= f * inv[col][k];
        }
    }
    std::vector<std::array<double, kTerms>> P(n);
    for (std::size_t i = 0; i < n; ++i)
        for (int a = 0; a < kTerms; ++a) {
            double s = 0;
            for (int b = 0; b < kTerms; ++b) s += inv[a][b] * basis[i][b];
            P[i][a] = s;
        }
    return P;
}

void validate_anisotropic(const AnisotropicBakeSpec& s) {
    const auto& g = s.grid;
    for (auto n : {g.visibility, g.n_dot_l, g.n_dot_v})
        if (n < 2 || n > 256) throw std::invalid_argument("anisotropic grid: every axis needs 2 to 256 texels");
    if (g.roughness.size() < 2 || g.roughness.size() > 32) throw std::invalid_argument("anisotropic grid: 2 to 32 roughness nodes");
    if (g.warps.visibility == VisibilityWarp::edge_roughness || g.n_dot_l_edge_view > 0)
        throw std::invalid_argument("anisotropic grid: not with the edge-roughness visibility warp or an NdotL edge view factor");
    for (std::size_t i = 0; i < g.roughness.size(); ++i)
        if (!(g.roughness[i] > 0 && g.roughness[i] <= 1) || (i && !(g.roughness[i] > g.roughness[i - 1])))
            throw std::invalid_argument("anisotropic grid: roughness nodes must increase within (0, 1]");
    if (!is_geometric(g.roughness)) throw std::invalid_argument("anisotropic grid: roughness nodes must be in geometric progression");
    if (g.warps.n_dot_l != NdotLWarp::edge_roughness) throw std::invalid_argument("anisotropic grid: the NdotL warp is edge-roughness");
    if (g.azimuth_warp != 0) throw std::invalid_argument("anisotropic grid: the far-side azimuth warp is for azimuth-harmonics");
    if (!(g.edge_width > 0 && g.edge_width <= 100)) throw std::invalid_argument("anisotropic grid: edge width must be in (0, 100]");
    if (s.term.ao_weighting != g.weighting) throw std::invalid_argument("anisotropic bake: term and grid AO weightings differ");
    if (s.azimuth_configs < 2 || s.azimuth_configs > 64 || s.correlation_configs < 1 || s.correlation_configs > 64)
        throw std::invalid_argument("anisotropic bake: 2 to 64 azimuth and 1 to 64 correlation configurations");
    if (!(s.max_ratio >= 1 && s.max_ratio <= 1000)) throw std::invalid_argument("anisotropic bake: max ratio must be in [1, 1000]");
}

}  // namespace

AzimuthBake bake_azimuth(const AzimuthBakeSpec& spec, TermBackend& backend,
                         const std::function<void(std::size_t, std::size_t)>& progress) {
    validate(spec);
    const auto start = std::chrono::steady_clock::now();
    AzimuthBake bake;
    bake.grid = spec.grid;
    bake.azimuth_nodes = spec.azimuth_nodes;
    bake.replicates = spec.plan.replicates;
    const auto& g = spec.grid;
    const std::size_t n = std::size_t(g.roughness.size()) * spec.azimuth_nodes * g.n_dot_v * g.n_dot_l * g.visibility;
    std::vector<Query> queries(n);
    for (std::uint32_t r = 0; r < g.roughness.size(); ++r)
        for (std::uint32_t k = 0; k < spec.azimuth_nodes; ++k) {
            for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv) {
                const double nv = g.n_dot_v_at(ivv);
                for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                    for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                        // The texel's query as eval takes it: V in the xz plane, L at azimuth phi from it
                        // (node k of this texel: the far-side warp places them by its NdotV and NdotL).
                        const double nl = g.n_dot_l_at(iv, il, r, nv), sl = std::sqrt(std::max(0.0, 1 - nl * nl));
                        const double phi = g.azimuth_node(k, spec.azimuth_nodes, nv, nl);
                        Query& q = queries[bake.index(r, k, iv, il, ivv)];
                        q.visibility = g.visibility_at(iv, r, nv);
                        q.alpha_x = q.alpha_y = g.roughness[r] * g.roughness[r];
                        q.wi = {std::sqrt(std::max(0.0, 1 - nv * nv)), 0, nv};
                        q.wo = {sl * std::cos(phi), sl * std::sin(phi), nl};
                    }
            }
        }
    EvalStats stats;
    const auto estimates = evaluate(backend, queries, spec.term, spec.plan, &stats, progress);
    bake.value.resize(n);
    bake.std_error.resize(n);
    double max_se = 0;
    for (std::size_t i = 0; i < n; ++i) {
        bake.value[i] = float(estimates[i].term);
        bake.std_error[i] = float(estimates[i].std_error);
        max_se = std::max(max_se, estimates[i].std_error);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    bake.metadata = {{"method", to_string(spec.plan.method)},
                     {"form", to_string(spec.term.form)}, {"ao_weighting", to_string(spec.term.ao_weighting)},
                     {"azimuth_nodes", spec.azimuth_nodes}, {"queries", n},
                     {"sampled", stats.sampled},       {"exact_zero", stats.exact_zero},
                     {"exact_one", stats.exact_one},   {"max_std_error", max_se},
                     {"seconds", seconds},             {"device", backend.name()},
                     {"command_line", spec.command_line}, {"version", MICROSHADOW_VERSION}};
    // What decided the texels and what their std_error holds: the exact method's tolerance and rule (an
    // estimated error), or the sampled method's point set (a replicate standard error).
    if (spec.plan.method == Method::exact) {
        bake.metadata["exact"] = exact_provenance(spec.plan);
    } else {
        bake.metadata["samples"] = spec.plan.samples;
        bake.metadata["replicates"] = spec.plan.replicates;
        bake.metadata["seed"] = spec.plan.seed;
        bake.metadata["sequence"] = to_string(spec.plan.sequence);
    }
    return bake;
}

std::vector<AnisotropicSurface> anisotropic_surfaces(const AnisotropicBakeSpec& spec, double alpha_v, double alpha_l) {
    std::vector<AnisotropicSurface> out;
    for (const Config& c : slab_configs(alpha_v, alpha_l, spec))
        out.push_back({c.dphi, c.rho, c.surface.alpha_x, c.surface.alpha_y, c.surface.axis_angle});
    return out;
}

std::unique_ptr<Representation> bake_anisotropic(const AnisotropicBakeSpec& spec, TermBackend& backend,
                                                 const std::function<void(std::size_t, std::size_t)>& progress,
                                                 const std::string& preset_name, std::optional<LookupDomain> domain) {
    validate_anisotropic(spec);
    const auto start = std::chrono::steady_clock::now();
    const ReprGrid& g = spec.grid;
    const std::uint32_t R = std::uint32_t(g.roughness.size());
    const std::size_t block = std::size_t(g.visibility) * g.n_dot_l * g.n_dot_v;
    const std::size_t width = std::size_t(g.visibility) * R, height = g.n_dot_l;
    std::vector<float> rgba(width * height * g.n_dot_v * R * 4, 0.0f);
    // Every slab's configurations and fit first (cheap), then one evaluation of all their queries.
    std::vector<std::vector<Config>> configs(std::size_t(R) * R);
    std::size_t total = 0;
    for (std::uint32_t jv = 0; jv < R; ++jv)
        for (std::uint32_t jl = 0; jl < R; ++jl) {
            auto& c = configs[jv * R + jl];
            c = slab_configs(g.roughness[jv] * g.roughness[jv], g.roughness[jl] * g.roughness[jl], spec);
            total += c.size() * block;
        }
    if (total > (std::size_t(1) << 26)) throw std::invalid_argument("anisotropic bake: more than 2^26 texel x configuration queries");
    double bound = 0, max_error = 0, fit_sum = 0, fit_weight = 0, fit_max = 0;
    std::size_t done = 0;
    // One slab at a time (its queries, their exact values, the fit), so memory stays one slab's.
    for (std::uint32_t jv = 0; jv < R; ++jv)
        for (std::uint32_t jl = 0; jl < R; ++jl) {
            const auto& c = configs[jv * R + jl];
            std::vector<Query> queries;
            queries.reserve(c.size() * block);
            for (const Config& cf : c)
                for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
                    for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                        for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                            // V at azimuth -axis_angle and L at dphi - axis_angle in the surface's own frame.
                            const double nv = g.n_dot_v_at(ivv), nl = g.n_dot_l_at(iv, il, jl);
                            const double sv = std::sqrt(std::max(0.0, 1 - nv * nv)), sl = std::sqrt(std::max(0.0, 1 - nl * nl));
                            const double pv = -cf.surface.axis_angle, pl = cf.dphi - cf.surface.axis_angle;
                            Query q;
                            q.visibility = g.visibility_at(iv);
                            q.alpha_x = cf.surface.alpha_x, q.alpha_y = cf.surface.alpha_y;
                            q.wi = {sv * std::cos(pv), sv * std::sin(pv), nv};
                            q.wo = {sl * std::cos(pl), sl * std::sin(pl), nl};
                            queries.push_back(q);
                        }
            const auto values = evaluate(backend, queries, spec.term, spec.plan, nullptr, [&](std::size_t d, std::size_t) {
                if (progress) progress(done + d, total);
            });
            done += queries.size();
            const auto P = fit_map(c);
            // The coefficients' bound for values in [0, 1]: the largest row sum of |P|.
            for (int a = 0; a < kTerms; ++a) {
                double sum = 0;
                for (const auto& p : P) sum += std::abs(p[a]);
                bound = std::max(bound, sum);
            }
            for (std::size_t texel = 0; texel < block; ++texel) {
                std::array<double, kTerms> coef{0, 0, 0, 0};
                for (std::size_t i = 0; i < c.size(); ++i) {
                    const Estimate& e = values[i * block + texel];
                    max_error = std::max(max_error, e.std_error);
                    for (int a = 0; a < kTerms; ++a) coef[a] += P[i][a] * e.term;
                }
                // The fit's residual over the configurations, N.L-weighted (what the series misses).
                const std::uint32_t iv = std::uint32_t(texel % g.visibility), il = std::uint32_t(texel / g.visibility % g.n_dot_l),
                                    ivv = std::uint32_t(texel / (std::size_t(g.visibility) * g.n_dot_l));
                const double w = g.n_dot_l_at(iv, il, jl);
                for (std::size_t i = 0; i < c.size(); ++i) {
                    const double cd = std::cos(c[i].dphi);
                    const double sum = coef[0] + coef[1] * cd + coef[2] * (2 * cd * cd - 1) + coef[3] * c[i].rho;
                    const double e = std::clamp(sum, 0.0, 1.0) - values[i * block + texel].term;
                    fit_sum += w * e * e, fit_weight += w;
                    fit_max = std::max(fit_max, std::abs(e));
                }
                const std::size_t x = std::size_t(jl) * g.visibility + iv, z = std::size_t(jv) * g.n_dot_v + ivv;
                for (int a = 0; a < kTerms; ++a) rgba[((z * height + il) * width + x) * 4 + a] = float(coef[a]);
            }
        }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    nlohmann::json bake = {{"method", to_string(spec.plan.method)},  {"form", to_string(spec.term.form)},
                           {"ao_weighting", to_string(spec.term.ao_weighting)}, {"queries", total},
                           {"azimuth_configs", spec.azimuth_configs},   {"correlation_configs", spec.correlation_configs},
                           {"max_ratio", spec.max_ratio},               {"max_std_error", max_error},
                           {"fit_rms", fit_weight > 0 ? std::sqrt(fit_sum / fit_weight) : 0.0},
                           {"fit_max", fit_max},
                           {"seconds", seconds},                        {"device", backend.name()},
                           {"command_line", spec.command_line},         {"version", MICROSHADOW_VERSION}};
    if (spec.plan.method == Method::exact) bake["exact"] = exact_provenance(spec.plan);
    // The bound is widened by half precision's rounding (2^-11 relative) so a half file passes its own check.
    nlohmann::json meta = {{"bake", bake}, {"coefficient_bound", bound * (1 + 1e-3) + 1e-6}, {"max_ratio", spec.max_ratio},
                           {"version", MICROSHADOW_VERSION}, {"command_line", spec.command_line}};
    if (!preset_name.empty()) meta["preset"] = preset_name;
    // Without a domain given: the nodes' roughness per axis and the ratio fitted, any visibility and NdotV.
    if (!domain) {
        domain = grid_domain(g);
        domain->max_alpha_ratio = spec.max_ratio;
    }
    meta["domain"] = domain->to_json(preset_name.empty() ? "the lookups this representation was made for; outside, its axes clamp"
                                                         : "the preset's domain: its measured errors hold here; outside, its axes clamp");
    return build_anisotropic_harmonics(g, std::move(rgba), std::move(meta));
}

namespace {

// Random anisotropic queries over a domain, as docs/representations.md's measurements draw them: the
// alpha ratio uniform in [1, max_ratio], the rougher axis's roughness uniform in
// [roughness_min sqrt(ratio), roughness_max] (so both axes' roughness lie in the domain), which axis is
// rougher at random, V's and L's azimuths uniform from the tangent, visibility and NdotV uniform in the
// domain, NdotL uniform in [0, 1].
std::vector<Query> random_anisotropic_queries(const LookupDomain& d, double max_ratio, std::size_t count, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    auto between = [&](double a, double b) { return a + (b - a) * u(rng); };
    std::vector<Query> queries(count);
    for (Query& q : queries) {
        q.visibility = between(d.visibility_min, d.visibility_max);
        const double ratio = between(1, max_ratio);
        const double r_max = between(std::min(d.roughness_min * std::sqrt(ratio), d.roughness_max), d.roughness_max);
        const double a_max = r_max * r_max;
        const bool x_rougher = u(rng) < 0.5;
        q.alpha_x = x_rougher ? a_max : a_max / ratio;
        q.alpha_y = x_rougher ? a_max / ratio : a_max;
        const double nv = between(d.n_dot_v_min, d.n_dot_v_max), nl = u(rng);
        const double pv = between(0, 2 * kPi), pl = between(0, 2 * kPi);
        const double sv = std::sqrt(std::max(0.0, 1 - nv * nv)), sl = std::sqrt(std::max(0.0, 1 - nl * nl));
        q.wi = {sv * std::cos(pv), sv * std::sin(pv), nv};
        q.wo = {sl * std::cos(pl), sl * std::sin(pl), nl};
    }
    return queries;
}

// The correction's fit (repr/harmonics.cpp, "anisotropic-corrected-harmonics"). The lookup is linear in
// the correction's coefficients c (correction_stencil: base + sum_k w_k c(texel_k) . g), so c is the
// least-squares solution over random anisotropic queries of
//     minimise  sum_q NdotL_q (base_q + sum_k w_qk c(texel_qk) . g_q - term_q)^2 + lambda |c|^2,
// the N.L weight of the figures it is judged by, lambda a ridge (1e-3 of the mean weight per unknown)
// that keeps coefficients no query reads at 0. Solved by conjugate gradients on the normal equations,
// from c = 0, for a fixed number of iterations (the fit is deterministic: one thread, fixed order).
struct CorrectionFit {
    std::vector<float> rgba;
    double rms_before = 0, rms_after = 0;  // N.L-weighted, on the fitting queries, before the clamp
};
CorrectionFit fit_correction(const Representation& zero, const std::vector<Query>& queries, const std::vector<Estimate>& exact,
                             std::size_t unknown_texels, std::uint32_t iterations, AoWeighting weighting) {
    struct Row {
        std::uint32_t n;
        std::array<std::uint32_t, 16> texel;
        std::array<float, 16> weight;
        std::array<float, 4> g;
        float target, w;
    };
    std::vector<Row> rows;
    rows.reserve(queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const approx::Inputs in = approx::inputs_of(queries[i], weighting);
        if (!(in.n_dot_l > 0)) continue;
        const CorrectionStencil s = correction_stencil(zero, in);
        if (!s.active) continue;
        Row r;
        r.n = std::uint32_t(s.texels);
        for (std::size_t k = 0; k < s.texels; ++k) r.texel[k] = s.texel[k], r.weight[k] = float(s.weight[k]);
        for (int m = 0; m < 4; ++m) r.g[m] = float(s.features[m]);
        r.target = float(exact[i].term - s.base);
        r.w = float(in.n_dot_l);
        rows.push_back(r);
    }
    const std::size_t U = 4 * unknown_texels;
    double weight_sum = 0;
    for (const Row& r : rows) weight_sum += r.w;
    const double lambda = 1e-3 * weight_sum / double(U);
    // y = (A^T W A + lambda) x, the normal equations' matrix applied to x.
    auto normal = [&](const std::vector<double>& x, std::vector<double>& y) {
        for (std::size_t u = 0; u < U; ++u) y[u] = lambda * x[u];
        for (const Row& r : rows) {
            double a = 0;
            for (std::uint32_t k = 0; k < r.n; ++k)
                for (int m = 0; m < 4; ++m) a += double(r.weight[k]) * r.g[m] * x[4 * std::size_t(r.texel[k]) + m];
            a *= r.w;
            for (std::uint32_t k = 0; k < r.n; ++k)
                for (int m = 0; m < 4; ++m) y[4 * std::size_t(r.texel[k]) + m] += a * r.weight[k] * r.g[m];
        }
    };
    std::vector<double> x(U, 0.0), res(U, 0.0), p, q(U);
    double before = 0;
    for (const Row& r : rows) {
        before += r.w * double(r.target) * r.target;
        for (std::uint32_t k = 0; k < r.n; ++k)
            for (int m = 0; m < 4; ++m) res[4 * std::size_t(r.texel[k]) + m] += double(r.w) * r.target * r.weight[k] * r.g[m];
    }
    p = res;
    double rr = 0;
    for (double v : res) rr += v * v;
    for (std::uint32_t it = 0; it < iterations && rr > 0; ++it) {
        normal(p, q);
        double pq = 0;
        for (std::size_t u = 0; u < U; ++u) pq += p[u] * q[u];
        const double step = rr / pq;
        double next = 0;
        for (std::size_t u = 0; u < U; ++u) x[u] += step * p[u], res[u] -= step * q[u], next += res[u] * res[u];
        for (std::size_t u = 0; u < U; ++u) p[u] = res[u] + next / rr * p[u];
        rr = next;
    }
    CorrectionFit fit;
    fit.rgba.assign(x.begin(), x.end());
    double after = 0;
    for (const Row& r : rows) {
        double a = 0;
        for (std::uint32_t k = 0; k < r.n; ++k)
            for (int m = 0; m < 4; ++m) a += double(r.weight[k]) * r.g[m] * fit.rgba[4 * std::size_t(r.texel[k]) + m];
        after += r.w * (a - r.target) * (a - r.target);
    }
    fit.rms_before = weight_sum > 0 ? std::sqrt(before / weight_sum) : 0;
    fit.rms_after = weight_sum > 0 ? std::sqrt(after / weight_sum) : 0;
    return fit;
}

}  // namespace

std::unique_ptr<Representation> bake_preset(const Preset& p, TermBackend& backend, const std::string& command_line,
                                            const std::function<void(std::size_t, std::size_t)>& progress) {
    AzimuthBakeSpec spec;
    spec.grid = p.grid;
    spec.azimuth_nodes = p.azimuth_nodes;
    spec.plan.method = Method::exact;
    spec.term.ao_weighting = p.grid.weighting;
    spec.command_line = command_line;
    AzimuthBake bake = bake_azimuth(spec, backend, progress);
    bake.metadata["preset"] = p.name;
    bake.metadata["domain"] = p.domain.to_json("the preset's domain: its measured errors hold here; outside, its axes clamp");
    return build_preset(p, bake, backend);
}

std::unique_ptr<Representation> build_preset(const Preset& p, const AzimuthBake& bake, TermBackend& backend) {
    if (p.kind != "anisotropic-corrected-harmonics") return build_representation(p.kind, bake);
    // The correction: the exact term at random anisotropic queries of the domain, and the least-squares
    // coefficients that bring the mapped lookup (the zero correction) nearest to it.
    const auto start = std::chrono::steady_clock::now();
    const auto zero = build_anisotropic_corrected(bake, {}, nlohmann::json::object());
    const auto queries = random_anisotropic_queries(p.domain, p.max_ratio, p.correction_queries, p.correction_seed);
    SamplingPlan plan;
    plan.method = Method::exact;
    TermOptions term;
    term.ao_weighting = p.grid.weighting;
    const auto exact = evaluate(backend, queries, term, plan);
    const CorrectionFit fit = fit_correction(*zero, queries, exact, anisotropic_correction_texels(p.grid), p.correction_iterations,
                                             p.grid.weighting);
    const nlohmann::json how = {
        {"method", "least squares (N.L-weighted, ridge 1e-3, conjugate gradients) over random anisotropic queries of the domain"},
        {"queries", p.correction_queries}, {"seed", p.correction_seed}, {"iterations", p.correction_iterations},
        {"max_ratio", p.max_ratio}, {"fit_rms_before", fit.rms_before}, {"fit_rms_after", fit.rms_after},
        {"seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}};
    return build_anisotropic_corrected(bake, fit.rgba, how);
}

std::shared_ptr<const Representation> baked_preset(const std::string& name) {
    static std::mutex mutex;
    static std::map<std::string, std::shared_ptr<const Representation>> baked;
    const std::lock_guard<std::mutex> lock(mutex);
    auto& slot = baked[name];
    if (!slot) {
        auto backend = make_oracle_backend();
        slot = bake_preset(preset(name), *backend, "preset " + name);
    }
    return slot;
}

schedule::CacheKey repr_cache_key(const AzimuthBakeSpec& spec, TermBackend& backend) {
    const ReprGrid& g = spec.grid;
    schedule::CacheKey key("repr-bake");
    key.add("grid.visibility", g.visibility)
        .add("grid.n_dot_l", g.n_dot_l)
        .add("grid.n_dot_v", g.n_dot_v)
        .add("grid.roughness", g.roughness)
        .add("grid.warps", {to_string(g.warps.n_dot_v), to_string(g.warps.n_dot_l), to_string(g.warps.visibility)})
        .add("grid.weighting", to_string(g.weighting))
        .add("grid.edge_width", g.edge_width)
        .add("grid.placement", to_string(g.placement))
        .add("grid.n_dot_v_start", g.n_dot_v_start)
        .add("grid.azimuth_warp", g.azimuth_warp)
        .add("grid.visibility_start", g.visibility_start)
        .add("grid.visibility_edge_share", g.visibility_edge_share)
        .add("grid.visibility_edge_width", g.visibility_edge_width)
        .add("grid.visibility_edge_view", g.visibility_edge_view)
        .add("grid.n_dot_l_edge_view", g.n_dot_l_edge_view)
        .add("azimuth_nodes", spec.azimuth_nodes);
    add_sampling_plan(key, spec.plan);
    add_term_options(key, spec.term);
    add_build(key, backend.config().build);
    add_results_place(key, backend.scheduler());
    return key;
}

const std::vector<std::string>& repr_cache_key_exclusions() {
    static const std::vector<std::string> excluded = {
        "command_line: provenance only, recorded in the file",
    };
    return excluded;
}

}  // namespace ms::repr
