// Options shared by the subcommands that sample the term (eval, bake, sweep), and small CLI helpers.
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "core/types.hpp"
#include "jobs/eval.hpp"

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

    TermOptions term_options() const;
    // The plan, with samples rounded up to replicates * 2^k (reported on stderr when rounded).
    SamplingPlan plan() const;
    std::unique_ptr<TermBackend> make_backend() const;
    ocl::BuildConfig build_config() const;
};

// Adds --samples --seed --replicates --sequence --form --ao-weighting --backend --device --fast-math --quiet.
void add_sampling_options(CLI::App* app, SamplingOptions& options);

// The full command line, for provenance records in output files.
std::string command_line();
void set_command_line(int argc, char** argv);

// Subcommand registration (one per file in host/cli/).
void add_devices_command(CLI::App& app);
void add_eval_command(CLI::App& app);
void add_bake_command(CLI::App& app);
void add_sweep_command(CLI::App& app);
void add_merge_command(CLI::App& app);
void add_shader_command(CLI::App& app);  // issue 12 (cmd_shader.cpp)

}  // namespace ms::cli
