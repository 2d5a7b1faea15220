// microshadow bake: part 2's 3D/2D micro-shadowing LUTs (or a custom layout) to OpenEXR, KTX2, DDS, a C header or a PNG
// atlas, and bake --scene. The runs are jobs (jobs/bake_run.hpp): this file turns flags into their specs and prints.
#include <iostream>
#include <memory>

#include "cli/bake_outputs.hpp"  // file formats, preview checks, shaders
#include "cli/common.hpp"
#include "cli/mpi_world.hpp"
#include "cli/progress.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "jobs/bake_run.hpp"

namespace ms::cli {

namespace {

struct BakeArgs {
    std::string layout = "seed-3d", out, preview, texel = "centres", azimuth = "mean", azimuth_quadrature = "nodes";
    std::uint32_t size = 32, size_visibility = 0, size_n_dot_l = 0, size_n_dot_v = 0;
    std::vector<double> roughness, visibility_range, n_dot_l_range, n_dot_v_range;
    std::uint32_t azimuth_intervals = 0, azimuth_cells = 32, max_batches = 64, verify = 0;
    std::string verify_method = "exact";
    double tolerance = 0;
    bool half = false;
    SamplingOptions sampling;
    BakeOutputArgs outputs;  // --format --encoding --shader-glsl --shader-hlsl (cli/bake_outputs.hpp)
    CLI::App* cmd = nullptr;
    // bake what a scene needs (jobs/scene_bake.hpp)
    std::string scene, scene_report, scene_layout = "fit";
    bool no_scene_compare = false;
    bool allow_tolerance_miss = false;
    double scene_error = 0.01;
    // Beyond one process (docs/cluster.md): shards and their chunk store, the merge, MPI ranks.
    DistributionArgs distribution;
};

// The oracle bake of a 16^3 x 4 layout at the default samples takes about a minute on 2 cores; larger
// layouts belong on a device (and --verify checks them against the oracle texel by texel).
constexpr std::uint64_t kMaxOracleBakeTexels = 16 * 16 * 16 * 4;

bool given(CLI::App* cmd, const std::string& name) { return cmd->get_option(name)->count() > 0; }

void set_range(LutAxis& axis, const std::vector<double>& range) {
    if (range.empty()) return;
    if (range.size() != 2) throw std::invalid_argument("--" + axis.name + "-range takes MIN,MAX");
    axis.min = range[0];
    axis.max = range[1];
}

BakeSpec make_spec(const BakeArgs& a) {
    const LutLayout layout = parse_lut_layout(a.layout);
    if (layout != LutLayout::custom) {
        for (const char* o : {"--roughness", "--visibility-range", "--n-dot-l-range", "--n-dot-v-range"})
            if (given(a.cmd, o)) throw std::invalid_argument(std::string(o) + " needs --layout custom");
    }
    if (layout == LutLayout::seed_2d && given(a.cmd, "--n-dot-v-count"))
        throw std::invalid_argument("--n-dot-v-count does not apply to seed-2d (the NdotV = 1 slice)");
    if (given(a.cmd, "--samples") && given(a.cmd, "--tolerance"))
        throw std::invalid_argument("give --samples or --tolerance, not both (--tolerance adds batches of the default size)");

    BakeSpec s = default_bake_spec(layout, a.size);
    if (a.size_visibility) s.visibility.count = a.size_visibility;
    if (a.size_n_dot_l) s.n_dot_l.count = a.size_n_dot_l;
    if (a.size_n_dot_v) s.n_dot_v.count = a.size_n_dot_v;
    const TexelConvention texel = parse_texel_convention(a.texel);
    s.visibility.texel = s.n_dot_l.texel = texel;
    if (layout != LutLayout::seed_2d) s.n_dot_v.texel = texel;
    if (layout == LutLayout::custom) {
        if (!a.roughness.empty()) s.roughness = a.roughness;
        set_range(s.visibility, a.visibility_range);
        set_range(s.n_dot_l, a.n_dot_l_range);
        set_range(s.n_dot_v, a.n_dot_v_range);
    }
    if (a.azimuth == "mean") {
        s.azimuth_mean = true;
    } else {
        std::size_t used = 0;
        double deg = 0;
        try {
            deg = std::stod(a.azimuth, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != a.azimuth.size()) throw std::invalid_argument("--azimuth must be 'mean' or degrees in [0, 180], not '" + a.azimuth + "'");
        s.azimuth_mean = false;
        s.azimuth_degrees = deg;
    }
    if (given(a.cmd, "--azimuth-intervals") && !s.azimuth_mean)
        throw std::invalid_argument("--azimuth-intervals applies to --azimuth mean only");
    s.azimuth_intervals = a.azimuth_intervals;
    s.azimuth_quadrature = parse_azimuth_quadrature(a.azimuth_quadrature);
    if ((given(a.cmd, "--azimuth-quadrature") || given(a.cmd, "--azimuth-cells")) && !s.azimuth_mean)
        throw std::invalid_argument("--azimuth-quadrature and --azimuth-cells apply to --azimuth mean only");
    if (given(a.cmd, "--azimuth-cells") && s.azimuth_quadrature != AzimuthQuadrature::stratified)
        throw std::invalid_argument("--azimuth-cells applies to --azimuth-quadrature stratified only");
    if (given(a.cmd, "--azimuth-intervals") && s.azimuth_quadrature == AzimuthQuadrature::stratified)
        throw std::invalid_argument("--azimuth-intervals applies to --azimuth-quadrature nodes only");
    s.azimuth_cells = a.azimuth_cells;
    const SamplingPlan plan = a.sampling.plan();
    s.term = a.sampling.term_options();
    s.sequence = plan.sequence;
    s.replicates = plan.replicates;
    s.seed = plan.seed;
    s.samples = given(a.cmd, "--samples") ? plan.samples : 0;
    s.tolerance = given(a.cmd, "--tolerance") ? a.tolerance : 0.0;
    s.method = plan.method;
    s.exact_single_precision = a.sampling.exact_single_precision;
    s.exact_kernel_on_cpu = a.sampling.exact_kernel;
    if (s.method == Method::exact) {
        for (const char* o : {"--samples", "--seed", "--replicates", "--sequence", "--max-batches", "--azimuth-intervals",
                              "--azimuth-quadrature", "--azimuth-cells", "--double-kernels"})
            if (given(a.cmd, o))
                throw std::invalid_argument(std::string(o) + " applies to --method sampled only (the exact method "
                                            "integrates every texel to --tolerance)");
        if (s.tolerance > 0) exact_term::validate_tolerance(s.tolerance);
    }
    s.max_batches = a.max_batches;
    s.backend = a.sampling.backend_spec();
    s.build = a.sampling.build_config();
    if (s.backend.is_oracle() && s.method == Method::sampled) {
        if (a.sampling.double_kernels || a.sampling.fast_math)
            throw std::invalid_argument("--double-kernels and --fast-math build kernels; the oracle bake has none (it is double already)");
        // The oracle integrates every sampled texel on its own: nv times the kernel's work per direction.
        const std::uint64_t texels = std::uint64_t(s.visibility.count) * s.n_dot_l.count * s.n_dot_v.count * s.roughness.size();
        if (texels > kMaxOracleBakeTexels)
            throw std::invalid_argument("--backend oracle bakes layouts of up to " + std::to_string(kMaxOracleBakeTexels) +
                                        " texels x channels (this one has " + std::to_string(texels) +
                                        "); check a large bake against the oracle with --verify K instead");
    }
    s.command_line = command_line();
    validate(s);
    return s;
}

// --- bake --scene (the scene's domain decides the bake; jobs/bake_run.hpp) ---
void run_scene_bake_command(const BakeArgs& args, MpiWorld* world) {
    for (const char* o : {"--preview", "--verify", "--verify-method", "--half", "--format", "--encoding", "--shader-glsl", "--shader-hlsl", "--shader-wgsl",
                          "--shader-prefix", "--ao-weighting", "--form"})
        if (args.cmd->get_option(o)->count() > 0) throw std::invalid_argument(std::string(o) + " does not apply to --scene");
    if (args.out.size() < 4 || args.out.substr(args.out.size() - 4) != ".exr")
        throw std::invalid_argument("--scene writes an OpenEXR LUT (its coverage record is in the metadata): --out must end in .exr");
    if (args.scene_report.empty()) throw std::invalid_argument("--scene needs --scene-report DIR (histograms and the report)");
    SceneBakeJobSpec job;
    job.base = make_spec(args);
    job.scene = args.scene, job.out = args.out, job.report = args.scene_report;
    job.options.fit = args.scene_layout == "fit";
    job.options.compare = !args.no_scene_compare;
    job.options.serve_error = args.scene_error;
    job.distribution = distribution_request(args.distribution, world);
    job.writer = !world || world->writer();
    job.command_line = command_line();
    const bool quiet = args.sampling.quiet;
    // One progress line per phase (the scene bake, the full bake, the default LUT, the reference).
    std::unique_ptr<Progress> progress;
    std::string phase;
    SceneBakeJobCallbacks callbacks;
    callbacks.progress = [&](const std::string& p, std::size_t done, std::size_t total) {
        if (p != phase) {
            if (progress) progress->finish();
            progress = std::make_unique<Progress>("bake --scene: " + p, quiet || !job.writer);
            phase = p;
        }
        progress->update(done, total);
    };
    callbacks.warn = [quiet](const std::string& w) {
        if (!quiet) std::cerr << "\nbake --scene: warning: " << w << "\n";
    };
    const SceneBakeJobResult r = run_scene_bake_job(job, callbacks);
    if (progress) progress->finish();
    if (!quiet && r.written) std::cerr << scene_bake_job_summary(job, r);
    if (!quiet && !r.written && !world) std::cerr << r.shard_note;
}

// The written bake's texels against the tolerance asked of them (the exact method's default when none
// was given; a sampled bake without --tolerance asked none).
ToleranceCheck bake_tolerance_check(const BakeJobSpec& job, const BakeJobResult& r) {
    ToleranceCheck check;
    if (!r.written) return check;
    check.tolerance = job.bake.method == Method::exact ? r.bake.exact_tolerance : job.bake.tolerance;
    for (const float e : r.bake.std_error) check.add(e);
    return check;
}

ToleranceCheck run_bake_job(const BakeArgs& args, const BakeSpec& spec, MpiWorld* world) {
    // The output format by extension or --format, the preview and shader paths: checked before the bake.
    const lutfmt::LutOutput output = check_bake_outputs(args.outputs, args.out, args.preview, args.half);
    BakeJobSpec job;
    job.bake = spec;
    job.out = args.out, job.preview = args.preview;
    job.verify = args.verify;
    job.verify_method = parse_method(args.verify_method);
    job.distribution = distribution_request(args.distribution, world);
    job.writer = !world || world->writer();
    const bool quiet = args.sampling.quiet;
    Progress progress("bake", quiet || !job.writer);
    BakeJobCallbacks callbacks;
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    callbacks.warn = [quiet](const std::string& w) {
        if (!quiet) std::cerr << "\nbake: warning: " << w << "\n";
    };
    const BakeJobResult r = [&] {
        struct Finish {
            Progress& p;
            ~Finish() { p.finish(); }
        } finish{progress};
        return run_bake_job(job, [&](const LutFile& lut) { write_bake_outputs(args.outputs, output, args.out, lut); }, callbacks);
    }();
    if (!quiet && r.written) std::cerr << bake_job_summary(job, r);
    if (!quiet && !r.written && !world) std::cerr << r.shard_note;
    return bake_tolerance_check(job, r);
}

void run_bake(const BakeArgs& args) {
    if (!args.scene.empty()) return with_distribution(args.distribution, [&](MpiWorld* world) { run_scene_bake_command(args, world); });
    const BakeSpec spec = make_spec(args);
    // The MPI world first: every rank reads the same command line, and only rank 0 touches the outputs.
    ToleranceCheck tolerance;
    with_distribution(args.distribution, [&](MpiWorld* world) { tolerance = run_bake_job(args, spec, world); });
    // After the world has ended: a flag is not a failure of the ranks.
    finish_tolerance_check("bake", "texels", tolerance, args.allow_tolerance_miss);
}

}  // namespace

void add_bake_command(CLI::App& app) {
    auto a = std::make_shared<BakeArgs>();
    auto* cmd = app.add_subcommand("bake", "bake a micro-shadowing LUT (part 2's 3D/2D layouts or custom) to OpenEXR, KTX2, DDS, a C header or a PNG atlas");
    a->cmd = cmd;
    cmd->add_option("--layout", a->layout, "seed-3d (v, NdotL, NdotV; RGBA = roughness 0.1 0.4 0.7 1), seed-2d (NdotV = 1) or custom")
        ->check(CLI::IsMember({"seed-3d", "seed-2d", "custom"}))
        ->capture_default_str();
    cmd->add_option("--out", a->out, "output LUT file: " + lutfmt::extension_list(lutfmt::TextureUse::lut) + " (see --format)")->required();
    add_bake_output_options(cmd, a->outputs);
    cmd->add_option("--size", a->size, "texels on every axis")->transform(decimal_range(1, 4096))->capture_default_str();
    add_hidden_alias(cmd, "--size-visibility",
                     cmd->add_option("--visibility-count", a->size_visibility, "texels on the visibility axis (default: --size)")->transform(decimal_range(1, 4096)));
    add_hidden_alias(cmd, "--size-n-dot-l",
                     cmd->add_option("--n-dot-l-count", a->size_n_dot_l, "texels on the NdotL axis (default: --size)")->transform(decimal_range(1, 4096)));
    add_hidden_alias(cmd, "--size-n-dot-v",
                     cmd->add_option("--n-dot-v-count", a->size_n_dot_v, "texels on the NdotV axis (default: --size)")->transform(decimal_range(1, 4096)));
    cmd->add_option("--texel", a->texel, "texel parameters: centres (i + 0.5) / n or endpoints i / (n - 1)")
        ->check(CLI::IsMember({"centres", "centers", "endpoints"}))
        ->capture_default_str();
    cmd->add_option("--azimuth", a->azimuth, "relative azimuth of wi and wo: 'mean' (mean term over [0, 180]) or degrees")
        ->capture_default_str();
    cmd->add_option("--azimuth-intervals", a->azimuth_intervals, "trapezoid intervals of --azimuth mean (default: measured)")
        ->transform(decimal_range(1, 256));
    cmd->add_option("--azimuth-quadrature", a->azimuth_quadrature,
                    "--azimuth mean by trapezoid nodes (every sample at every node) or stratified (each sample at one "
                    "azimuth cell's midpoint: one histogram pass per row)")
        ->check(CLI::IsMember({"nodes", "stratified"}))
        ->capture_default_str();
    cmd->add_option("--azimuth-cells", a->azimuth_cells, "cells of --azimuth-quadrature stratified (a power of two)")
        ->transform(decimal_range(2, 256))
        ->capture_default_str();
    cmd->add_option("--roughness", a->roughness, "custom layout: 1 to 4 roughness values in (0, 1] (channels R, G, B, A)")
        ->delimiter(',');
    cmd->add_option("--visibility-range", a->visibility_range, "custom layout: MIN,MAX of the visibility axis")->delimiter(',');
    cmd->add_option("--n-dot-l-range", a->n_dot_l_range, "custom layout: MIN,MAX of the NdotL axis")->delimiter(',');
    cmd->add_option("--n-dot-v-range", a->n_dot_v_range, "custom layout: MIN,MAX of the NdotV axis")->delimiter(',');
    cmd->add_flag("--half", a->half, "store 16-bit half floats instead of 32-bit floats");
    cmd->add_option("--preview", a->preview, "also write a PNG picture of the slices (roughness across, NdotV down)");
    cmd->add_option("--tolerance", a->tolerance, "the estimated error asked of every texel: --method sampled adds sample batches to a slice until every texel's std error <= E; --method exact integrates each texel to E (default 1e-6)")
        ->check(real_range(1e-7, 1.0));
    cmd->add_option("--max-batches", a->max_batches, "most batches per slice with --tolerance")
        ->transform(decimal_range(1, 4096))
        ->capture_default_str();
    add_tolerance_miss_option(cmd, a->allow_tolerance_miss);
    cmd->add_option("--verify", a->verify,
                    "recompute K random texels (--verify-method) at the bake's azimuth rule; fail if one disagrees "
                    "beyond its error bar (Bonferroni-corrected Student-t)")
        ->transform(decimal_range(0, 100000));
    cmd->add_option("--verify-method", a->verify_method,
                    "what --verify recomputes with: exact (the deterministic evaluator, ~1e-10: a texel is judged "
                    "against its own error bar alone, the sharpest check, and ~10 us a node per core) or sampled "
                    "(the scalar oracle on independent points, judged against both error bars)")
        ->check(CLI::IsMember({"exact", "sampled"}))
        ->capture_default_str();
    // bake what a scene needs
    cmd->add_option("--scene", a->scene, "bake only what this scene description's lookups touch (docs/scenes.md)");
    cmd->add_option("--scene-report", a->scene_report, "with --scene: folder for the histograms and the report (created if missing)");
    cmd->add_option("--scene-layout", a->scene_layout, "with --scene: fit (axes and channels fitted to the scene) or layout (--layout's)")
        ->check(CLI::IsMember({"fit", "layout"}))
        ->capture_default_str();
    // Beyond one process (docs/cluster.md)
    add_distribution_options(cmd, a->distribution, "slices", "OUT.chunks");
    cmd->add_flag("--no-scene-compare", a->no_scene_compare, "with --scene: skip the full bake, the default LUT and the reference");
    cmd->add_option("--scene-error", a->scene_error, "with --scene: the weighted error within which the default LUT serves the scene")
        ->check(real_range(1e-6, 1.0))
        ->capture_default_str();
    add_sampling_options(cmd, a->sampling,
                         "Default sampled. On 2 CPU cores the default 32^3 x 4 azimuth-mean bake takes ~2.7 s sampled "
                         "(worst texel ~8e-4 off) and ~2.2 s exact (at 1e-6 or 1e-7: estimated within 5e-7 or 6e-8), a 64^3 "
                         "x 4 one ~11 s sampled against ~16 s exact; on a GPU the sampled bake is 2-5x faster "
                         "(docs/exact-method.md, docs/benchmarks.md)");
    // A bake's samples are per (roughness, NdotV) slice and batch, as its summary counts them.
    cmd->get_option("--samples")->description("VNDF samples per slice and batch, all replicates together (rounded up to replicates x 2^k; default 65536)");
    cmd->callback([a] { run_bake(*a); });
}

}  // namespace ms::cli
