#include "jobs/eval_run.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "jobs/compare.hpp"

namespace ms {

EvalJobResult run_eval_job(const EvalJobSpec& spec, const JobCallbacks& callbacks) {
    const TermOptions& term = spec.term;
    const SamplingPlan& plan = spec.plan;
    JobControl control(callbacks);
    // Comparators first: a bad name, an unreadable LUT or a clashing column stops before any work.
    std::vector<std::string> taken(kQueryColumns.begin(), kQueryColumns.end());
    taken.insert(taken.end(), {"term", "std_error"});
    const std::vector<compare::Comparator> comparators = compare::parse_comparators(spec.compare, taken);
    const std::vector<Query> queries = read_query_csv(spec.in);
    EvalJobResult result;
    result.queries = queries.size();
    // Comparator values (cheap) before the term, so a query a comparator cannot take is refused first.
    std::vector<std::vector<double>> compared(comparators.size(), std::vector<double>(queries.size()));
    std::vector<double> n_dot_l(queries.size());
    // Lookups outside each comparator's domain are answered (clamped) but counted, and reported.
    result.comparators.resize(comparators.size());
    for (std::size_t k = 0; k < comparators.size(); ++k) {
        result.comparators[k].name = comparators[k].name();
        result.comparators[k].domain = comparators[k].domain();
    }
    for (std::size_t i = 0; i < queries.size() && !comparators.empty(); ++i) {
        const approx::Inputs in = approx::inputs_of(queries[i], term.ao_weighting);
        n_dot_l[i] = in.n_dot_l;
        for (std::size_t k = 0; k < comparators.size(); ++k) {
            EvalComparatorResult& c = result.comparators[k];
            if (c.domain) {
                const bool inside = c.domain->contains(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
                c.outside.add(inside);
                if (!inside && c.first_outside.empty())
                    c.first_outside = "query " + std::to_string(i + 1) + ": " +
                                      c.domain->first_outside(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
            }
            try {
                compared[k][i] = comparators[k](in);
            } catch (const std::domain_error& e) {
                throw std::invalid_argument(spec.in + ": query " + std::to_string(i + 1) + ": --compare " +
                                            comparators[k].name() + ": " + e.what());
            }
        }
    }
    if (spec.strict_domain)
        for (const EvalComparatorResult& c : result.comparators)
            if (c.domain) compare::refuse_outside_domain(spec.in, c.name, *c.domain, c.outside, c.first_outside);
    // Both outputs checked before computing, written together or not at all. `--out -` writes the
    // CSV to standard output and no sidecar: its provenance has no file to sit beside.
    OutputSet outputs;
    const std::size_t csv_out = outputs.add(spec.out, false, /*allow_stdout=*/true);
    const bool sidecar = !outputs.to_stdout(csv_out);
    const std::size_t json_out = sidecar ? outputs.add(spec.out + ".json") : 0;
    auto backend = spec.make_backend();
    result.backend = backend->name();

    const auto results = evaluate(*backend, queries, term, plan, &result.stats, control.progress());
    control.checkpoint();

    auto& out = outputs.stream(csv_out);
    for (const auto& c : kQueryColumns) out << c << ",";
    out << "term,std_error";
    for (const auto& c : comparators) out << "," << c.name() << "," << c.name() << "_error";
    out << "\n";
    // Per comparator: max |e|, RMS and the N.L-weighted RMS, w = max(N.L, 0).
    // The exact method always has a tolerance (its default when not given); the sampled one when given.
    result.tolerance.tolerance = plan.tolerance;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const Query& q = queries[i];
        for (double v : {q.visibility, q.alpha_x, q.alpha_y, q.wi.x, q.wi.y, q.wi.z, q.wo.x, q.wo.y, q.wo.z})
            out << format_number(v) << ",";
        out << format_number(results[i].term) << "," << format_number(results[i].std_error);
        for (std::size_t k = 0; k < comparators.size(); ++k) {
            const double e = compared[k][i] - results[i].term;
            result.comparators[k].errors.add(e, std::max(n_dot_l[i], 0.0));
            out << "," << format_number(compared[k][i]) << "," << format_number(e);
        }
        out << "\n";
        result.max_std_error = std::max(result.max_std_error, results[i].std_error);
        result.tolerance.add(results[i].std_error);
    }

    // Provenance beside the CSV (CSV has no standard place for metadata).
    nlohmann::json meta = {{"program", "microshadow " MICROSHADOW_VERSION},
                           {"command_line", spec.command_line},
                           {"backend", result.backend},
                           {"form", to_string(term.form)},
                           {"ao_weighting", to_string(term.ao_weighting)},
                           {"method", to_string(plan.method)},
                           {"fast_math", spec.fast_math},
                           {"queries", queries.size()},
                           {"sampled", result.stats.sampled},
                           {"exact_zero", result.stats.exact_zero},
                           {"exact_one", result.stats.exact_one},
                           {"max_std_error", result.max_std_error}};
    if (result.tolerance.tolerance > 0) {
        meta["tolerance_met"] = result.tolerance.met();
        meta["queries_over_tolerance"] = result.tolerance.over;
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
            const EvalComparatorResult& r = result.comparators[k];
            nlohmann::json c = comparators[k].provenance();
            c["max_abs_error"] = r.errors.max_abs();
            c["rms_error"] = r.errors.rms();
            c["n_dot_l_weighted_rms_error"] = r.errors.weighted_rms();
            c.update(compare::domain_report(r.domain, r.outside));
            list.push_back(c);
        }
        meta["comparators"] = list;
        meta["comparator_roughness"] = "(alpha_x alpha_y)^(1/4)";
    }
    if (sidecar) outputs.stream(json_out) << dump_json(meta, 2) << "\n";
    control.checkpoint();
    outputs.commit();
    return result;
}

std::string eval_job_summary(const EvalJobSpec& spec, const EvalJobResult& r) {
    const SamplingPlan& plan = spec.plan;
    std::ostringstream o;
    o << "eval: " << r.queries << " queries (" << r.stats.sampled << (plan.method == Method::exact ? " integrated, " : " sampled, ")
      << r.stats.exact_zero << " exact 0 in the zero region, " << r.stats.exact_one << " exact 1 at v = 1), "
      << (plan.method == Method::exact ? std::string("exact method, max estimated error ")
                                       : std::to_string(plan.samples) + " samples each" +
                                             (r.stats.resampled ? ", up to " + std::to_string(r.stats.most_samples) + " for the " +
                                                                      std::to_string(r.stats.resampled) + " sampled again to the tolerance"
                                                                : std::string()) +
                                             ", max std error ")
      << std::setprecision(3) << r.max_std_error << (r.tolerance.tolerance > 0 ? " " + r.tolerance.summary() : "") << ", "
      << std::setprecision(3) << "computed in " << r.stats.seconds << " s on " << r.backend << "\n";
    for (const EvalComparatorResult& c : r.comparators)
        o << "eval: " << c.name << " - term: max |error| " << std::setprecision(4) << c.errors.max_abs() << ", RMS "
          << c.errors.rms() << ", N.L-weighted RMS " << c.errors.weighted_rms() << "\n";
    return o.str();
}

std::string eval_job_warnings(const EvalJobResult& r) {
    std::ostringstream o;
    for (const EvalComparatorResult& c : r.comparators)
        if (c.outside.outside > 0)
            o << "eval: warning: " << c.name << ": " << c.outside.outside << " of " << c.outside.lookups
              << " queries outside its domain (" << c.domain->describe() << "), e.g. " << c.first_outside
              << "; --strict-domain refuses them\n";
    return o.str();
}

}  // namespace ms
