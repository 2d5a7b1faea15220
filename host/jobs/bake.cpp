// LUT bakes as a job: the layouts, the scheduler run of the LUT slice integrand, and the metadata of the
// file. The algorithm and its derivation live in host/integrands/lut_slice/ and kernels/lut_slice/.
#include "jobs/bake.hpp"

#include "core/digest.hpp"
#include "jobs/cache_keys.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <stdexcept>

#include "exact/cap_region.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_lut_integrand.hpp"
#include "integrands/lut_slice/lut_slice_integrand.hpp"
#include "lut/formats/lut_formats.hpp"

namespace ms {

std::string to_string(LutLayout l) {
    switch (l) {
        case LutLayout::seed_3d: return "seed-3d";
        case LutLayout::seed_2d: return "seed-2d";
        case LutLayout::custom: return "custom";
    }
    return "?";
}

LutLayout parse_lut_layout(const std::string& s) {
    if (s == "seed-3d") return LutLayout::seed_3d;
    if (s == "seed-2d") return LutLayout::seed_2d;
    if (s == "custom") return LutLayout::custom;
    throw std::invalid_argument("layout must be seed-3d, seed-2d or custom, not '" + s + "'");
}

BakeSpec default_bake_spec(LutLayout layout, std::uint32_t size) {
    BakeSpec s;
    s.layout = layout;
    s.visibility.count = s.n_dot_l.count = s.n_dot_v.count = size;
    if (layout == LutLayout::seed_2d) s.n_dot_v = Axis{"n_dot_v", 1, 1, 1, TexelConvention::centres};
    return s;
}

float BakeResult::at(std::uint32_t c, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv) const {
    return value.at(AtlasShape{width, n_dot_l_count, height / std::max(1u, n_dot_l_count), channels}.index(c, iv, il, ivv));
}

std::uint64_t bake_host_memory(const BakeSpec& spec, std::size_t places) {
    validate(spec);
    return lut_slice::memory_estimate(lut_slice::make_slice_plan(spec), places).host_bytes;
}

BakeResult bake_lut(const BakeSpec& spec, const BakeCallbacks& callbacks) {
    validate(spec);  // before any device is touched
    schedule::Scheduler scheduler(spec.backend);
    return bake_lut(spec, scheduler, callbacks);
}

namespace {

// Where the slices came from: this process's places, the chunk store, or other processes (a merge: the
// shards' devices and reruns as they recorded them).
void record_run(BakeResult& result, const schedule::ItemRunReport& run, const schedule::Scheduler& scheduler) {
    result.devices = !run.devices.empty() ? run.devices
                     : scheduler.is_oracle() ? std::vector<std::string>{scheduler.name()}
                                             : scheduler.device_labels();
    result.failed_devices = run.run.failed_places;
    result.rerun_chunks = run.rerun;
    result.complete = run.complete;
    result.loaded_slices = run.loaded;
    result.computed_slices = run.run.done;
}

// The exact method: every texel by the deterministic evaluator, one work item per slice.
BakeResult bake_lut_exact(const BakeSpec& spec, schedule::Scheduler& scheduler, const BakeCallbacks& callbacks,
                          const schedule::ItemPlan& items, std::chrono::steady_clock::time_point start) {
    exact_term::ExactConfig config;
    config.tolerance = spec.tolerance > 0 ? spec.tolerance : kDefaultExactBakeTolerance;
    config.build = spec.build;
    config.force_float = spec.exact_single_precision;
    config.kernel_on_cpu_devices = spec.exact_kernel_on_cpu;
    exact_term::ExactLutIntegrand integrand(spec, config);
    schedule::RunCallbacks run_callbacks;
    if (callbacks.progress)
        run_callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { callbacks.progress(done, total); };
    const schedule::ItemRunReport run = schedule::run_items(scheduler, integrand, items, run_callbacks);
    BakeResult result;
    record_run(result, run, scheduler);
    result.width = spec.visibility.count;
    result.n_dot_l_count = spec.n_dot_l.count;
    result.height = spec.n_dot_l.count * spec.n_dot_v.count;
    result.channels = std::uint32_t(spec.roughness.size());
    result.texels = std::uint64_t(result.width) * result.height * result.channels;
    result.value = integrand.values();
    result.std_error = integrand.errors();
    result.max_std_error = integrand.max_error();
    result.slices = integrand.work_items();
    result.skipped_zero = integrand.exact_zero();
    result.skipped_one = integrand.exact_one();
    result.exact_quadrature_pieces = integrand.quadrature_pieces();
    result.exact_tolerance = config.tolerance;
    result.tolerance_met = result.max_std_error <= config.tolerance;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

}  // namespace

BakeResult bake_lut(const BakeSpec& spec, schedule::Scheduler& scheduler, const BakeCallbacks& callbacks,
                    const schedule::ItemPlan& items) {
    validate(spec);
    const auto start = std::chrono::steady_clock::now();
    if (spec.method == Method::exact) return bake_lut_exact(spec, scheduler, callbacks, items, start);
    lut_slice::LutSliceIntegrand integrand(spec);
    const lut_slice::SlicePlan& plan = integrand.plan();

    schedule::RunCallbacks run_callbacks;
    if (callbacks.progress)
        run_callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { callbacks.progress(done, total); };
    const schedule::ItemRunReport run = schedule::run_items(scheduler, integrand, items, run_callbacks);

    BakeResult result;
    record_run(result, run, scheduler);
    result.width = plan.nv;
    result.height = plan.nl * plan.nvv;
    result.n_dot_l_count = plan.nl;
    result.channels = plan.channels;
    result.texels = std::uint64_t(result.width) * result.height * result.channels;
    result.value = integrand.values();
    result.std_error = integrand.std_errors();
    result.slices = plan.slices();
    result.samples_per_batch = plan.batch_samples;
    result.azimuth_nodes = std::uint32_t(plan.node_degrees.size());
    result.azimuth_cells = plan.cells;
    for (std::uint32_t il = 0; il < plan.nl; ++il)
        for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
            const std::uint8_t s = plan.texel(il, iv);
            result.skipped_zero += (s == lut_slice::exact_zero) * result.slices;
            result.skipped_one += (s == lut_slice::exact_one) * result.slices;
        }
    std::uint64_t max_batches_used = 0;
    for (const auto& r : integrand.reports()) {
        result.max_std_error = std::max(result.max_std_error, r.max_std_error);
        result.device_seconds += r.device_seconds;
        result.normals_seconds += r.normals_seconds;
        result.histogram_seconds += r.histogram_seconds;
        result.reduce_seconds += r.reduce_seconds;
        result.batches += r.batches;
        max_batches_used = std::max<std::uint64_t>(max_batches_used, r.batches);
        result.sample_node_rows += r.histogram_updates;
        result.azimuth_quadrature_error = std::max(result.azimuth_quadrature_error, r.quadrature_error);
        for (int k : r.row_intervals)
            if (k >= 0) ++result.azimuth_rows_by_intervals[std::uint32_t(k)];
        if (spec.tolerance > 0 && r.max_std_error > spec.tolerance) result.tolerance_met = false;
    }
    result.max_samples_per_slice = max_batches_used * plan.batch_samples;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

schedule::CacheKey bake_cache_key(const BakeSpec& spec, const schedule::Scheduler& scheduler) {
    schedule::CacheKey key("bake");
    for (const Axis* a : {&spec.visibility, &spec.n_dot_l, &spec.n_dot_v})
        key.add("axis." + a->name, {a->name, a->min, a->max, a->count, int(a->texel), int(a->spacing)});
    key.add("layout", to_string(spec.layout))
        .add("roughness", spec.roughness)
        .add("azimuth_mean", spec.azimuth_mean)
        .add("azimuth_degrees", spec.azimuth_degrees)
        .add("azimuth_intervals", spec.azimuth_intervals)
        .add("azimuth_min_intervals", spec.azimuth_min_intervals)
        .add("azimuth_max_intervals", spec.azimuth_max_intervals)
        .add("azimuth_refine_threshold", spec.azimuth_refine_threshold)
        .add("azimuth_refine_z", spec.azimuth_refine_z)
        .add("azimuth_quadrature", to_string(spec.azimuth_quadrature))
        .add("azimuth_cells", spec.azimuth_cells)
        .add("sequence", to_string(spec.sequence))
        .add("replicates", spec.replicates)
        .add("samples", spec.samples)
        .add("seed", spec.seed)
        .add("tolerance", spec.tolerance)
        .add("max_batches", spec.max_batches)
        .add("method", to_string(spec.method))
        .add("exact_single_precision", spec.exact_single_precision)
        .add("exact_kernel_on_cpu", spec.exact_kernel_on_cpu)
        // A partial bake's row flags by their digest (one byte a row would make the key text long).
        .add("baked_rows", {spec.baked_rows.size(), hex16(fnv1a(std::string(spec.baked_rows.begin(), spec.baked_rows.end())))})
        .add("oracle", spec.backend.is_oracle());
    if (spec.method == Method::exact) add_exact_rules(key, spec.tolerance);
    add_term_options(key, spec.term);
    add_build(key, spec.build);
    add_results_place(key, scheduler);
    return key;
}

const std::vector<std::string>& bake_cache_key_exclusions() {
    static const std::vector<std::string> excluded = {
        "backend.device: which devices of a kind run the bake; their kind is the key's `results`",
        "backend.threads: how many threads share the oracle's slices, not what a slice holds",
        "command_line: provenance only, recorded in the file",
    };
    return excluded;
}

schedule::StoreKey bake_store_key(const BakeSpec& spec, const schedule::Scheduler& scheduler) {
    return bake_cache_key(spec, scheduler).store_key(std::uint64_t(spec.n_dot_v.count) * spec.roughness.size());
}

nlohmann::json bake_metadata(const BakeSpec& spec, const BakeResult& r) {
    nlohmann::json m;
    m["layout"] = to_string(spec.layout);
    m["method"] = to_string(spec.method);
    if (spec.method == Method::exact) {
        const exact::ArcRule rule = exact::arc_rule_for(0.25 * r.exact_tolerance);
        m["azimuth"] = spec.azimuth_mean ? nlohmann::json("mean") : nlohmann::json(spec.azimuth_degrees);
        if (spec.azimuth_mean) {
            const exact::AzimuthRule azimuth = exact::azimuth_rule_for(r.exact_tolerance);
            m["azimuth_quadrature"] =
                "pieces of [0, 180] degrees between the azimuths where the term is not analytic, cosine-substituted, "
                "graded from complex events (rho = " + std::to_string(azimuth.rho).substr(0, 3) +
                "), the Gauss-Kronrod pair of " + std::to_string(azimuth.nodes) + " and " +
                std::to_string(2 * azimuth.nodes + 1) + " points on each piece (the value the Kronrod sum, the estimate "
                "its difference to the Gauss sum), bisected until that difference is within the piece's share of the "
                "tolerance";
        }
        m["rule"] = "boundary integral; arcs in closed form (partial fractions over the circle quartic's roots, on the "
                    "C++ evaluator solved once per visibility, NdotL and roughness row with the view rotated) where its "
                    "bound meets the arc's share of the tolerance, else Gauss-Legendre " +
                    std::to_string(rule.high) + "/" + std::to_string(rule.low) +
                    " nodes, poles outside the Bernstein ellipse rho = " + std::to_string(rule.rho).substr(0, 3);
        m["tolerance"] = r.exact_tolerance;
        m["tolerance_met"] = r.tolerance_met;
        m["max_error"] = r.max_std_error;
        m["max_error_kind"] = "largest per-texel recorded error of the exact method (quadrature estimates: each piece's "
                              "difference of two rules, the terms' own estimates, plus the float texel's rounding); "
                              "tolerance_met compares it with the tolerance";
        m["quadrature_pieces"] = r.exact_quadrature_pieces;
        m["form"] = to_string(spec.term.form);
        m["ao_weighting"] = to_string(spec.term.ao_weighting);
        m["skipped_zero"] = r.skipped_zero;
        m["skipped_one"] = r.skipped_one;
        m["n_dot_v_clamp_min"] = kMinNdotV;
        m["n_dot_l_clamp_min"] = kMinNdotL;
        m["rerun_chunks"] = r.rerun_chunks;
        std::string devices;
        for (std::size_t i = 0; i < r.devices.size(); ++i) devices += (i ? "; " : "") + r.devices[i];
        m["device"] = devices;
        m["kernel_precision"] = spec.backend.is_oracle() ? "C++ double" : (spec.exact_single_precision ? "float" : "double where the device has fp64, else float");
        if (!spec.backend.is_oracle()) {
            exact_term::ExactConfig engines;
            engines.force_float = spec.exact_single_precision;
            engines.kernel_on_cpu_devices = spec.exact_kernel_on_cpu;
            m["engines"] = exact_term::describe_engines(engines);
        }
        m["backend"] = spec.backend.kind_name();
        m["version"] = MICROSHADOW_VERSION;
        m["program"] = "microshadow " MICROSHADOW_VERSION;
        m["command_line"] = spec.command_line;
        return m;
    }
    if (spec.azimuth_mean) {
        m["azimuth"] = "mean";
        if (r.azimuth_cells) {
            m["azimuth_quadrature"] = "stratified: midpoint rule over cells of [0, 180] degrees, each cell's own samples";
            m["azimuth_cells"] = r.azimuth_cells;
        } else if (spec.azimuth_intervals) {
            m["azimuth_nodes"] = spec.azimuth_intervals + 1;
            m["azimuth_quadrature"] = "trapezoid on [0, 180] degrees";
        } else {
            m["azimuth_nodes"] = r.azimuth_nodes;  // the finest grid a row may use
            m["azimuth_quadrature"] = "adaptive nested trapezoid on [0, 180] degrees, per (slice, NdotL row)";
            m["azimuth_intervals_min"] = spec.azimuth_min_intervals;
            m["azimuth_intervals_max"] = spec.azimuth_max_intervals;
            m["azimuth_refine_threshold"] = spec.azimuth_refine_threshold;
            m["azimuth_refine_z"] = spec.azimuth_refine_z;
            nlohmann::json rows = nlohmann::json::object();
            for (const auto& [k, n] : r.azimuth_rows_by_intervals) rows[std::to_string(k)] = n;
            m["azimuth_rows_by_intervals"] = rows;
        }
        // max over sampled rows of |T_k/2 - T_k| (same points) at the intervals k the row used; the
        // stratified midpoint rule has no nested estimate (docs/bench/bake_time_to_error.md).
        if (!r.azimuth_cells) m["azimuth_quadrature_error"] = r.azimuth_quadrature_error;
    } else {
        m["azimuth"] = spec.azimuth_degrees;
    }
    m["form"] = to_string(spec.term.form);
    m["ao_weighting"] = to_string(spec.term.ao_weighting);
    m["sequence"] = to_string(spec.sequence);
    m["seed"] = spec.seed;
    m["replicates"] = spec.replicates;
    m["samples"] = r.samples_per_batch;  // per batch and slice, all replicates
    m["max_samples_per_slice"] = r.max_samples_per_slice;
    m["batches"] = r.batches;
    m["tolerance"] = spec.tolerance;
    m["tolerance_met"] = r.tolerance_met;
    m["max_error"] = r.max_std_error;
    m["max_error_kind"] = "largest per-texel standard error (replicate spread)";
    m["skipped_zero"] = r.skipped_zero;
    m["skipped_one"] = r.skipped_one;
    m["n_dot_v_clamp_min"] = kMinNdotV;
    m["n_dot_l_clamp_min"] = kMinNdotL;
    m["rerun_chunks"] = r.rerun_chunks;  // chunks rerun after a device failed (the data do not depend on it)
    std::string devices;
    for (std::size_t i = 0; i < r.devices.size(); ++i) devices += (i ? "; " : "") + r.devices[i];
    m["device"] = devices;
    m["fast_math"] = spec.build.fast_math;
    m["double_kernels"] = spec.build.double_precision;
    m["backend"] = spec.backend.kind_name();
    m["version"] = MICROSHADOW_VERSION;
    m["program"] = "microshadow " MICROSHADOW_VERSION;
    m["command_line"] = spec.command_line;
    return m;
}

std::vector<LutChannel> bake_channels(const BakeSpec& spec) {
    std::vector<LutChannel> channels;
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < spec.roughness.size(); ++c) {
        const double r = spec.roughness[c];
        channels.push_back({names[c], r, r * r, r * r});
    }
    return channels;
}

LutFile bake_lut_file(const BakeSpec& spec, const BakeResult& result, nlohmann::json metadata) {
    return lutfmt::make_lut_file({spec.visibility, spec.n_dot_l, spec.n_dot_v}, bake_channels(spec), result.value,
                                 std::move(metadata));
}

}  // namespace ms
