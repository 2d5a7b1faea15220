#include "cli/common.hpp"

#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"


#include <cstdlib>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>

#include "cli/progress.hpp"
#include "lut/shader/compose.hpp"
#include "core/cancel.hpp"
#include "device/error.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "sampling/point_set.hpp"

namespace ms::cli {

namespace {
std::string g_command_line;

// Largest samples per replicate that make_point_set accepts (host/sampling/point_set.cpp).
constexpr std::uint64_t kMaxPerReplicate = std::uint64_t(1) << 28;
constexpr std::uint32_t kMaxReplicates = 1024;

std::string format_g(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

}  // namespace

void set_command_line(int argc, char** argv) {
    // Each argument as a bash word (shell_quote): the record is valid UTF-8 whatever bytes the
    // arguments hold (file names on Linux are bytes), so JSON provenance never fails to dump it.
    g_command_line.clear();
    for (int i = 0; i < argc; ++i) g_command_line += (i ? " " : "") + shell_quote(argv[i]);
}

std::string command_line() { return g_command_line; }

int report_error(const std::exception_ptr& error) {
    try {
        std::rethrow_exception(error);
    } catch (const ReportedError& e) {
        return e.code();
    } catch (const Cancelled& e) {
        std::cerr << "microshadow: " << e.what() << "\n";
        return interrupted_exit_status();
    } catch (const std::exception& e) {
        std::cerr << "microshadow: error: " << e.what() << "\n";
        if (const auto* exit = dynamic_cast<const ExitError*>(&e)) return exit->code();
        const bool bad_input = dynamic_cast<const CsvError*>(&e) || dynamic_cast<const std::invalid_argument*>(&e) ||
                               dynamic_cast<const ocl::UnknownDeviceError*>(&e);
        return bad_input ? 2 : 1;
    } catch (...) {
        std::cerr << "microshadow: error: unknown failure\n";
        return 1;
    }
}

void add_tolerance_miss_option(CLI::App* app, bool& allow) {
    app->add_flag("--allow-tolerance-miss", allow,
                  "exit status 0 even when a value's estimated error is above the tolerance asked (by default such a "
                  "run writes its outputs, flags them in its summary and metadata, and exits with status 3)");
}

void finish_tolerance_check(const std::string& command, const std::string& what, const ToleranceCheck& check, bool allowed) {
    if (check.met()) return;
    std::cerr << command << ": warning: the estimated error of " << check.over << " of " << check.values << " " << what
              << " is above the tolerance " << format_g(check.tolerance) << " (worst " << format_g(check.worst) << ")"
              << (allowed ? "\n" : "; exit status 3 (--allow-tolerance-miss: 0)\n");
    if (!allowed) throw ReportedError(kExitToleranceNotMet);
}

void check_sampling_size(const SamplingPlan& p) {
    const std::uint64_t per_replicate = p.samples / p.replicates;
    if (per_replicate > kMaxPerReplicate)
        throw std::invalid_argument("--samples " + std::to_string(p.samples) + " with " + std::to_string(p.replicates) +
                                    " replicates is " + std::to_string(per_replicate) +
                                    " points per replicate; at most 2^28 = " + std::to_string(kMaxPerReplicate) +
                                    " (raise --replicates or lower --samples)");
    const std::uint64_t bytes = p.samples * 8;  // two floats a sample (sampling/point_set.hpp)
    const std::uint64_t memory = physical_memory();
    if (memory > 0 && bytes > memory / 2)
        throw std::invalid_argument("--samples " + std::to_string(p.samples) + " needs " + gib(bytes) +
                                    " for the point set (8 bytes a sample), more than the limit of " + gib(memory / 2) +
                                    " (half the " + gib(memory) + " of physical memory); lower --samples");
}

TermOptions SamplingOptions::term_options() const {
    TermOptions t;
    t.form = parse_form(form);
    t.ao_weighting = parse_ao_weighting(ao_weighting);
    return t;
}

SamplingPlan SamplingOptions::plan(double exact_default) const {
    SamplingPlan p;
    p.sequence = parse_sequence(sequence);
    p.replicates = replicates;
    p.seed = seed;
    p.samples = round_up_samples(samples, replicates);
    p.method = parse_method(method);
    p.single_precision = exact_single_precision;
    p.kernel_on_cpu_devices = exact_kernel;
    p.tolerance = tolerance;
    if (p.method == Method::exact) {
        if (p.tolerance == 0) p.tolerance = exact_default > 0 ? exact_default : exact::kDefaultTolerance;
        exact_term::validate_tolerance(p.tolerance);
        return p;  // no point set is made: the sampling fields are unused
    }
    check_sampling_size(p);
    if (p.samples != samples && !quiet)
        std::cerr << "note: --samples " << samples << " rounded up to " << p.samples << " (" << replicates
                  << " replicates of a power-of-two net)\n";
    return p;
}

schedule::BackendSpec backend_spec(const std::string& backend, const std::string& device, unsigned threads) {
    try {
        return schedule::BackendSpec::parse(backend, device, threads);
    } catch (const std::invalid_argument&) {
        throw std::invalid_argument("--backend " + backend + ": opencl or oracle");
    }
}

schedule::BackendSpec SamplingOptions::backend_spec() const { return cli::backend_spec(backend, device); }

ocl::BuildConfig SamplingOptions::build_config() const {
    ocl::BuildConfig b;
    b.fast_math = fast_math;
    b.double_precision = double_kernels;
    return b;
}

std::unique_ptr<TermBackend> SamplingOptions::make_backend() const {
    OpenClBackendConfig config;
    config.build = build_config();
    return make_term_backend(backend_spec(), config);
}

CLI::Validator decimal_range(std::uint64_t min, std::uint64_t max) {
    const std::string range = std::to_string(min) + " to " + std::to_string(max);
    return CLI::Validator(
        [min, max, range](std::string& s) -> std::string {
            if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos)
                return "'" + s + "' is not a decimal integer (" + range + ")";
            std::uint64_t v = 0;
            const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 10);
            if (ec == std::errc::result_out_of_range || v > max || v < min)
                return "Value " + s + " not in range " + range;
            // Normalised: CLI11's own conversion would read the leading zero of "010" as octal.
            s = std::to_string(v);
            return {};
        },
        std::to_string(min) + ".." + std::to_string(max));
}

CLI::Validator real_range(double min, double max) {
    const std::string range = format_g(min) + " to " + format_g(max);
    return CLI::Validator(
        [min, max, range](std::string& s) -> std::string {
            double v = 0;
            const char* begin = s.data() + (s.size() > 1 && s[0] == '+' ? 1 : 0);
            const auto [end, ec] = std::from_chars(begin, s.data() + s.size(), v);
            if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v))
                return "'" + s + "' is not a finite number (" + range + ")";
            if (v < min || v > max) return "Value " + s + " not in range " + range;
            return {};
        },
        format_g(min) + ".." + format_g(max));
}

void add_shader_prefix_option(CLI::App* app, std::string& prefix) {
    app->add_option("--shader-prefix", prefix,
                    "prefix of the names the generated shaders define (PREFIX_micro_shadowing, ...), so that several "
                    "generated files combine in one shader (default: each shader file's name; standard output: ms)")
        ->check([](const std::string& p) {
            try {
                lutshader::check_prefix(p);
            } catch (const std::invalid_argument& e) {
                return std::string(e.what());
            }
            return std::string();
        });
}

void add_tolerance_option(CLI::App* app, SamplingOptions& o) {
    app->add_option("--tolerance", o.tolerance,
                    "estimated absolute error asked of each value: the exact method's quadrature estimate (default "
                    "1e-10; 1e-13 to 0.1), or for the sampled method the replicate standard error, reached by "
                    "quadrupling the samples of the queries above it (up to 2^24)")
        ->check(CLI::PositiveNumber);
}

void note_unused_sampling_options(CLI::App* app, const SamplingOptions& o) {
    if (o.method != "exact" || o.quiet) return;
    for (const char* name : {"--samples", "--replicates", "--seed", "--sequence"})
        if (app->get_option(name)->count() > 0)
            std::cerr << "note: " << name << " is unused by the exact method (add --method sampled to sample)\n";
}

void add_sampling_options(CLI::App* app, SamplingOptions& o, const std::string& method_why) {
    app->add_option("--method", o.method,
                    "exact: the deterministic boundary-integral evaluator (quadrature error estimate in std_error, "
                    "no samples); sampled: VNDF sampling (replicate standard error)" +
                        (method_why.empty() ? std::string() : ". " + method_why))
        ->check(CLI::IsMember({"exact", "sampled"}))
        ->capture_default_str();
    app->add_flag("--exact-float", o.exact_single_precision,
                  "exact method on OpenCL devices: the float kernel even where the device has fp64 (what a GPU "
                  "without fp64 gets; its accuracy is in docs/exact-method.md)");
    app->add_flag("--exact-kernel", o.exact_kernel,
                  "exact method: the OpenCL kernel on CPU devices too (by default a CPU device's share runs the C++ "
                  "evaluator on its cores, ~2x (bake) to ~5x (eval) faster than the kernel through PoCL; other devices always run the "
                  "kernel)");
    const std::uint64_t memory = physical_memory();
    const std::string memory_note = memory ? " here: " + gib(memory / 2) : "";
    PlanOptionLimits limits;
    limits.max_samples = kMaxPerReplicate * kMaxReplicates;
    limits.max_replicates = kMaxReplicates;
    limits.samples_help =
        "VNDF samples per query: 16 to replicates x 2^28 (2^31 with 8 replicates), rounded up to replicates x 2^k; the point "
        "set takes 8 bytes a sample, at most half the physical memory" + memory_note;
    limits.replicates_help = "independent randomisations, for the error estimate (2 to 1024)";
    limits.seed_help = "seed of the point-set randomisation (decimal, 0 .. 2^64 - 1)";
    add_plan_options(app, o.samples, o.replicates, o.seed, limits);
    app->add_option("--sequence", o.sequence, "sample points")->check(CLI::IsMember({"sobol", "random"}))->capture_default_str();
    app->add_option("--form", o.form, "Smith form of G2/G1")
        ->check(CLI::IsMember({"height-correlated", "uncorrelated"}))
        ->capture_default_str();
    app->add_option("--ao-weighting", o.ao_weighting, "how the AO map was baked: cos_t = sqrt(1-v) or 1-v")
        ->check(CLI::IsMember({"cosine", "uniform"}))
        ->capture_default_str();
    add_backend_option(app, o.backend, "opencl kernels or the scalar double oracle");
    add_device_option(app, o.device);
    add_kernel_build_flags(app, o.fast_math, o.double_kernels);
    add_quiet_flag(app, o.quiet);
}

void add_plan_options(CLI::App* app, std::uint64_t& samples, std::uint32_t& replicates, std::uint64_t& seed,
                      const PlanOptionLimits& limits) {
    app->add_option("--samples", samples, limits.samples_help)->transform(decimal_range(16, limits.max_samples))->capture_default_str();
    app->add_option("--seed", seed, limits.seed_help)
        ->transform(decimal_range(0, std::numeric_limits<std::uint64_t>::max()))
        ->capture_default_str();
    app->add_option("--replicates", replicates, limits.replicates_help)
        ->transform(decimal_range(2, limits.max_replicates))
        ->capture_default_str();
}

void add_backend_option(CLI::App* app, std::string& backend, const std::string& help) {
    CLI::Option* o = app->add_option("--backend", backend, help)->check(CLI::IsMember({"opencl", "oracle"}));
    if (!backend.empty()) o->capture_default_str();
}

void add_device_option(CLI::App* app, std::string& device, const std::string& help) {
    CLI::Option* o = app->add_option("--device", device, help);
    if (!device.empty()) o->capture_default_str();
}

void add_fast_math_flag(CLI::App* app, bool& fast_math) {
    app->add_flag("--fast-math", fast_math, "build kernels with -cl-fast-relaxed-math (recorded in outputs)");
}

void add_kernel_build_flags(CLI::App* app, bool& fast_math, bool& double_kernels) {
    add_fast_math_flag(app, fast_math);
    app->add_flag("--double-kernels", double_kernels,
                  "run the kernels in double precision (devices with cl_khr_fp64; separates rounding from algorithm)");
}

void add_threads_option(CLI::App* app, unsigned& threads, const std::string& help) {
    app->add_option("--threads", threads, help)->transform(decimal_range(0, 1024));
}

void add_verify_option(CLI::App* app, std::uint32_t& k, const std::string& help) {
    app->add_option("--verify", k, help)->transform(decimal_range(0, 100000));
}

void add_quiet_flag(CLI::App* app, bool& quiet, const std::string& help) { app->add_flag("-q,--quiet", quiet, help); }

void add_hidden_alias(CLI::App* app, const std::string& old_name, CLI::Option* current) {
    // CLI11 lists every name of an option in --help, so the old name is an option of its own in the hidden
    // group "" whose callback feeds `current`: current's validators and transforms then apply as usual.
    auto* alias = app->add_option(
        old_name,
        [old_name, current](const CLI::results_t& values) {
            if (current->count() > 0) throw CLI::ExcludesError(old_name, current->get_name());
            for (const std::string& value : values) current->add_result(value);
            try {
                current->run_callback();
            } catch (const CLI::ValidationError& e) {
                // Name the flag as the user typed it: "--size-visibility: ..." rather than the current name.
                std::string message = e.what();
                if (message.rfind(current->get_name(), 0) == 0) message.replace(0, current->get_name().size(), old_name);
                throw CLI::ValidationError(message);
            }
            return true;
        },
        "older spelling of " + current->get_name());
    alias->group("");
}

schedule::Shard resolve_shard(const std::string& given_text) {
    if (!given_text.empty()) return schedule::parse_shard(given_text, "--shard");
    if (const auto task = schedule::slurm_array_shard([](const char* name) { return std::getenv(name); })) return *task;
    return {};
}

}  // namespace ms::cli
