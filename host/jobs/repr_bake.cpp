#include "jobs/repr_bake.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>

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
    for (std::uint32_t r = 0; r < g.roughness.size(); ++r)
        for (std::uint32_t k = 0; k < spec.azimuth_nodes; ++k) {
            const double phi = bake.azimuth_at(k);
            for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv) {
                const double nv = g.n_dot_v_at(ivv);
                for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                    for (std::uint32_t iv = 0; iv < g.visibility; ++iv) {
                        // The texel's query as eval takes it: V in the xz plane, L at azimuth phi from it.
                        const double nl = g.n_dot_l_at(iv, il, r), sl = std::sqrt(std::max(0.0, 1 - nl * nl));
                        Query& q = queries[bake.index(r, k, iv, il, ivv)];
                        q.visibility = g.visibility_at(iv);
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
    return build_representation(p.kind, bake);
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

}  // namespace ms::repr
