// `microshadow eval` as a job that owns its run: the term for every query of a CSV file, the
// comparators' columns (`--compare`), the result CSV and its provenance beside it. The CLI
// (cli/cmd_eval.cpp) only turns flags into this spec and prints the summary.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error_stats.hpp"
#include "core/lookup_domain.hpp"
#include "jobs/eval.hpp"
#include "jobs/job_callbacks.hpp"
#include "jobs/tolerance_check.hpp"

namespace ms {

struct EvalJobSpec {
    std::string in;                     // the query CSV
    std::string out;                    // the result CSV ('-': standard output, without the OUT.json provenance)
    TermOptions term;
    SamplingPlan plan;
    std::vector<std::string> compare;   // comparators: NAME | FILE | NAME=FILE (compare::parse_comparators)
    bool strict_domain = false;         // refuse queries outside a comparator's domain, writing nothing
    bool fast_math = false;             // recorded in the provenance (the backend was built with it)
    std::string command_line;           // provenance
    // Where the term is evaluated; called once the inputs and outputs have been checked.
    std::function<std::unique_ptr<TermBackend>()> make_backend;
};

// One comparator's column against the term: its errors (comparator - term, weighted by max(N.L, 0)) and
// the queries that fell outside its domain.
struct EvalComparatorResult {
    std::string name;
    std::optional<LookupDomain> domain;
    DomainTally outside;
    std::string first_outside;          // "query N: ..." for the first one outside, or empty
    ErrorStats errors;
};

struct EvalJobResult {
    std::size_t queries = 0;
    EvalStats stats;
    std::string backend;
    double max_std_error = 0;
    ToleranceCheck tolerance;           // the exact method always has one; the sampled one when asked
    std::vector<EvalComparatorResult> comparators;
};

// Reads the queries, evaluates the term and the comparators, and writes the CSV and its provenance
// (all or nothing). std::invalid_argument for bad input; ms::Cancelled when stopped.
EvalJobResult run_eval_job(const EvalJobSpec& spec, const JobCallbacks& callbacks = {});
// The lines the command prints unless --quiet.
std::string eval_job_summary(const EvalJobSpec& spec, const EvalJobResult& result);
// The warnings said even with --quiet: queries outside a comparator's domain.
std::string eval_job_warnings(const EvalJobResult& result);

}  // namespace ms
