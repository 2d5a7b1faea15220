// microshadow sweep SPEC.toml: a parameter study of the generic term against comparators, streamed
// to disk in chunks (resumable, shardable: the shared item store). sweep SPEC --merge, or its other
// spelling microshadow merge, assembles the shards' folder (one code path: sweep::merge_shards).

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>

#include "cli/common.hpp"
#include "cli/mpi_world.hpp"
#include "cli/plot_runner.hpp"
#include "cli/progress.hpp"
#include "core/cancel.hpp"
#include "io/text.hpp"
#include "jobs/sweep/runner.hpp"

namespace ms::cli {

namespace {

namespace fs = std::filesystem;

struct SweepArgs {
    std::string spec, out, shard;
    std::uint64_t max_chunks = 0;
    bool restart = false, plot = false, mpi = false, strict_domain = false, merge = false, allow_tolerance_miss = false;
    SamplingOptions sampling;
    CLI::App* cmd = nullptr;
};

// Draws the sweep's heatmaps into OUT/figures with plot_sweep.py.
void run_plot(const std::string& out_dir) {
    // Absolute paths: a relative directory starting with '-' would read as an option to argparse.
    const fs::path dir = fs::absolute(out_dir).lexically_normal();
    run_plot_script("plot_sweep.py", {"heatmaps", (dir / "sweep.csv").string(), "--out", (dir / "figures").string()},
                    "the sweep itself is complete in " + out_dir);
}

void run_sweep_job(const SweepArgs& args, const sweep::Spec& spec, sweep::RunConfig& config, MpiWorld* world);

// What a finished sweep or merge prints: where sweep.csv went and the summary table.
void print_sweep_summary(const std::string& out_dir) {
    std::cout << "wrote " << out_dir << "/sweep.csv\n\n";
    std::ifstream md(out_dir + "/summary.md");
    std::cout << md.rdbuf();
}

void warn_sweep(const std::string& w) { std::cerr << "\nsweep: warning: " << w << "\n"; }

void run_sweep_command(SweepArgs& args) {
    sweep::Spec spec = sweep::parse_spec_file(args.spec);
    // The spec's [sampling] values are defaults; an option given on the command line wins.
    auto given = [&](const char* name) { return args.cmd->get_option(name)->count() > 0; };
    if (spec.samples && !given("--samples")) args.sampling.samples = *spec.samples;
    if (spec.replicates && !given("--replicates")) args.sampling.replicates = *spec.replicates;
    if (spec.seed && !given("--seed")) args.sampling.seed = *spec.seed;
    if (spec.sequence && !given("--sequence")) args.sampling.sequence = *spec.sequence;
    if (spec.method && !given("--method")) args.sampling.method = to_string(*spec.method);
    if (spec.tolerance && !given("--tolerance")) args.sampling.tolerance = *spec.tolerance;
    if (args.sampling.method == "sampled" && args.sampling.tolerance > 0)
        // A sweep's chunks are fixed batches of one plan; sampled accuracy is chosen with --samples.
        throw std::invalid_argument("--tolerance (or sampling.tolerance in " + args.spec +
                                    ") applies to the exact method; a sampled sweep takes --samples");
    note_unused_sampling_options(args.cmd, args.sampling);
    if (args.sampling.method == "exact" && !args.sampling.quiet &&
        (spec.samples || spec.replicates || spec.seed || spec.sequence))
        std::cerr << "note: " << args.spec << ": sampling.samples, replicates, seed and sequence are unused by the exact "
                     "method (add method = \"sampled\" to sample)\n";
    if (!spec.forms.empty() && given("--form"))
        throw std::invalid_argument("--form conflicts with parameters.form in " + args.spec + "; use one of them");
    if (!spec.weightings.empty() && given("--ao-weighting"))
        throw std::invalid_argument("--ao-weighting conflicts with parameters.ao_weighting in " + args.spec);

    // The comparator files before the devices start: a missing or damaged one is bad input, named.
    sweep::check_comparator_files(spec);

    sweep::RunConfig config;
    config.out_dir = args.out.empty() ? std::filesystem::path(args.spec).stem().string() + ".sweep" : args.out;
    config.plan = args.sampling.plan();
    config.defaults = args.sampling.term_options();
    // --shard, else a Slurm array task's (an MPI world is one job: the array variables do not apply).
    if (args.mpi && !args.shard.empty()) throw std::invalid_argument("--mpi shares the chunks among the ranks: it takes no --shard");
    const schedule::Shard shard = args.mpi ? schedule::Shard{} : resolve_shard(args.shard);
    config.shard = {shard.index, shard.count};
    config.max_chunks = args.max_chunks;
    config.restart = args.restart;
    config.strict_domain = args.strict_domain;
    config.command_line = command_line();
    if (args.merge) {
        // The shards' folder assembled: the spec and options name the sweep it must hold.
        if (args.mpi || !args.shard.empty() || args.max_chunks || args.restart)
            throw std::invalid_argument("--merge assembles the shards in --out: it takes no --shard, --mpi, --max-chunks or --restart");
        auto backend = args.sampling.make_backend();
        config.backend = backend.get();
        const auto merged = sweep::merge_shards({config.out_dir}, config.out_dir, config.command_line,
                                                sweep::sweep_cache_key(spec, config).hash(), warn_sweep);
        if (!args.sampling.quiet) print_sweep_summary(config.out_dir);
        finish_tolerance_check("sweep", "points", merged.tolerance, args.allow_tolerance_miss);
        if (args.plot) run_plot(config.out_dir);
        return;
    }
    // The MPI world before the devices: only rank 0 touches the output folder.
    std::unique_ptr<MpiWorld> world;
    if (args.mpi) world = std::make_unique<MpiWorld>();
    if (world) return world->guard([&] { run_sweep_job(args, spec, config, world.get()); });
    run_sweep_job(args, spec, config, nullptr);
}

void run_sweep_job(const SweepArgs& args, const sweep::Spec& spec, sweep::RunConfig& config, MpiWorld* world) {
    const bool rank0 = !world || world->writer();
    if (world) config.transport = &world->transport();
    auto backend = args.sampling.make_backend();
    config.backend = backend.get();
    config.warn = warn_sweep;
    Progress progress("sweep", args.sampling.quiet || !rank0);
    config.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };

    sweep::RunResult r;
    try {
        r = sweep::run_sweep(spec, config);
    } catch (const Cancelled&) {
        progress.finish();
        // One message (main prints it): unlike eval and bake, a sweep keeps what it finished.
        throw Cancelled("interrupted; the finished chunks are kept in " + config.out_dir +
                        " - rerun the same command to resume");
    }
    progress.finish();
    if (!rank0) return;  // a computing rank: rank 0 reports and writes
    for (const auto& w : r.warnings_outside_domain)
        std::cerr << "sweep: warning: " << w << "; --strict-domain refuses them\n";
    if (!args.sampling.quiet)
        std::cerr << "sweep: " << r.points << " points in " << r.chunks << " chunks of " << spec.chunk_size
                  << "; this run computed " << r.computed << ", found " << r.skipped << " finished (spec hash "
                  << r.spec_hash << ")\n";
    if (!r.complete) {
        std::cerr << "sweep: stopped after --max-chunks " << args.max_chunks << "; rerun to continue\n";
        return;
    }
    if (!r.assembled) {
        std::cerr << "sweep: shard " << config.shard.index << "/" << config.shard.count << " finished in " << config.out_dir
                  << "; when every shard has, assemble them with 'microshadow sweep " << args.spec << " --merge --out "
                  << config.out_dir << "' (or 'microshadow merge --out DIR " << config.out_dir << "')\n";
        return;
    }
    if (!args.sampling.quiet) print_sweep_summary(config.out_dir);
    finish_tolerance_check("sweep", "points", r.tolerance, args.allow_tolerance_miss);
    if (args.plot) run_plot(config.out_dir);
}

}  // namespace

void add_sweep_command(CLI::App& app) {
    auto args = std::make_shared<SweepArgs>();
    auto* cmd = app.add_subcommand("sweep", "parameter study of the generic term against analytic terms and LUTs");
    args->cmd = cmd;
    cmd->add_option("spec", args->spec, "sweep spec (TOML; its format: docs/sweep-spec.md)")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--out,-o", args->out, "output directory (default: SPEC-STEM.sweep)");
    cmd->add_option("--shard", args->shard,
                    "run only chunks c with c % N == I (I/N; default: the Slurm array task's, from SLURM_ARRAY_TASK_ID and "
                    "SLURM_ARRAY_TASK_COUNT, else 0/1); join with 'merge'");
    cmd->add_flag("--mpi", args->mpi, "share the chunks among the ranks of an MPI world (mpirun -np N, N >= 2): rank 0 hands them out and writes");
    cmd->add_option("--max-chunks", args->max_chunks, "compute at most this many chunks, then stop (resumable)")
        ->transform(decimal_range(0, std::numeric_limits<std::uint64_t>::max()));
    cmd->add_flag("--restart", args->restart, "discard a previous run of a different sweep in --out");
    cmd->add_flag("--merge", args->merge,
                  "assemble the shards that ran into --out (every one must have finished) into sweep.csv and its summary; "
                  "the same as 'microshadow merge --out DIR DIR'");
    cmd->add_flag("--strict-domain", args->strict_domain,
                  "refuse (exit status 2, nothing written) a sweep whose points lie outside a comparator file's domain (the "
                  "roughness, visibility and NdotV ranges its metadata records); without it they are counted in "
                  "summary.md and sweep.json (\"outside_domain\") and warned of");
    cmd->add_flag("--plot", args->plot, "draw heatmaps into OUT/figures with plot_sweep.py (Python 3 with matplotlib: MICROSHADOW_PYTHON, else python3 or py on PATH; found beside the "
                  "executable: ../share/microshadow/ or the source tree's scripts/)");
    // Measured on the project's 2-core CPU: the exact evaluator takes ~10 us a query per core at its
    // default 1e-10; the sampled default (65536 samples) ~45 us for a standard error of ~5e-4.
    args->sampling.method = "exact";
    add_sampling_options(cmd, args->sampling,
                         "Default exact (or the spec's sampling.method): at its default tolerance 1e-10 it takes ~10 us "
                         "a point per core, less than the sampled default's 65536 samples (~45 us a point per core for "
                         "~5e-4)");
    add_tolerance_option(cmd, args->sampling);
    add_tolerance_miss_option(cmd, args->allow_tolerance_miss);
    cmd->callback([args] { run_sweep_command(*args); });
}

void add_merge_command(CLI::App& app) {
    struct MergeArgs {
        std::vector<std::string> dirs;
        std::string out;
        bool quiet = false, allow_tolerance_miss = false;
    };
    auto args = std::make_shared<MergeArgs>();
    auto* cmd = app.add_subcommand("merge",
                                   "assemble the folder(s) 'sweep --shard I/N' ran into into one sweep.csv (the same as 'sweep SPEC --merge', "
                                   "without the spec: the folder says what it holds)");
    cmd->add_option("shards", args->dirs, "the shards' folder (or one folder a shard)")->required()->check(CLI::ExistingDirectory);
    cmd->add_option("--out,-o", args->out, "output directory (may be the shards' folder)")->required();
    cmd->add_flag("--quiet,-q", args->quiet, "no summary on stdout");
    add_tolerance_miss_option(cmd, args->allow_tolerance_miss);
    cmd->callback([args] {
        const auto merged = sweep::merge_shards(args->dirs, args->out, command_line(), "", warn_sweep);
        if (!args->quiet) print_sweep_summary(args->out);
        finish_tolerance_check("sweep", "points", merged.tolerance, args->allow_tolerance_miss);
    });
}

}  // namespace ms::cli
