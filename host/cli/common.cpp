#include "cli/common.hpp"

#include <cstdlib>

#include <iostream>

#include "sampling/point_set.hpp"

namespace ms::cli {

namespace {
std::string g_command_line;
}

void set_command_line(int argc, char** argv) {
    g_command_line.clear();
    for (int i = 0; i < argc; ++i) {
        std::string arg = argv[i];
        const bool quote = arg.empty() || arg.find_first_of(" \t\"'$") != std::string::npos;
        g_command_line += (i ? " " : "") + (quote ? "'" + arg + "'" : arg);
    }
}

std::string command_line() { return g_command_line; }

TermOptions SamplingOptions::term_options() const {
    TermOptions t;
    t.form = parse_form(form);
    t.ao_weighting = parse_ao_weighting(ao_weighting);
    return t;
}

SamplingPlan SamplingOptions::plan() const {
    SamplingPlan p;
    p.sequence = parse_sequence(sequence);
    p.replicates = replicates;
    p.seed = seed;
    p.samples = round_up_samples(samples, replicates);
    if (p.samples != samples && !quiet)
        std::cerr << "note: --samples " << samples << " rounded up to " << p.samples << " (" << replicates
                  << " replicates of a power-of-two net)\n";
    return p;
}

schedule::FaultInjection fault_injection_from_environment() {
    schedule::FaultInjection f;
    const char* env = std::getenv("MICROSHADOW_FAIL_DEVICE");
    if (!env || !*env) return f;
    const std::string s(env);
    const auto colon = s.find(':');
    try {
        f.place = std::stol(s.substr(0, colon));
        f.after = colon == std::string::npos ? 0 : std::stol(s.substr(colon + 1));
    } catch (const std::exception&) {
        throw std::invalid_argument("MICROSHADOW_FAIL_DEVICE must be <place index>:<items>, not '" + s + "'");
    }
    return f;
}

ocl::BuildConfig SamplingOptions::build_config() const {
    ocl::BuildConfig b;
    b.fast_math = fast_math;
    b.double_precision = double_kernels;
    return b;
}

std::unique_ptr<TermBackend> SamplingOptions::make_backend() const {
    std::unique_ptr<TermBackend> made;
    if (backend == "oracle") {
        made = make_oracle_backend();
    } else {
        OpenClBackendConfig config;
        config.build = build_config();
        made = make_opencl_backend(ocl::select_devices(device), config);
    }
    made->scheduler().set_fault_injection(fault_injection_from_environment());
    return made;
}

void add_sampling_options(CLI::App* app, SamplingOptions& o) {
    app->add_option("--samples", o.samples, "VNDF samples per query (rounded up to replicates x 2^k)")
        ->check(CLI::Range(std::uint64_t(16), std::uint64_t(1) << 34))
        ->capture_default_str();
    // CLI11's unsigned conversion would wrap "-1" to 2^64 - 1 silently.
    const CLI::Validator no_sign(
        [](std::string& s) { return s.find_first_of("+-") == std::string::npos ? std::string() : "--seed takes an integer in 0 .. 2^64 - 1, got '" + s + "'"; },
        "UINT");
    app->add_option("--seed", o.seed, "seed of the point-set randomisation (0 .. 2^64 - 1)")
        ->check(no_sign)
        ->capture_default_str();
    app->add_option("--replicates", o.replicates, "independent randomisations, for the error estimate")
        ->check(CLI::Range(2u, 1024u))
        ->capture_default_str();
    app->add_option("--sequence", o.sequence, "sample points")->check(CLI::IsMember({"sobol", "random"}))->capture_default_str();
    app->add_option("--form", o.form, "Smith form of G2/G1")
        ->check(CLI::IsMember({"height-correlated", "uncorrelated"}))
        ->capture_default_str();
    app->add_option("--ao-weighting", o.ao_weighting, "how the AO map was baked: cos_t = sqrt(1-v) or 1-v")
        ->check(CLI::IsMember({"cosine", "uniform"}))
        ->capture_default_str();
    app->add_option("--backend", o.backend, "opencl kernels or the scalar double oracle")
        ->check(CLI::IsMember({"opencl", "oracle"}))
        ->capture_default_str();
    app->add_option("--device", o.device, "OpenCL device: default, all, an index (see 'devices') or a name")
        ->capture_default_str();
    app->add_flag("--fast-math", o.fast_math, "build kernels with -cl-fast-relaxed-math (recorded in outputs)");
    app->add_flag("--double-kernels", o.double_kernels,
                  "run the kernels in double precision (devices with cl_khr_fp64; separates rounding from algorithm)");
    app->add_flag("--quiet,-q", o.quiet, "no progress or summary on stderr");
}

}  // namespace ms::cli
