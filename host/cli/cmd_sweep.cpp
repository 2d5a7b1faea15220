// microshadow sweep SPEC.toml: a parameter study of the generic term against comparators, streamed
// to disk in chunks (resumable, shardable). microshadow merge: joins the outputs of --shard runs.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "core/cancel.hpp"
#include "io/text.hpp"
#include "jobs/sweep/runner.hpp"

extern char** environ;

namespace ms::cli {

namespace {

namespace fs = std::filesystem;

struct SweepArgs {
    std::string spec, out, shard = "0/1";
    std::uint64_t max_chunks = 0;
    bool restart = false, plot = false;
    SamplingOptions sampling;
    CLI::App* cmd = nullptr;
};

// The plotting script, found from the executable's own location (no path compiled in, so a moved or
// installed binary finds its own copy): <prefix>/bin/microshadow -> <prefix>/share/microshadow/; a
// build tree (build/microshadow) -> the source tree's scripts/, found beside the build directory or
// through the build directory's CMakeCache.txt (CMAKE_HOME_DIRECTORY) for out-of-tree builds.
std::string plot_script() {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw std::runtime_error("--plot: cannot find the executable's path (/proc/self/exe: " + ec.message() + ")");
    const fs::path bin = exe.parent_path();
    std::vector<fs::path> candidates = {bin / ".." / "share" / "microshadow" / "plot_sweep.py",
                                        bin / ".." / "scripts" / "plot_sweep.py"};
    std::ifstream cache(bin / "CMakeCache.txt");
    for (std::string line; std::getline(cache, line);)
        if (line.rfind("CMAKE_HOME_DIRECTORY:INTERNAL=", 0) == 0)
            candidates.push_back(fs::path(line.substr(line.find('=') + 1)) / "scripts" / "plot_sweep.py");
    std::string looked;
    for (const auto& c : candidates) {
        if (fs::is_regular_file(c, ec)) return c.lexically_normal().string();
        looked += "\n  " + c.lexically_normal().string();
    }
    throw std::runtime_error("--plot: plot_sweep.py not found; looked in:" + looked);
}

// Runs the plotting script without a shell: an argument vector for posix_spawn, so no file name
// (a spec called x';touch PWNED;'.toml, an --out with quotes) is ever parsed as a command.
void run_plot(const std::string& out_dir, bool quiet) {
    // Absolute paths: a relative directory starting with '-' would read as an option to argparse.
    const fs::path dir = fs::absolute(out_dir).lexically_normal();
    // Debian's python3 carries python3-matplotlib; a python3 earlier on PATH may not.
    const std::vector<std::string> args = {"/usr/bin/python3", plot_script(), "heatmaps", (dir / "sweep.csv").string(),
                                           "--out", (dir / "figures").string()};
    std::string shown;
    for (const auto& a : args) shown += (shown.empty() ? "" : " ") + shell_quote(a);
    if (!quiet) std::cerr << "sweep: " << shown << "\n";
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    // The CLI blocks SIGINT/SIGTERM in every thread (progress.cpp) and a spawned child inherits that
    // mask: give the plotter the default mask and dispositions so Ctrl-C stops it too.
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t none, defaults;
    sigemptyset(&none);
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGINT);
    sigaddset(&defaults, SIGTERM);
    sigaddset(&defaults, SIGPIPE);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    std::cout.flush();
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0], nullptr, &attr, argv.data(), environ);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) throw std::runtime_error("--plot: cannot run " + args[0] + ": " + std::strerror(rc));
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) throw std::runtime_error(std::string("--plot: waitpid: ") + std::strerror(errno));
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
    // The plotter's own status becomes the command's (128 + N for a signal, as a shell reports it).
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    throw ExitError(code, "plotting failed (" +
                              (WIFEXITED(status) ? "exit status " + std::to_string(code)
                                                 : "killed by signal " + std::to_string(WTERMSIG(status))) +
                              "): " + shown + "; the sweep itself is complete in " + out_dir);
}

void run_sweep_command(SweepArgs& args) {
    sweep::Spec spec = sweep::parse_spec_file(args.spec);
    // The spec's [sampling] values are defaults; an option given on the command line wins.
    auto given = [&](const char* name) { return args.cmd->get_option(name)->count() > 0; };
    if (spec.samples && !given("--samples")) args.sampling.samples = *spec.samples;
    if (spec.replicates && !given("--replicates")) args.sampling.replicates = *spec.replicates;
    if (spec.seed && !given("--seed")) args.sampling.seed = *spec.seed;
    if (spec.sequence && !given("--sequence")) args.sampling.sequence = *spec.sequence;
    if (!spec.forms.empty() && given("--form"))
        throw std::invalid_argument("--form conflicts with parameters.form in " + args.spec + "; use one of them");
    if (!spec.weightings.empty() && given("--ao-weighting"))
        throw std::invalid_argument("--ao-weighting conflicts with parameters.ao_weighting in " + args.spec);

    sweep::RunConfig config;
    config.out_dir = args.out.empty() ? std::filesystem::path(args.spec).stem().string() + ".sweep" : args.out;
    config.plan = args.sampling.plan();
    config.defaults = args.sampling.term_options();
    config.shard = sweep::parse_shard(args.shard);
    config.max_chunks = args.max_chunks;
    config.restart = args.restart;
    config.fast_math = args.sampling.fast_math;
    config.command_line = command_line();
    auto backend = args.sampling.make_backend();
    config.backend = backend.get();
    // Bits depend on the kind of device, not on how many: a sweep begun on one device resumes on --device all.
    config.backend_label = backend->scheduler().results_label();
    config.warn = [&](const std::string& w) { std::cerr << "\nsweep: warning: " << w << "\n"; };
    Progress progress("sweep", args.sampling.quiet);
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
    if (!args.sampling.quiet)
        std::cerr << "sweep: " << r.points << " points in " << r.chunks << " chunks of " << spec.chunk_size
                  << "; this run computed " << r.computed << ", found " << r.skipped << " finished (spec hash "
                  << r.spec_hash << ")\n";
    if (!r.complete) {
        std::cerr << "sweep: stopped after --max-chunks " << args.max_chunks << "; rerun to continue\n";
        return;
    }
    if (!r.assembled) {
        std::cerr << "sweep: shard " << args.shard << " finished in " << config.out_dir
                  << "; join the shards with 'microshadow merge --out DIR SHARD_DIRS...'\n";
        return;
    }
    std::cout << "wrote " << config.out_dir << "/sweep.csv\n\n";
    std::ifstream md(config.out_dir + "/summary.md");
    std::cout << md.rdbuf();
    if (args.plot) run_plot(config.out_dir, args.sampling.quiet);
}

}  // namespace

void add_sweep_command(CLI::App& app) {
    auto args = std::make_shared<SweepArgs>();
    auto* cmd = app.add_subcommand("sweep", "parameter study of the generic term against analytic terms and LUTs");
    args->cmd = cmd;
    cmd->add_option("spec", args->spec, "sweep spec (TOML; see host/sweep/spec.hpp or docs/study.md)")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--out,-o", args->out, "output directory (default: SPEC-STEM.sweep)");
    cmd->add_option("--shard", args->shard, "run only chunks c with c % N == I (I/N); join with 'merge'")
        ->capture_default_str();
    cmd->add_option("--max-chunks", args->max_chunks, "compute at most this many chunks, then stop (resumable)")
        ->transform(decimal_range(0, std::numeric_limits<std::uint64_t>::max()));
    cmd->add_flag("--restart", args->restart, "discard a previous run of a different sweep in --out");
    cmd->add_flag("--plot", args->plot, "draw heatmaps into OUT/figures with plot_sweep.py (/usr/bin/python3, matplotlib; found beside the "
                  "executable: ../share/microshadow/ or the source tree's scripts/)");
    add_sampling_options(cmd, args->sampling);
    cmd->callback([args] { run_sweep_command(*args); });
}

void add_merge_command(CLI::App& app) {
    struct MergeArgs {
        std::vector<std::string> dirs;
        std::string out;
        bool quiet = false;
    };
    auto args = std::make_shared<MergeArgs>();
    auto* cmd = app.add_subcommand("merge", "join the outputs of 'sweep --shard I/N' runs into one sweep.csv");
    cmd->add_option("shards", args->dirs, "shard output directories")->required()->check(CLI::ExistingDirectory);
    cmd->add_option("--out,-o", args->out, "output directory")->required();
    cmd->add_flag("--quiet,-q", args->quiet, "no summary on stdout");
    cmd->callback([args] {
        sweep::merge_shards(args->dirs, args->out, command_line());
        if (args->quiet) return;
        std::cout << "wrote " << args->out << "/sweep.csv\n\n";
        std::ifstream md(args->out + "/summary.md");
        std::cout << md.rdbuf();
    });
}

}  // namespace ms::cli
