#include "jobs/area_run.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <sstream>

#include "integrands/exact_term/exact_term_integrand.hpp"
#include "io/atomic_file.hpp"
#include "io/text.hpp"

namespace ms::area {

namespace {

nlohmann::json area_provenance(const TermOptions& term, const SamplingPlan& plan, const std::string& backend,
                               const std::string& command_line) {
    return {{"program", "microshadow " MICROSHADOW_VERSION},
            {"command_line", command_line},
            {"backend", backend},
            {"ao_weighting", to_string(term.ao_weighting)},
            {"brdf", "lambert: 1/pi; ggx: D G2 / (4 NdotV NdotL), height-correlated Smith G2, F = 1"},
            {"sequence", to_string(plan.sequence)},
            {"samples", plan.samples},
            {"replicates", plan.replicates},
            {"seed", plan.seed}};
}

}  // namespace

AreaEvalRun evaluate_area_queries(const AreaEvalMethod& method, const std::vector<AreaQuery>& queries,
                                  const JobCallbacks& callbacks) {
    JobControl control(callbacks);
    if (method.exact) exact_term::validate_tolerance(method.inner_tolerance);
    // The exact inner term is evaluated on the host's threads (the scalar double evaluator).
    auto backend = method.exact ? make_oracle_backend() : method.make_backend();
    AreaRoutineConfig config;
    if (method.exact) config.inner_term = exact_inner_term(method.term.ao_weighting, method.inner_tolerance);
    AreaEvalRun run;
    run.backend = backend->name();
    run.estimates = evaluate_area(*backend, queries, method.term, method.plan, config, &run.stats, control.progress());
    control.checkpoint();
    return run;
}

AreaEvalJobResult run_area_eval_job(const AreaEvalJobSpec& spec, const JobCallbacks& callbacks) {
    const bool exact = spec.method.exact;
    if (exact) exact_term::validate_tolerance(spec.method.inner_tolerance);
    std::vector<std::vector<double>> raw;
    const std::vector<AreaQuery> queries = read_area_csv(spec.in, spec.shape, spec.lobe, &raw);
    OutputSet outputs;
    const std::size_t csv_out = outputs.add(spec.out, false, /*allow_stdout=*/true);
    const bool sidecar = !outputs.to_stdout(csv_out);
    const std::size_t json_out = sidecar ? outputs.add(spec.out + ".json") : 0;
    AreaEvalJobResult r;
    r.queries = queries.size();
    r.run = evaluate_area_queries(spec.method, queries, callbacks);
    const auto& results = r.run.estimates;

    auto& out = outputs.stream(csv_out);
    const auto& columns = spec.shape == LightShape::sphere ? kSphereColumns : kRectColumns;
    for (const auto& c : columns) out << c << ",";
    out << "term,std_error" << (exact ? ",inner_error" : "") << "\n";
    // The exact method's tolerance is its inner term's: each light's inner error against it.
    r.tolerance.tolerance = exact ? spec.method.inner_tolerance : 0.0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const std::vector<double>& v = raw[i];  // the input columns as written
        for (double x : v) out << format_number(x) << ",";
        out << format_number(results[i].term.term) << "," << format_number(results[i].term.std_error);
        if (exact) out << "," << format_number(results[i].inner_error);
        out << "\n";
        r.max_std_error = std::max(r.max_std_error, results[i].term.std_error);
        r.max_inner_error = std::max(r.max_inner_error, results[i].inner_error);
        if (exact) r.tolerance.add(results[i].inner_error);
    }
    nlohmann::json meta = area_provenance(spec.method.term, spec.method.plan, r.run.backend, spec.command_line);
    meta["method"] = exact ? "exact" : "sampled";
    if (exact) {
        meta["exact"] = {{"inner", "the exact evaluator (boundary integrals) at every outer light direction"},
                         {"inner_tolerance", spec.method.inner_tolerance},
                         {"outer", "the light sampled as the kernel samples it (randomised replicates)"},
                         {"std_error", "the outer sampling's (Student t, replicates - 1 degrees of freedom)"},
                         {"inner_error", "deterministic bound from the inner values' estimated errors"},
                         {"max_inner_error", r.max_inner_error},
                         {"tolerance_met", r.tolerance.met()},
                         {"lights_over_tolerance", r.tolerance.over}};
    }
    meta["light"] = to_string(spec.shape);
    meta["lobe"] = to_string(spec.lobe);
    meta["queries"] = queries.size();
    meta["sampled"] = r.run.stats.sampled;
    meta["exact_zero_below_horizon"] = r.run.stats.below_horizon;
    meta["exact_zero_region"] = r.run.stats.zero_region;
    meta["exact_one"] = r.run.stats.visibility_one;
    meta["max_std_error"] = r.max_std_error;
    if (sidecar) outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    outputs.commit();
    return r;
}

std::string area_eval_job_summary(const AreaEvalJobSpec& spec, const AreaEvalJobResult& r) {
    const bool exact = spec.method.exact;
    const AreaEvalStats& stats = r.run.stats;
    std::ostringstream o;
    o << "area eval: " << r.queries << " " << to_string(spec.shape) << " lights (" << stats.sampled << (exact ? " integrated, " : " sampled, ")
      << stats.below_horizon << " below the horizon, " << stats.zero_region << " in the zero region, "
      << stats.visibility_one << " at v = 1), max std error " << std::setprecision(3) << r.max_std_error
      << (exact ? ", max inner error " + format_number(r.max_inner_error) + " " + r.tolerance.summary() : std::string()) << ", "
      << "computed in " << stats.seconds << " s on " << r.run.backend << "\n";
    return o.str();
}

AreaSweepJobResult run_area_sweep_job(const AreaSweepJobSpec& spec, const JobCallbacks& callbacks) {
    for (double g : spec.grid.half_angles_deg)
        if (!(g > 0 && g < 90)) throw std::invalid_argument("--half-angles: " + format_number(g) + " must be in (0, 90) degrees");
    for (double r : spec.grid.roughness)
        if (!(r > 0 && r <= 1)) throw std::invalid_argument("--roughness: " + format_number(r) + " must be in (0, 1]");
    for (double v : spec.grid.visibility)
        if (!(v >= 0 && v <= 1)) throw std::invalid_argument("--visibility: " + format_number(v) + " must be in [0, 1]");
    for (double n : spec.grid.n_dot_v)
        if (!(n > 0 && n <= 1)) throw std::invalid_argument("--n-dot-v: " + format_number(n) + " must be in (0, 1]");
    if (!(spec.max_half_angle > 0 && spec.max_half_angle < 90))
        throw std::invalid_argument("--max-half-angle: " + format_number(spec.max_half_angle) + " must be in (0, 90) degrees");
    const bool rect = spec.shape == LightShape::rect;
    if (rect && !spec.random)
        throw std::invalid_argument("--light rect: the sweep draws random rectangles; give --random N (the grid is of sphere lights)");
    const SamplingPlan& plan = spec.plan;
    const std::vector<StudyPoint> points =
        rect ? random_rect_points(spec.random, spec.max_half_angle, plan.seed)
             : spec.random ? random_points(spec.random, spec.max_half_angle, plan.seed) : grid_points(spec.grid);
    OutputSet outputs;
    const std::size_t csv_out = outputs.add(spec.out);
    const std::size_t json_out = outputs.add(spec.out + ".json");
    auto backend = spec.make_backend();
    JobControl control(callbacks);
    const auto rows = run_study(*backend, points, spec.term, plan, control.progress());
    control.checkpoint();
    auto& out = outputs.stream(csv_out);
    out << "lobe,half_angle_deg,roughness,visibility,n_dot_v,elevation_deg,azimuth_deg,area,area_std_error,"
           "centre,centre_std_error,representative,representative_std_error,taps,taps_std_error,"
           "centre_error,representative_error,taps_error,lobe_integral\n";
    for (const auto& r : rows) {
        const auto& q = r.point.query;
        out << to_string(q.lobe) << "," << format_number(r.point.half_angle_deg) << ","
            << format_number(r.point.roughness) << "," << format_number(q.visibility) << "," << format_number(r.point.n_dot_v)
            << "," << format_number(r.point.elevation_deg) << "," << format_number(r.point.azimuth_deg) << ","
            << format_number(r.area.term.term) << "," << format_number(r.area.term.std_error) << ","
            << format_number(r.centre.term) << "," << format_number(r.centre.std_error) << ","
            << format_number(r.representative.term) << "," << format_number(r.representative.std_error) << ","
            << format_number(r.taps.term) << "," << format_number(r.taps.std_error) << ","
            << format_number(r.centre.term - r.area.term.term) << ","
            << format_number(r.representative.term - r.area.term.term) << "," << format_number(r.taps.term - r.area.term.term)
            << "," << format_number(r.area.sampled ? r.area.lobe_integral.term : 0.0) << "\n";
    }
    nlohmann::json meta = area_provenance(spec.term, plan, backend->name(), spec.command_line);
    meta["points"] = rows.size();
    meta["light"] = to_string(spec.shape);
    if (rect) meta["half_angle_deg"] = "rect: the largest angle from the centre direction to a corner";
    meta["mode"] = spec.random ? "random" : "grid";
    if (spec.random) meta["max_half_angle_deg"] = spec.max_half_angle;
    meta["representative"] = "lambert: the centre; ggx: Karis 2013's closest point to the mirror direction";
    meta["taps"] = rect ? "the 3 x 3 Gauss-Legendre rule on the rectangle, weighted by solid angle and f cos"
                        : "Radon's 7-point degree-5 disc rule on the cone (equal-area map), weighted by f cos";
    outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    outputs.commit();
    return {rows.size(), backend->name()};
}

}  // namespace ms::area
