// microshadow area eval | sweep: the micro-shadowing of sphere and rectangle lights, and how far the
// point lookups engines use are from it.
#include <iostream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "io/atomic_file.hpp"
#include "jobs/area_run.hpp"
#include "jobs/area_shader.hpp"
#include "lut/shader/compose.hpp"

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

void run_area_eval(const AreaEvalArgs& args) {
    const bool exact = args.sampling.method == "exact";
    // The exact method samples the outer integral over the light (jobs/area.hpp, exact_inner_term): its
    // plan is a sampled one, with fewer samples by default; --tolerance is the inner term's.
    SamplingOptions outer = args.sampling;
    outer.method = "sampled";
    outer.tolerance = 0;
    if (exact && !args.samples_given) outer.samples = area::kExactOuterSamples;
    area::AreaEvalJobSpec spec;
    spec.in = args.in;
    spec.out = args.out;
    spec.shape = area::parse_light_shape(args.light);
    spec.lobe = area::parse_lobe(args.lobe);
    spec.method.term = args.sampling.term_options();
    spec.method.plan = outer.plan();
    spec.method.exact = exact;
    spec.method.inner_tolerance = args.sampling.tolerance > 0 ? args.sampling.tolerance : area::kExactInnerTolerance;
    spec.method.make_backend = [&] { return args.sampling.make_backend(); };
    spec.command_line = command_line();
    Progress progress("area eval", args.sampling.quiet);
    JobCallbacks callbacks;
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    const area::AreaEvalJobResult result = area::run_area_eval_job(spec, callbacks);
    progress.finish();
    if (!args.sampling.quiet) std::cerr << area::area_eval_job_summary(spec, result);
    finish_tolerance_check("area eval", "lights", result.tolerance, args.allow_tolerance_miss);
}

void run_area_sweep(const AreaSweepArgs& args) {
    area::AreaSweepJobSpec spec;
    spec.term = args.sampling.term_options();
    spec.plan = args.sampling.plan();
    spec.out = args.out;
    spec.shape = area::parse_light_shape(args.light);
    spec.random = args.random;
    spec.max_half_angle = args.max_half_angle;
    spec.grid = args.grid;
    spec.grid.lobes.clear();
    for (const auto& l : args.lobes) spec.grid.lobes.push_back(area::parse_lobe(l));
    spec.make_backend = [&] { return args.sampling.make_backend(); };
    spec.command_line = command_line();
    Progress progress("area sweep", args.sampling.quiet);
    JobCallbacks callbacks;
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    const area::AreaSweepJobResult result = area::run_area_sweep_job(spec, callbacks);
    progress.finish();
    if (!args.sampling.quiet) std::cerr << "area sweep: " << result.points << " points on " << result.backend << "\n";
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
