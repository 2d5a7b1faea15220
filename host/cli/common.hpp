// Options shared by the subcommands that sample the term (eval, bake, sweep), and small CLI helpers.
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "core/memory.hpp"
#include "core/types.hpp"
#include "jobs/eval.hpp"
#include "jobs/tolerance_check.hpp"
#include "schedule/distributed.hpp"

namespace ms::cli {

struct SamplingOptions {
    std::uint64_t samples = 65536;
    std::uint64_t seed = 0;
    std::uint32_t replicates = 8;
    std::string sequence = "sobol";
    std::string form = "height-correlated";
    std::string ao_weighting = "cosine";
    std::string backend = "opencl";
    std::string device = "default";
    bool fast_math = false;
    bool double_kernels = false;
    bool quiet = false;
    // The integration method (each command sets its own default before add_sampling_options, chosen by
    // measurement and explained in its help) and, for the exact method, the float kernel on fp64 devices.
    std::string method = "sampled";
    bool exact_single_precision = false;
    bool exact_kernel = false;
    // --tolerance where the command takes it through add_tolerance_option: the estimated error asked of
    // each value (0: the method's default).
    double tolerance = 0;

    TermOptions term_options() const;
    // The plan, with samples rounded up to replicates * 2^k (reported on stderr when rounded).
    // The plan these options ask for; the exact method's tolerance defaults to `exact_default` (0: the
    // exact method's own default, 1e-10) when --tolerance is not given.
    SamplingPlan plan(double exact_default = 0) const;
    // --backend and --device as every job holds them (cli::backend_spec).
    schedule::BackendSpec backend_spec() const;
    std::unique_ptr<TermBackend> make_backend() const;
    ocl::BuildConfig build_config() const;
};

// The checks every sampling job passes before it computes anything (plan() calls it): samples per
// replicate at most 2^28 (the point-set generator's limit), and the point set (8 bytes a sample: two
// floats; the OpenCL backend holds a second copy, in host memory on PoCL's CPU device) at most half
// the physical memory. Throws std::invalid_argument with the figure and the limit.
void check_sampling_size(const SamplingPlan& plan);
// physical_memory() and gib(), for the memory checks (core/memory.hpp).
using ms::gib;
using ms::physical_memory;

// Integer options in decimal only: CLI11 reads "010" as octal 8 and "0x10" as hex; this transform
// accepts digits only (leading zeros are decimal), rejects a sign and values outside [min, max]
// (also >= 2^64, which CLI11 clamps silently), and passes the normalised digits on.
CLI::Validator decimal_range(std::uint64_t min, std::uint64_t max);
// A real range whose message prints the bounds with %g ("1", not "1.000000").
CLI::Validator real_range(double min, double max);

// Adds --samples --seed --replicates --sequence --form --ao-weighting --backend --device --fast-math --quiet.
// `method_why`: one sentence on why the command's default method is the default (shown in --help).
void add_sampling_options(CLI::App* app, SamplingOptions& options, const std::string& method_why = "");
// --tolerance E for commands whose sampling options do not already define one.
void add_tolerance_option(CLI::App* app, SamplingOptions& o);
// Under the exact method, a note on stderr (unless --quiet) for each of --samples --replicates --seed
// --sequence given on `app`'s command line: they are unused, and a recipe written for the sampled
// method should say --method sampled.
void note_unused_sampling_options(CLI::App* app, const SamplingOptions& o);

// Option groups: each flag defined once, here, and added by every command that takes it. A command
// passes its own defaults (the variables' initial values), ranges and the sentence of help that says
// what the flag means for it.
//
// --samples --replicates --seed of a point-set plan.
struct PlanOptionLimits {
    std::uint64_t max_samples = std::uint64_t(1) << 28;  // --samples: 16 to this
    std::uint32_t max_replicates = 64;                   // --replicates: 2 to this
    std::string samples_help = "samples per query (all replicates)";
    std::string replicates_help = "independent scrambles (error bars)";
    std::string seed_help = "scramble seed";
};
void add_plan_options(CLI::App* app, std::uint64_t& samples, std::uint32_t& replicates, std::uint64_t& seed,
                      const PlanOptionLimits& limits);
// --backend opencl|oracle (`help` says what each means for the command; its default shown when not empty).
void add_backend_option(CLI::App* app, std::string& backend, const std::string& help);
// --device: the OpenCL devices (`what`: the command's sentence; the default shown when not empty).
void add_device_option(CLI::App* app, std::string& device,
                       const std::string& help = "OpenCL device: default, all, an index (see 'devices') or a name");
// --fast-math and --double-kernels: how the command's kernels are built (recorded in outputs).
void add_kernel_build_flags(CLI::App* app, bool& fast_math, bool& double_kernels);
// --fast-math alone, for commands whose kernels run in float only.
void add_fast_math_flag(CLI::App* app, bool& fast_math);
// --threads: host threads (0: all), `help` naming which.
void add_threads_option(CLI::App* app, unsigned& threads, const std::string& help);
// --verify K (0 to 100000 texels re-checked), `help` saying against what and what a failure does.
void add_verify_option(CLI::App* app, std::uint32_t& k, const std::string& help);
// -q / --quiet.
void add_quiet_flag(CLI::App* app, bool& quiet, const std::string& help = "no progress or summary on stderr");
// An older spelling of the option `current` (e.g. --size-visibility for --visibility-count), kept working
// but left out of --help: its value is handed to `current`, checked and stored as if `current` had been
// given; giving both is an error.
void add_hidden_alias(CLI::App* app, const std::string& old_name, CLI::Option* current);
// --shader-prefix: the prefix of every name a generated shader defines (lut/shader/compose.hpp); empty
// keeps the default, each output file's name.
void add_shader_prefix_option(CLI::App* app, std::string& prefix);

// --backend, --device and --threads of any command as the one type every job's options hold: the only
// place the command line's words become a backend (std::invalid_argument for an unknown --backend).
// The test hook MICROSHADOW_FAIL_DEVICE is not read here: every scheduler made from the result reads it
// (schedule::fault_injection_from_environment), on the library's path too.
schedule::BackendSpec backend_spec(const std::string& backend, const std::string& device, unsigned threads = 0);

// The shard a job runs: --shard I/N when given (`given_text` non-empty), else the Slurm array task's
// (SLURM_ARRAY_TASK_ID and _COUNT, _MIN, _STEP), else 0/1. Throws std::invalid_argument naming the
// option or variable.
schedule::Shard resolve_shard(const std::string& given_text);

// A failure whose exit status is not the usual 1 (the status of a child process: the plotter).
class ExitError : public std::runtime_error {
public:
    ExitError(int code, const std::string& what) : std::runtime_error(what), code_(code) {}
    int code() const { return code_; }

private:
    int code_;
};

// A failure already reported on stderr (rank 0 of an MPI world reports before the world ends): main
// prints nothing more and exits with its status.
class ReportedError : public std::runtime_error {
public:
    explicit ReportedError(int code) : std::runtime_error("reported"), code_(code) {}
    int code() const { return code_; }

private:
    int code_;
};

// The exit status of a run that wrote its outputs but left some value's estimated error above the
// tolerance asked of it (docs/cli.md): distinct from 1 (failed) and 2 (bad input), so a script can tell
// "computed, but less accurate than asked" from both.
constexpr int kExitToleranceNotMet = 3;
// The exit status of a run that wrote its outputs but whose --plot step failed: the plotter exited with
// an error or was killed, or no plotter or Python was found (the message says which, and the plotter's
// own status). Its own number, so that a plotter's status can never read as another of ours (3).
constexpr int kExitPlotFailed = 4;

// --allow-tolerance-miss, for a command that checks its values against a tolerance.
void add_tolerance_miss_option(CLI::App* app, bool& allow);

// The last step of a command that checks its values, after its outputs are written and its summary
// printed: when some value's estimated error is above the tolerance, one line on stderr (said even with
// --quiet: the outputs are not what was asked) and, unless `allowed` (--allow-tolerance-miss), the run
// ends with kExitToleranceNotMet. `what` names the values ("queries", "texels", "lights").
void finish_tolerance_check(const std::string& command, const std::string& what, const ToleranceCheck& check, bool allowed);

// Prints a failure of a command's run as "microshadow: ..." on stderr and returns its exit status: 2 for
// bad input (std::invalid_argument, CSV errors, a --device that names no device), the signal's status when interrupted, an ExitError's
// own, 1 otherwise.
int report_error(const std::exception_ptr& error);

// The full command line (each argument quoted as a bash word, valid UTF-8 whatever the bytes), for
// provenance records in output files.
std::string command_line();
void set_command_line(int argc, char** argv);

// The program (program.cpp): every command registered on `app`, with its description and --version
// (the CLI fuzzer parses with the same app), and a whole run: parses argv, runs the command and returns
// the exit status (main.cpp is a call of it).
void build_app(CLI::App& app);
int run_program(int argc, char** argv);

// Subcommand registration (one per file in host/cli/).
void add_devices_command(CLI::App& app);
void add_eval_command(CLI::App& app);
void add_bake_command(CLI::App& app);
void add_sweep_command(CLI::App& app);
void add_merge_command(CLI::App& app);
void add_shader_command(CLI::App& app);  // cmd_shader.cpp
void add_lut_command(CLI::App& app);     // cmd_lut.cpp
void add_repr_command(CLI::App& app);    // cmd_repr.cpp
void add_scene_command(CLI::App& app);   // cmd_scene.cpp
void add_ibl_command(CLI::App& app);     // cmd_ibl.cpp
void add_design_command(CLI::App& app);  // cmd_design.cpp
void add_area_command(CLI::App& app);    // cmd_area.cpp
void add_help_command(CLI::App& app);
// "; did you mean --size?" for the closest of `scope`'s long options (`options`) or of its subcommands
// within 3 edits of `word`, or "".
std::string suggestion(CLI::App& scope, const std::string& word, bool options);
// The one line printed for a command line that does not parse: a word that is no command or option
// of the command, with the closest spelling, or else CLI11's message; each names the help to read.
std::string parse_error_line(CLI::App& app, int argc, char** argv, const CLI::ParseError& error);

}  // namespace ms::cli
