// `microshadow eval` as a job: the term integrand (integrands/term/) over a list of queries, on the
// scheduler (schedule/). Provable zeros and v = 1 queries are answered exactly without sampling.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/query.hpp"
#include "core/types.hpp"
#include "device/runtime.hpp"
#include "integrands/term/term_integrand.hpp"
#include "sampling/point_set.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

using term::Tallies;
using OpenClBackendConfig = term::RoutineConfig;

// Where the term is evaluated (a scheduler over OpenCL devices or oracle threads) and how its kernel
// routine is built. Eval, sweeps, verification and the tests hold one of these.
class TermBackend {
public:
    // Where the user named (the scheduler resolves it: schedule::BackendSpec).
    TermBackend(const schedule::BackendSpec& where, term::RoutineConfig config = {});
    // Places chosen by the caller (tests, benchmarks).
    TermBackend(schedule::Backend where, term::RoutineConfig config = {});
    std::string name() const { return scheduler_.name(); }
    schedule::Scheduler& scheduler() { return scheduler_; }
    const term::RoutineConfig& config() const { return config_; }
    // Raw per-replicate tallies of normalised, non-trivial queries on a given point set.
    Tallies tally(const std::vector<Query>& queries, const TermOptions& options, const PointSet& points);

private:
    schedule::Scheduler scheduler_;
    term::RoutineConfig config_;
};

// The scalar double oracle, spread over `threads` threads (0: all hardware threads).
std::unique_ptr<TermBackend> make_oracle_backend(unsigned threads = 0);
// The OpenCL kernels on the given devices; work items are shared out among them.
std::unique_ptr<TermBackend> make_opencl_backend(const std::vector<ocl::DeviceInfo>& devices,
                                                 const OpenClBackendConfig& config = {});
// The term's routine where `where` says (its OpenCL build options from `config`).
std::unique_ptr<TermBackend> make_term_backend(const schedule::BackendSpec& where, const OpenClBackendConfig& config = {});

struct EvalStats {
    std::size_t sampled = 0;       // queries that were integrated
    std::size_t exact_zero = 0;    // zero region or light below the horizon: exactly 0
    std::size_t exact_one = 0;     // visibility 1: exactly 1
    std::size_t rerun = 0;         // work items rerun after a device failed
    std::vector<std::string> failed_devices;
    double seconds = 0;
    // Sampled to a tolerance: the queries sampled again with more points, and the most points one got
    // (0 when no query was sampled again).
    std::size_t resampled = 0;
    std::uint64_t most_samples = 0;
};

// Validates the queries (std::invalid_argument naming the first bad one), answers the trivial ones
// exactly, and samples the rest with the point set of `plan`. Progress reports (done, total) queries.
// Throws ms::Cancelled when cancellation was requested (nothing is returned).
std::vector<Estimate> evaluate(TermBackend& backend, const std::vector<Query>& queries, const TermOptions& options,
                               const SamplingPlan& plan, EvalStats* stats = nullptr,
                               const std::function<void(std::size_t, std::size_t)>& progress = {});
// The same with options per query (sweeps mix forms and AO weightings in one run).
std::vector<Estimate> evaluate_each(TermBackend& backend, const std::vector<Query>& queries,
                                    const std::vector<TermOptions>& options, const SamplingPlan& plan,
                               EvalStats* stats = nullptr,
                               const std::function<void(std::size_t, std::size_t)>& progress = {});

// The provenance of the exact method under `plan` (method, rule, tolerance, what the error column holds),
// recorded by every output it made. (What decides its bits, for cache keys: jobs/cache_keys.hpp.)
nlohmann::json exact_provenance(const SamplingPlan& plan);

}  // namespace ms
