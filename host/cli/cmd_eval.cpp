// microshadow eval: the generic term for every query of a CSV file.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <optional>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "core/error_stats.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "jobs/compare.hpp"

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
    const TermOptions term = args.sampling.term_options();
    const SamplingPlan plan = args.sampling.plan();
    // Comparators first: a bad name, an unreadable LUT or a clashing column stops before any work.
    std::vector<std::string> taken(kQueryColumns.begin(), kQueryColumns.end());
    taken.insert(taken.end(), {"term", "std_error"});
    const std::vector<compare::Comparator> comparators = compare::parse_comparators(args.compare, taken);
    const std::vector<Query> queries = read_query_csv(args.in);
    // Comparator values (cheap) before the term, so a query a comparator cannot take is refused first.
    std::vector<std::vector<double>> compared(comparators.size(), std::vector<double>(queries.size()));
    std::vector<double> n_dot_l(queries.size());
    // Lookups outside each comparator's domain are answered (clamped) but counted, and reported.
    std::vector<DomainTally> outside(comparators.size());
    std::vector<std::string> first_outside(comparators.size());
    std::vector<std::optional<LookupDomain>> domains;
    for (const auto& c : comparators) domains.push_back(c.domain());
    for (std::size_t i = 0; i < queries.size() && !comparators.empty(); ++i) {
        const approx::Inputs in = approx::inputs_of(queries[i], term.ao_weighting);
        n_dot_l[i] = in.n_dot_l;
        for (std::size_t k = 0; k < comparators.size(); ++k) {
            if (domains[k]) {
                const bool inside = domains[k]->contains(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
                outside[k].add(inside);
                if (!inside && first_outside[k].empty())
                    first_outside[k] = "query " + std::to_string(i + 1) + ": " +
                                       domains[k]->first_outside(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
            }
            try {
                compared[k][i] = comparators[k](in);
            } catch (const std::domain_error& e) {
                throw std::invalid_argument(args.in + ": query " + std::to_string(i + 1) + ": --compare " +
                                            comparators[k].name() + ": " + e.what());
            }
        }
    }
    if (args.strict_domain)
        for (std::size_t k = 0; k < comparators.size(); ++k)
            if (domains[k]) compare::refuse_outside_domain(args.in, comparators[k].name(), *domains[k], outside[k], first_outside[k]);
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
    out << "term,std_error";
    for (const auto& c : comparators) out << "," << c.name() << "," << c.name() << "_error";
    out << "\n";
    // Per comparator: max |e|, RMS and the N.L-weighted RMS, w = max(N.L, 0).
    std::vector<ErrorStats> errors(comparators.size());
    double max_error = 0;
    // The exact method always has a tolerance (its default when not given); the sampled one when given.
    ToleranceCheck tolerance{plan.tolerance};
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const Query& q = queries[i];
        for (double v : {q.visibility, q.alpha_x, q.alpha_y, q.wi.x, q.wi.y, q.wi.z, q.wo.x, q.wo.y, q.wo.z})
            out << format_number(v) << ",";
        out << format_number(results[i].term) << "," << format_number(results[i].std_error);
        for (std::size_t k = 0; k < comparators.size(); ++k) {
            const double e = compared[k][i] - results[i].term;
            errors[k].add(e, std::max(n_dot_l[i], 0.0));
            out << "," << format_number(compared[k][i]) << "," << format_number(e);
        }
        out << "\n";
        max_error = std::max(max_error, results[i].std_error);
        tolerance.add(results[i].std_error);
    }

    // Provenance beside the CSV (CSV has no standard place for metadata).
    nlohmann::json meta = {{"program", "microshadow " MICROSHADOW_VERSION},
                           {"command_line", command_line()},
                           {"backend", backend->name()},
                           {"form", to_string(term.form)},
                           {"ao_weighting", to_string(term.ao_weighting)},
                           {"method", to_string(plan.method)},
                           {"fast_math", args.sampling.fast_math},
                           {"queries", queries.size()},
                           {"sampled", stats.sampled},
                           {"exact_zero", stats.exact_zero},
                           {"exact_one", stats.exact_one},
                           {"max_std_error", max_error}};
    if (tolerance.tolerance > 0) {
        meta["tolerance_met"] = tolerance.met();
        meta["queries_over_tolerance"] = tolerance.over;
    }
    if (plan.method == Method::exact) {
        // What decides the numbers of the exact method, and what its std_error column means.
        meta["exact"] = exact_provenance(plan);
    } else {
        meta["sequence"] = to_string(plan.sequence);
        meta["samples"] = plan.samples;
        meta["replicates"] = plan.replicates;
        meta["seed"] = plan.seed;
        if (plan.tolerance > 0) meta["tolerance"] = plan.tolerance;
    }
    if (!comparators.empty()) {
        nlohmann::json list = nlohmann::json::array();
        for (std::size_t k = 0; k < comparators.size(); ++k) {
            nlohmann::json c = comparators[k].provenance();
            c["max_abs_error"] = errors[k].max_abs();
            c["rms_error"] = errors[k].rms();
            c["n_dot_l_weighted_rms_error"] = errors[k].weighted_rms();
            c.update(compare::domain_report(domains[k], outside[k]));
            list.push_back(c);
        }
        meta["comparators"] = list;
        meta["comparator_roughness"] = "(alpha_x alpha_y)^(1/4)";
    }
    if (sidecar) outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    outputs.commit();

    if (!args.sampling.quiet)
        std::cerr << "eval: " << queries.size() << " queries (" << stats.sampled
                  << (plan.method == Method::exact ? " integrated, " : " sampled, ") << stats.exact_zero
                  << " exact 0 in the zero region, " << stats.exact_one << " exact 1 at v = 1), "
                  << (plan.method == Method::exact ? std::string("exact method, max estimated error ")
                                                   : std::to_string(plan.samples) + " samples each, max std error ")
                  << std::setprecision(3) << max_error << (tolerance.tolerance > 0 ? " " + tolerance.summary() : "") << ", "
                  << std::setprecision(3) << "computed in " << stats.seconds << " s on " << backend->name() << "\n";
    if (!args.sampling.quiet)
        for (std::size_t k = 0; k < comparators.size(); ++k)
            std::cerr << "eval: " << comparators[k].name() << " - term: max |error| " << std::setprecision(4)
                      << errors[k].max_abs() << ", RMS " << errors[k].rms() << ", N.L-weighted RMS "
                      << errors[k].weighted_rms() << "\n";
    // Said even with --quiet: the figures above mean little for a file used outside its domain.
    for (std::size_t k = 0; k < comparators.size(); ++k)
        if (outside[k].outside > 0)
            std::cerr << "eval: warning: " << comparators[k].name() << ": " << outside[k].outside << " of " << outside[k].lookups
                      << " queries outside its domain (" << domains[k]->describe() << "), e.g. " << first_outside[k]
                      << "; --strict-domain refuses them\n";
    finish_tolerance_check("eval", "queries", tolerance, args.allow_tolerance_miss);
}

}  // namespace

void add_eval_command(CLI::App& app) {
    auto args = std::make_shared<EvalArgs>();
    auto* cmd = app.add_subcommand("eval", "evaluate the generic term for the queries of a CSV file (exact by default, or sampled)");
    cmd->add_option("--in", args->in, "query CSV: " "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z")->required();
    cmd->add_option("--out", args->out, "result CSV: the input columns plus term,std_error (and the --compare columns), and its provenance in OUT.json "
                                       "(a symlink is followed; '-' writes the CSV to standard output, without the .json)")->required();
    cmd->add_option("--compare", args->compare,
                    "add a comparator column and its error column <name>_error = comparator - term (repeatable): "
                    "one of part 1's analytic terms (reference-step, naughty-dog, naughty-dog-ao-fresnel, activision, "
                    "activision-adjusted, pz-analytic), a baked LUT file (.exr, column named after the file stem) or "
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
