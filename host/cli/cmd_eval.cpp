// microshadow eval: the generic term for every query of a CSV file.
#include <iostream>

#include "analytic/part1_terms.hpp"
#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "jobs/eval_run.hpp"

namespace ms::cli {

namespace {

struct EvalArgs {
    std::string in, out;
    SamplingOptions sampling;
    std::vector<std::string> compare;  // --compare NAME | FILE | NAME=FILE
    bool strict_domain = false;        // refuse queries outside a comparator's domain
    bool allow_tolerance_miss = false;
};

void run_eval(const EvalArgs& args) {
    EvalJobSpec spec;
    spec.in = args.in;
    spec.out = args.out;
    spec.term = args.sampling.term_options();
    spec.plan = args.sampling.plan();
    spec.compare = args.compare;
    spec.strict_domain = args.strict_domain;
    spec.fast_math = args.sampling.fast_math;
    spec.command_line = command_line();
    spec.make_backend = [&] { return args.sampling.make_backend(); };
    Progress progress("eval", args.sampling.quiet);
    JobCallbacks callbacks;
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    const EvalJobResult result = run_eval_job(spec, callbacks);
    progress.finish();
    if (!args.sampling.quiet) std::cerr << eval_job_summary(spec, result);
    // Said even with --quiet: the figures above mean little for a file used outside its domain.
    std::cerr << eval_job_warnings(result);
    finish_tolerance_check("eval", "queries", result.tolerance, args.allow_tolerance_miss);
}

}  // namespace

void add_eval_command(CLI::App& app) {
    auto args = std::make_shared<EvalArgs>();
    auto* cmd = app.add_subcommand("eval", "evaluate the generic term for the queries of a CSV file (exact by default, or sampled)");
    cmd->add_option("--in", args->in, "query CSV: " "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z")->required();
    cmd->add_option("--out", args->out, "result CSV: the input columns plus term,std_error (and the --compare columns), and its provenance in OUT.json "
                                       "(a symlink is followed; '-' writes the CSV to standard output, without the .json)")->required();
    std::string analytic_terms;  // the registry's names, so that the help lists every term there is
    for (const std::string& name : analytic::analytic_term_names()) analytic_terms += (analytic_terms.empty() ? "" : ", ") + name;
    cmd->add_option("--compare", args->compare,
                    "add a comparator column and its error column <name>_error = comparator - term (repeatable): "
                    "one of part 1's analytic terms (" + analytic_terms + "), a baked LUT file (.exr, column named after the file stem) or "
                    "NAME=FILE; each reads visibility, NdotL = wo_z, NdotV = wi_z (normalised) and the "
                    "isotropic-equivalent roughness (alpha_x alpha_y)^(1/4), as sweeps do; the anisotropic preset (or a file of it) reads alpha_x, alpha_y and the azimuths of wi and wo from the tangent");
    cmd->add_flag("--strict-domain", args->strict_domain,
                  "refuse (exit status 2, nothing written) when a query lies outside a --compare file's domain (the "
                  "roughness, visibility and NdotV ranges its metadata records); without it such queries are answered, "
                  "counted (\"outside_domain\" per comparator in OUT.json) and warned of");
    args->sampling.method = "exact";
    add_sampling_options(cmd, args->sampling,
                         "Default exact: at its default tolerance 1e-10 it takes ~10 us a query per core, less "
                         "than the sampled default's 65536 samples (~45 us a query per core for ~5e-4)");
    add_tolerance_option(cmd, args->sampling);
    add_tolerance_miss_option(cmd, args->allow_tolerance_miss);
    cmd->callback([args, cmd] {
        // Sampling settings with the exact method would be ignored: refuse them, naming the way out.
        if (args->sampling.method == "exact")
            for (const char* o : {"--samples", "--seed", "--replicates", "--sequence", "--double-kernels", "--fast-math"})
                if (cmd->count(o) > 0)
                    throw std::invalid_argument(std::string(o) + " applies to --method sampled only (the exact method "
                                                "does not sample; its accuracy is --tolerance)");
        run_eval(*args);
    });
}

}  // namespace ms::cli
