// `microshadow area eval | sweep` as jobs that own their runs: T_area of sphere and rectangle lights
// (jobs/area.hpp), their CSV outputs and the provenance beside them. The CLI (cli/cmd_area.cpp) turns
// flags into these specs and prints; the library's area_evaluate (api/area.cpp) runs the same
// evaluation on queries in memory.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "jobs/area.hpp"
#include "jobs/eval.hpp"
#include "jobs/job_callbacks.hpp"
#include "jobs/tolerance_check.hpp"

namespace ms::area {

// How T_area is evaluated. The exact method samples the outer integral over the light (exact_inner_term):
// `plan` is then a sampled plan too, and `inner_tolerance` the inner term's, evaluated on the host's
// threads (the scalar double evaluator) whatever `make_backend` would give.
struct AreaEvalMethod {
    TermOptions term;
    SamplingPlan plan;                  // the outer (light) sampling
    bool exact = false;
    double inner_tolerance = kExactInnerTolerance;
    // The sampled method's backend (the joint kernel); called once the inputs and outputs are checked.
    std::function<std::unique_ptr<TermBackend>()> make_backend;
};

struct AreaEvalRun {
    std::vector<AreaEstimate> estimates;
    AreaEvalStats stats;
    std::string backend;
};

// T_area of validated queries by `method` (std::invalid_argument for an inner tolerance out of range).
AreaEvalRun evaluate_area_queries(const AreaEvalMethod& method, const std::vector<AreaQuery>& queries,
                                  const JobCallbacks& callbacks = {});

struct AreaEvalJobSpec {
    std::string in;                     // the query CSV (its columns by `shape`)
    std::string out;                    // the result CSV ('-': standard output, without the OUT.json provenance)
    LightShape shape = LightShape::sphere;
    Lobe lobe = Lobe::ggx;
    AreaEvalMethod method;
    std::string command_line;           // provenance
};

struct AreaEvalJobResult {
    AreaEvalRun run;
    std::size_t queries = 0;
    double max_std_error = 0, max_inner_error = 0;
    ToleranceCheck tolerance;           // the exact method's inner errors against its tolerance
};

// Reads the CSV, evaluates, and writes the CSV and its provenance (all or nothing).
AreaEvalJobResult run_area_eval_job(const AreaEvalJobSpec& spec, const JobCallbacks& callbacks = {});
std::string area_eval_job_summary(const AreaEvalJobSpec& spec, const AreaEvalJobResult& result);

struct AreaSweepJobSpec {
    std::string out;                    // the sweep CSV (and OUT.json)
    LightShape shape = LightShape::sphere;
    std::size_t random = 0;             // N random lights in place of the grid (rectangles: required)
    double max_half_angle = 30;         // degrees, of the random lights
    StudyGrid grid;
    TermOptions term;
    SamplingPlan plan;
    std::function<std::unique_ptr<TermBackend>()> make_backend;
    std::string command_line;
};

struct AreaSweepJobResult {
    std::size_t points = 0;
    std::string backend;
};

// Checks the grid, runs the study and writes the CSV and its provenance (all or nothing).
AreaSweepJobResult run_area_sweep_job(const AreaSweepJobSpec& spec, const JobCallbacks& callbacks = {});

}  // namespace ms::area
