// microshadow eval: the generic term for every query of a CSV file.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <iostream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"

namespace ms::cli {

namespace {

struct EvalArgs {
    std::string in, out;
    SamplingOptions sampling;
};

void run_eval(const EvalArgs& args) {
    const TermOptions term = args.sampling.term_options();
    const SamplingPlan plan = args.sampling.plan();
    const std::vector<Query> queries = read_query_csv(args.in);
    // Both outputs checked before computing, written together or not at all. `--out -` writes the
    // CSV to standard output and no sidecar: its provenance has no file to sit beside.
    OutputSet outputs;
    const std::size_t csv_out = outputs.add(args.out, false, /*allow_stdout=*/true);
    const bool sidecar = !outputs.to_stdout(csv_out);
    const std::size_t json_out = sidecar ? outputs.add(args.out + ".json") : 0;
    auto backend = args.sampling.make_backend();

    Progress progress("eval", args.sampling.quiet);
    EvalStats stats;
    const auto results = evaluate(*backend, queries, term, plan, &stats,
                                  [&](std::size_t done, std::size_t total) { progress.update(done, total); });
    progress.finish();

    auto& out = outputs.stream(csv_out);
    for (const auto& c : kQueryColumns) out << c << ",";
    out << "term,std_error\n";
    double max_error = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const Query& q = queries[i];
        for (double v : {q.visibility, q.alpha_x, q.alpha_y, q.wi.x, q.wi.y, q.wi.z, q.wo.x, q.wo.y, q.wo.z})
            out << format_number(v) << ",";
        out << format_number(results[i].term) << "," << format_number(results[i].std_error) << "\n";
        max_error = std::max(max_error, results[i].std_error);
    }

    // Provenance beside the CSV (CSV has no standard place for metadata).
    nlohmann::json meta = {{"program", "microshadow " MICROSHADOW_VERSION},
                           {"command_line", command_line()},
                           {"backend", backend->name()},
                           {"form", to_string(term.form)},
                           {"ao_weighting", to_string(term.ao_weighting)},
                           {"sequence", to_string(plan.sequence)},
                           {"samples", plan.samples},
                           {"replicates", plan.replicates},
                           {"seed", plan.seed},
                           {"fast_math", args.sampling.fast_math},
                           {"queries", queries.size()},
                           {"sampled", stats.sampled},
                           {"exact_zero", stats.exact_zero},
                           {"exact_one", stats.exact_one},
                           {"max_std_error", max_error}};
    if (sidecar) outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    outputs.commit();

    if (!args.sampling.quiet)
        std::cerr << "eval: " << queries.size() << " queries (" << stats.sampled << " sampled, " << stats.exact_zero
                  << " exact 0 in the zero region, " << stats.exact_one << " exact 1 at v = 1), " << plan.samples
                  << " samples each, max std error " << std::setprecision(3) << max_error << ", "
                  << std::setprecision(3) << stats.seconds << " s on " << backend->name() << "\n";
}

}  // namespace

void add_eval_command(CLI::App& app) {
    auto args = std::make_shared<EvalArgs>();
    auto* cmd = app.add_subcommand("eval", "evaluate the generic term for the queries of a CSV file");
    cmd->add_option("--in", args->in, "query CSV: " "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z")->required();
    cmd->add_option("--out", args->out, "result CSV: the input columns plus term,std_error, and its provenance in OUT.json "
                                       "(a symlink is followed; '-' writes the CSV to standard output, without the .json)")->required();
    add_sampling_options(cmd, args->sampling);
    cmd->callback([args] { run_eval(*args); });
}

}  // namespace ms::cli
