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
    // Where each query's value goes: queries[i] is texel and node at[i] of the bake. Sampled bakes
    // evaluate in the bake's own order (a sampled value depends on its position in the batch); exact
    // ones by (roughness, NdotL texel, visibility texel, NdotV texel, node), so that the queries of one
    // (visibility, alpha, NdotL) row of the exact evaluator's azimuth grid share a batch: a texel's nodes,
    // and every NdotV texel's where the warps make visibility and NdotL independent of NdotV.
    std::vector<std::size_t> at(n);
    const bool texel_major = spec.plan.method == Method::exact;
    std::size_t next = 0;
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
                        const std::size_t index = bake.index(r, k, iv, il, ivv);
                        const std::size_t i =
                            texel_major ? ((((std::size_t(r) * g.n_dot_l + il) * g.visibility + iv) * g.n_dot_v + ivv) *
                                               spec.azimuth_nodes + k)
                                        : next++;
                        at[i] = index;
                        Query& q = queries[i];
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
        bake.value[at[i]] = float(estimates[i].term);
        bake.std_error[at[i]] = float(estimates[i].std_error);
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
