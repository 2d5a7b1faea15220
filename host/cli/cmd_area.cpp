// microshadow area eval | sweep: the micro-shadowing of sphere and rectangle lights, and how far the
// point lookups engines use are from it.
#include <nlohmann/json.hpp>

#include <iomanip>
#include <iostream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "jobs/area.hpp"
#include "jobs/area_shader.hpp"
#include "lut/shader/compose.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"

namespace ms::cli {

namespace {

struct AreaEvalArgs {
    std::string in, out, light = "sphere", lobe = "ggx";
    SamplingOptions sampling;
    bool samples_given = false;
    bool allow_tolerance_miss = false;
};

struct AreaSweepArgs {
    std::string out, light = "sphere";
    std::size_t random = 0;
    double max_half_angle = 30;
    area::StudyGrid grid;
    std::vector<std::string> lobes{"lambert", "ggx"};
    SamplingOptions sampling;
};

nlohmann::json provenance(const SamplingOptions& s, const SamplingPlan& plan, const std::string& backend) {
    return {{"program", "microshadow " MICROSHADOW_VERSION},
            {"command_line", command_line()},
            {"backend", backend},
            {"ao_weighting", s.ao_weighting},
            {"brdf", "lambert: 1/pi; ggx: D G2 / (4 NdotV NdotL), height-correlated Smith G2, F = 1"},
            {"sequence", to_string(plan.sequence)},
            {"samples", plan.samples},
            {"replicates", plan.replicates},
            {"seed", plan.seed}};
}

void run_area_eval(const AreaEvalArgs& args) {
    const TermOptions term = args.sampling.term_options();
    const bool exact = args.sampling.method == "exact";
    // The exact method samples the outer integral over the light (jobs/area.hpp, exact_inner_term): its
    // plan is a sampled one, with fewer samples by default; --tolerance is the inner term's.
    SamplingOptions outer = args.sampling;
    outer.method = "sampled";
    outer.tolerance = 0;
    if (exact && !args.samples_given) outer.samples = area::kExactOuterSamples;
    const SamplingPlan plan = outer.plan();
    const double inner_tolerance = args.sampling.tolerance > 0 ? args.sampling.tolerance : area::kExactInnerTolerance;
    if (exact) exact_term::validate_tolerance(inner_tolerance);
    const area::LightShape shape = area::parse_light_shape(args.light);
    const area::Lobe lobe = area::parse_lobe(args.lobe);
    std::vector<std::vector<double>> raw;
    const std::vector<area::AreaQuery> queries = area::read_area_csv(args.in, shape, lobe, &raw);
    OutputSet outputs;
    const std::size_t csv_out = outputs.add(args.out, false, /*allow_stdout=*/true);
    const bool sidecar = !outputs.to_stdout(csv_out);
    const std::size_t json_out = sidecar ? outputs.add(args.out + ".json") : 0;
    // The exact inner term is evaluated on the host's threads (the scalar double evaluator).
    auto backend = exact ? make_oracle_backend() : args.sampling.make_backend();
    area::AreaRoutineConfig config;
    if (exact) config.inner_term = area::exact_inner_term(term.ao_weighting, inner_tolerance);
    Progress progress("area eval", args.sampling.quiet);
    area::AreaEvalStats stats;
    const auto results = area::evaluate_area(*backend, queries, term, plan, config, &stats,
                                             [&](std::size_t done, std::size_t total) { progress.update(done, total); });
    progress.finish();

    auto& out = outputs.stream(csv_out);
    const auto& columns = shape == area::LightShape::sphere ? area::kSphereColumns : area::kRectColumns;
    for (const auto& c : columns) out << c << ",";
    out << "term,std_error" << (exact ? ",inner_error" : "") << "\n";
    double max_error = 0, max_inner = 0;
    // The exact method's tolerance is its inner term's: each light's inner error against it.
    ToleranceCheck tolerance{exact ? inner_tolerance : 0.0};
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const std::vector<double>& v = raw[i];  // the input columns as written
        for (double x : v) out << format_number(x) << ",";
        out << format_number(results[i].term.term) << "," << format_number(results[i].term.std_error);
        if (exact) out << "," << format_number(results[i].inner_error);
        out << "\n";
        max_error = std::max(max_error, results[i].term.std_error);
        max_inner = std::max(max_inner, results[i].inner_error);
        if (exact) tolerance.add(results[i].inner_error);
    }
    nlohmann::json meta = provenance(args.sampling, plan, backend->name());
    meta["method"] = args.sampling.method;
    if (exact) {
        meta["exact"] = {{"inner", "the exact evaluator (boundary integrals) at every outer light direction"},
                         {"inner_tolerance", inner_tolerance},
                         {"outer", "the light sampled as the kernel samples it (randomised replicates)"},
                         {"std_error", "the outer sampling's (Student t, replicates - 1 degrees of freedom)"},
                         {"inner_error", "deterministic bound from the inner values' estimated errors"},
                         {"max_inner_error", max_inner},
                         {"tolerance_met", tolerance.met()},
                         {"lights_over_tolerance", tolerance.over}};
    }
    meta["light"] = args.light;
    meta["lobe"] = args.lobe;
    meta["queries"] = queries.size();
    meta["sampled"] = stats.sampled;
    meta["exact_zero_below_horizon"] = stats.below_horizon;
    meta["exact_zero_region"] = stats.zero_region;
    meta["exact_one"] = stats.visibility_one;
    meta["max_std_error"] = max_error;
    if (sidecar) outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    outputs.commit();
    if (!args.sampling.quiet)
        std::cerr << "area eval: " << queries.size() << " " << args.light << " lights (" << stats.sampled << (exact ? " integrated, " : " sampled, ")
                  << stats.below_horizon << " below the horizon, " << stats.zero_region << " in the zero region, "
                  << stats.visibility_one << " at v = 1), max std error " << std::setprecision(3) << max_error
                  << (exact ? ", max inner error " + format_number(max_inner) + " " + tolerance.summary() : std::string()) << ", "
                  << "computed in " << stats.seconds << " s on " << backend->name() << "\n";
    finish_tolerance_check("area eval", "lights", tolerance, args.allow_tolerance_miss);
}

void run_area_sweep(AreaSweepArgs args) {
    const TermOptions term = args.sampling.term_options();
    const SamplingPlan plan = args.sampling.plan();
    args.grid.lobes.clear();
    for (const auto& l : args.lobes) args.grid.lobes.push_back(area::parse_lobe(l));
    for (double g : args.grid.half_angles_deg)
        if (!(g > 0 && g < 90)) throw std::invalid_argument("--half-angles: " + format_number(g) + " must be in (0, 90) degrees");
    for (double r : args.grid.roughness)
        if (!(r > 0 && r <= 1)) throw std::invalid_argument("--roughness: " + format_number(r) + " must be in (0, 1]");
    for (double v : args.grid.visibility)
        if (!(v >= 0 && v <= 1)) throw std::invalid_argument("--visibility: " + format_number(v) + " must be in [0, 1]");
    for (double n : args.grid.n_dot_v)
        if (!(n > 0 && n <= 1)) throw std::invalid_argument("--n-dot-v: " + format_number(n) + " must be in (0, 1]");
    if (!(args.max_half_angle > 0 && args.max_half_angle < 90))
        throw std::invalid_argument("--max-half-angle: " + format_number(args.max_half_angle) + " must be in (0, 90) degrees");
    const bool rect = args.light == "rect";
    if (rect && !args.random)
        throw std::invalid_argument("--light rect: the sweep draws random rectangles; give --random N (the grid is of sphere lights)");
    const std::vector<area::StudyPoint> points =
        rect ? area::random_rect_points(args.random, args.max_half_angle, plan.seed)
             : args.random ? area::random_points(args.random, args.max_half_angle, plan.seed) : area::grid_points(args.grid);
    OutputSet outputs;
    const std::size_t csv_out = outputs.add(args.out);
    const std::size_t json_out = outputs.add(args.out + ".json");
    auto backend = args.sampling.make_backend();
    Progress progress("area sweep", args.sampling.quiet);
    const auto rows = area::run_study(*backend, points, term, plan,
                                      [&](std::size_t done, std::size_t total) { progress.update(done, total); });
    progress.finish();
    auto& out = outputs.stream(csv_out);
    out << "lobe,half_angle_deg,roughness,visibility,n_dot_v,elevation_deg,azimuth_deg,area,area_std_error,"
           "centre,centre_std_error,representative,representative_std_error,taps,taps_std_error,"
           "centre_error,representative_error,taps_error,lobe_integral\n";
    for (const auto& r : rows) {
        const auto& q = r.point.query;
        out << area::to_string(q.lobe) << "," << format_number(r.point.half_angle_deg) << ","
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
    nlohmann::json meta = provenance(args.sampling, plan, backend->name());
    meta["points"] = rows.size();
    meta["light"] = args.light;
    if (rect) meta["half_angle_deg"] = "rect: the largest angle from the centre direction to a corner";
    meta["mode"] = args.random ? "random" : "grid";
    if (args.random) meta["max_half_angle_deg"] = args.max_half_angle;
    meta["representative"] = "lambert: the centre; ggx: Karis 2013's closest point to the mirror direction";
    meta["taps"] = rect ? "the 3 x 3 Gauss-Legendre rule on the rectangle, weighted by solid angle and f cos"
                        : "Radon's 7-point degree-5 disc rule on the cone (equal-area map), weighted by f cos";
    outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    outputs.commit();
    if (!args.sampling.quiet) std::cerr << "area sweep: " << rows.size() << " points on " << backend->name() << "\n";
}

}  // namespace

void add_area_command(CLI::App& app) {
    auto* area_cmd = app.add_subcommand("area", "micro-shadowing of area lights (sphere and rectangle): eval, sweep, shader");
    area_cmd->require_subcommand(1);

    auto eval = std::make_shared<AreaEvalArgs>();
    auto* e = area_cmd->add_subcommand("eval", "T_area for the queries of a CSV file");
    e->add_option("--in", eval->in,
                  "query CSV: visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z, then for --light sphere "
                  "light_x,light_y,light_z,half_angle_deg (centre direction, half-angle in (0, 90) degrees), for "
                  "--light rect p0_x,...,p3_z (corners in order, positions relative to the shaded point, tangent frame)")
        ->required();
    e->add_option("--out", eval->out, "result CSV: the input columns plus term,std_error, provenance in OUT.json ('-': standard output)")
        ->required();
    e->add_option("--light", eval->light, "sphere | rect")->check(CLI::IsMember({"sphere", "rect"}));
    e->add_option("--lobe", eval->lobe, "the BRDF lobe weighting the light: ggx (Fresnel-free specular at the surface's alpha) | lambert")
        ->check(CLI::IsMember({"ggx", "lambert"}));
    add_sampling_options(e, eval->sampling,
                         "Default sampled: the joint kernel. exact: the exact inner term T(wo) at each of --samples "
                         "outer light directions (default 8192), on the host's threads; std_error is the outer "
                         "sampling's and the inner_error column bounds the inner values' part");
    e->add_option("--tolerance", eval->sampling.tolerance,
                  "exact method: the estimated error asked of each inner value T(wo) (default 1e-6; 1e-13 to 0.1)")
        ->check(CLI::PositiveNumber);
    add_tolerance_miss_option(e, eval->allow_tolerance_miss);
    e->callback([eval, e] {
        eval->samples_given = e->count("--samples") > 0;
        if (eval->sampling.method == "exact") {
            // The exact inner term runs on the host: refuse settings that would be ignored.
            for (const char* o : {"--device", "--double-kernels", "--fast-math", "--exact-float"})
                if (e->count(o) > 0)
                    throw std::invalid_argument(std::string(o) + " applies to --method sampled only (the exact inner term "
                                                "runs on the host's threads)");
            if (e->count("--backend") > 0 && eval->sampling.backend != "oracle")
                throw std::invalid_argument("--backend " + eval->sampling.backend + " applies to --method sampled only (the "
                                            "exact inner term runs on the host's threads)");
        } else if (e->count("--tolerance") > 0) {
            throw std::invalid_argument("--tolerance applies to --method exact only (the inner term's tolerance)");
        }
        run_area_eval(*eval);
    });

    auto sweep = std::make_shared<AreaSweepArgs>();
    auto* s = area_cmd->add_subcommand("sweep", "sphere or rectangle lights: T_area against the point term at the centre, at the "
                                                "representative point and the tap approximation (7 taps; rectangles 9)");
    s->add_option("--out", sweep->out, "sweep CSV (and OUT.json)")->required();
    s->add_option("--light", sweep->light, "sphere (grid or --random) | rect (--random only: tilted rectangles of 1:1 to 1:3)")
        ->check(CLI::IsMember({"sphere", "rect"}));
    s->add_option("--random", sweep->random, "N random queries instead of the grid (sizes up to --max-half-angle)");
    s->add_option("--max-half-angle", sweep->max_half_angle, "largest half-angle of --random, degrees");
    s->add_option("--half-angles", sweep->grid.half_angles_deg, "grid: light half-angles, degrees")->delimiter(',');
    s->add_option("--roughness", sweep->grid.roughness, "grid: roughness (alpha = roughness^2)")->delimiter(',');
    s->add_option("--visibility", sweep->grid.visibility, "grid: visibility")->delimiter(',');
    s->add_option("--n-dot-v", sweep->grid.n_dot_v, "grid: NdotV")->delimiter(',');
    s->add_option("--elevations", sweep->grid.elevations_deg, "grid: elevation of the light's centre, degrees")->delimiter(',');
    s->add_option("--azimuths", sweep->grid.azimuths_deg, "grid: azimuth of the light's centre from the view's, degrees")->delimiter(',');
    s->add_option("--lobes", sweep->lobes, "lambert,ggx")->delimiter(',')->check(CLI::IsMember({"ggx", "lambert"}));
    add_sampling_options(s, sweep->sampling);
    s->callback([sweep] {
        // The study's T_area is the joint kernel's; half of it exact (the point terms) would mix two methods.
        if (sweep->sampling.method == "exact")
            throw std::invalid_argument("--method exact: area sweep samples T_area and the point terms alike; "
                                        "the exact inner term is `area eval --method exact`");
        run_area_sweep(*sweep);
    });

    auto lang = std::make_shared<std::string>("glsl");
    auto shader_out = std::make_shared<std::string>("-");
    auto shader_prefix = std::make_shared<std::string>();
    auto* sh = area_cmd->add_subcommand("shader", "GLSL or HLSL of the tap approximations (sphere lights 7 taps, rectangles 9; "
                                                  "they call the engine's float PREFIX_point_term(wi, wo), defined before them)");
    sh->add_option("--lang", *lang, "glsl | hlsl | wgsl")->check(CLI::IsMember({"glsl", "hlsl", "wgsl"}));
    sh->add_option("--out", *shader_out, "output file ('-': standard output, the default)");
    add_shader_prefix_option(sh, *shader_prefix);
    sh->callback([lang, shader_out, shader_prefix] {
        OutputSet outputs;
        const std::size_t i = outputs.add(*shader_out, false, /*allow_stdout=*/true);
        const auto language = lutshader::parse_shader_language(*lang);
        outputs.stream(i) << lutshader::compose(area::taps_shader(language), language,
                                                shader_prefix->empty() ? lutshader::default_prefix(*shader_out) : *shader_prefix);
        outputs.commit();
    });
}

}  // namespace ms::cli
