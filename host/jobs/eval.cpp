#include "jobs/eval.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace ms {

TermBackend::TermBackend(schedule::Backend where, term::RoutineConfig config)
    : scheduler_(std::move(where)), config_(std::move(config)) {}

Tallies TermBackend::tally(const std::vector<Query>& queries, const TermOptions& options, const PointSet& points) {
    return term::tally(scheduler_, queries, options, points, config_);
}

std::unique_ptr<TermBackend> make_oracle_backend(unsigned threads) {
    return std::make_unique<TermBackend>(schedule::Backend::oracle(threads));
}

std::unique_ptr<TermBackend> make_opencl_backend(const std::vector<ocl::DeviceInfo>& devices,
                                                 const OpenClBackendConfig& config) {
    return std::make_unique<TermBackend>(schedule::Backend::opencl(devices), config);
}

std::vector<Estimate> evaluate(TermBackend& backend, const std::vector<Query>& queries, const TermOptions& options,
                               const SamplingPlan& plan, EvalStats* stats,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
    return evaluate_each(backend, queries, std::vector<TermOptions>(queries.size(), options), plan, stats, progress);
}

std::vector<Estimate> evaluate_each(TermBackend& backend, const std::vector<Query>& queries,
                                    const std::vector<TermOptions>& options, const SamplingPlan& plan, EvalStats* stats,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
    const auto start = std::chrono::steady_clock::now();
    if (options.size() != queries.size()) throw std::invalid_argument("evaluate: one option set per query");
    for (const Query& q : queries) validate_query(q);  // every query before any work
    const std::uint64_t per_item = term::queries_per_item(backend.scheduler(), plan, backend.config());
    const std::uint64_t items = (queries.size() + per_item - 1) / per_item;
    std::vector<Estimate> results(queries.size());
    term::TermIntegrand integrand(
        items,
        [&](std::uint64_t item) {
            const std::size_t first = std::size_t(item * per_item);
            const std::size_t last = std::min(queries.size(), std::size_t(first + per_item));
            return term::Batch{{queries.begin() + first, queries.begin() + last},
                               {options.begin() + first, options.begin() + last}};
        },
        [&](std::uint64_t item, std::vector<Estimate>&& estimates) {
            std::copy(estimates.begin(), estimates.end(), results.begin() + std::size_t(item * per_item));
        },
        plan, backend.config());
    schedule::RunCallbacks callbacks;
    if (progress)
        callbacks.progress = [&](std::uint64_t done, std::uint64_t) {
            progress(std::min<std::size_t>(queries.size(), std::size_t(done * per_item)), queries.size());
        };
    const schedule::RunReport report = backend.scheduler().run(integrand, {}, callbacks);
    if (stats) {
        stats->sampled = integrand.stats().sampled;
        stats->exact_zero = integrand.stats().exact_zero;
        stats->exact_one = integrand.stats().exact_one;
        stats->rerun = report.rerun;
        stats->failed_devices = report.failed_places;
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return results;
}

}  // namespace ms
