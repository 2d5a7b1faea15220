#include "jobs/eval.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <stdexcept>

#include "exact/cap_region.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"

namespace ms {

namespace {
std::string format_rho(double rho) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", rho);
    return text;
}
}  // namespace

TermBackend::TermBackend(const schedule::BackendSpec& where, term::RoutineConfig config)
    : scheduler_(where), config_(std::move(config)) {}

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

std::unique_ptr<TermBackend> make_term_backend(const schedule::BackendSpec& where, const OpenClBackendConfig& config) {
    // The oracle builds no kernel: its config stays the default (provenance records no build options).
    return std::make_unique<TermBackend>(where, where.is_oracle() ? OpenClBackendConfig{} : config);
}

nlohmann::json exact_provenance(const SamplingPlan& plan) {
    const double tolerance = plan.tolerance > 0 ? plan.tolerance : exact::kDefaultTolerance;
    const exact::ArcRule rule = exact::arc_rule_for(tolerance);
    return {{"method", "exact"},
            {"evaluator", "boundary integral of the VNDF over the cone and hemisphere (closed-form great circles, "
                          "pole-aware Gauss-Legendre on the other arcs)"},
            {"rule", "Gauss-Legendre " + std::to_string(rule.high) + " nodes per piece, error from " +
                         std::to_string(rule.low) + " nodes, pieces split until every pole lies outside the "
                         "Bernstein ellipse rho = " + format_rho(rule.rho)},
            {"tolerance", tolerance},
            {"kernel_precision", plan.single_precision ? "float" : "double where the device has fp64, else float"},
            {"engines_on_opencl", [&] {
                 exact_term::ExactConfig engines;
                 engines.force_float = plan.single_precision;
                 engines.kernel_on_cpu_devices = plan.kernel_on_cpu_devices;
                 return exact_term::describe_engines(engines);
             }()},
            {"error", "std_error holds the estimated absolute error of each value (the lower-order rule's "
                      "difference plus a rounding floor), not a standard deviation"}};
}

namespace {

// Runs queries in fixed batches of `per_item` through an integrand with the term integrands' Source/Sink
// contract (term::TermIntegrand, exact_term::ExactTermIntegrand), with progress in queries and the run's
// report in `stats`. `make` builds the integrand from (items, source, sink); `count` reads its
// (evaluated, exact_zero, exact_one) after the run.
template <class Make, class Count>
std::vector<Estimate> run_batches(TermBackend& backend, const std::vector<Query>& queries,
                                  const std::vector<TermOptions>& options, std::uint64_t per_item, EvalStats* stats,
                                  const std::function<void(std::size_t, std::size_t)>& progress,
                                  std::chrono::steady_clock::time_point start, Make make, Count count) {
    const std::uint64_t items = (queries.size() + per_item - 1) / per_item;
    std::vector<Estimate> results(queries.size());
    auto integrand = make(
        items,
        [&](std::uint64_t item) {
            const std::size_t first = std::size_t(item * per_item);
            const std::size_t last = std::min(queries.size(), std::size_t(first + per_item));
            return term::Batch{{queries.begin() + first, queries.begin() + last},
                               {options.begin() + first, options.begin() + last}};
        },
        [&](std::uint64_t item, std::vector<Estimate>&& estimates) {
            std::copy(estimates.begin(), estimates.end(), results.begin() + std::size_t(item * per_item));
        });
    schedule::RunCallbacks callbacks;
    if (progress)
        callbacks.progress = [&](std::uint64_t done, std::uint64_t) {
            progress(std::min<std::size_t>(queries.size(), std::size_t(done * per_item)), queries.size());
        };
    const schedule::RunReport report = backend.scheduler().run(*integrand, {}, callbacks);
    if (stats) {
        count(*integrand, *stats);
        stats->rerun = report.rerun;
        stats->failed_devices = report.failed_places;
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    return results;
}

// The exact method (host/exact/) on the same scheduler: each value with its estimated error in std_error.
std::vector<Estimate> evaluate_exact(TermBackend& backend, const std::vector<Query>& queries,
                                     const std::vector<TermOptions>& options, const SamplingPlan& plan, EvalStats* stats,
                                     const std::function<void(std::size_t, std::size_t)>& progress,
                                     std::chrono::steady_clock::time_point start) {
    exact_term::ExactConfig config;
    config.tolerance = plan.tolerance > 0 ? plan.tolerance : exact::kDefaultTolerance;
    config.build = backend.config().build;
    config.force_float = plan.single_precision;
    config.kernel_on_cpu_devices = plan.kernel_on_cpu_devices;
    return run_batches(
        backend, queries, options, exact_term::queries_per_item(backend.scheduler()), stats, progress, start,
        [&](std::uint64_t items, term::TermIntegrand::Source source, term::TermIntegrand::Sink sink) {
            return std::make_unique<exact_term::ExactTermIntegrand>(items, std::move(source), std::move(sink), config);
        },
        [](const exact_term::ExactTermIntegrand& integrand, EvalStats& s) {
            s.sampled = integrand.stats().evaluated;
            s.exact_zero = integrand.stats().exact_zero;
            s.exact_one = integrand.stats().exact_one;
        });
}

}  // namespace

std::vector<Estimate> evaluate(TermBackend& backend, const std::vector<Query>& queries, const TermOptions& options,
                               const SamplingPlan& plan, EvalStats* stats,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
    return evaluate_each(backend, queries, std::vector<TermOptions>(queries.size(), options), plan, stats, progress);
}

namespace {
std::vector<Estimate> evaluate_sampled(TermBackend& backend, const std::vector<Query>& queries,
                                       const std::vector<TermOptions>& options, const SamplingPlan& plan, EvalStats* stats,
                                       const std::function<void(std::size_t, std::size_t)>& progress,
                                       std::chrono::steady_clock::time_point start);
}  // namespace

// Largest per-query sample count a sampled run with a tolerance climbs to.
constexpr std::uint64_t kMaxToleranceSamples = std::uint64_t(1) << 24;

std::vector<Estimate> evaluate_each(TermBackend& backend, const std::vector<Query>& queries,
                                    const std::vector<TermOptions>& options, const SamplingPlan& plan, EvalStats* stats,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
    const auto start = std::chrono::steady_clock::now();
    if (options.size() != queries.size()) throw std::invalid_argument("evaluate: one option set per query");
    // Every query before any work (the exact method's own domain too), named by its position.
    for (std::size_t i = 0; i < queries.size(); ++i) {
        try {
            plan.method == Method::exact ? validate_exact_query(queries[i]) : validate_query(queries[i]);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("query " + std::to_string(i + 1) + ": " + e.what());
        }
    }
    if (plan.method == Method::exact) return evaluate_exact(backend, queries, options, plan, stats, progress, start);
    std::vector<Estimate> results = evaluate_sampled(backend, queries, options, plan, stats, progress, start);
    if (!(plan.tolerance > 0)) return results;
    // To a tolerance: the queries whose standard error is above it again with 4x the samples and an
    // independent scramble (seed + round), until none is left or the sample cap is reached.
    SamplingPlan round = plan;
    for (std::uint64_t r = 1;; ++r) {
        std::vector<Query> again;
        std::vector<TermOptions> again_options;
        std::vector<std::size_t> where;
        for (std::size_t i = 0; i < results.size(); ++i)
            if (results[i].std_error > plan.tolerance) {
                again.push_back(queries[i]);
                again_options.push_back(options[i]);
                where.push_back(i);
            }
        if (again.empty() || round.samples * 4 > kMaxToleranceSamples) break;
        round.samples *= 4;
        round.seed = plan.seed + r;
        EvalStats round_stats;
        const std::vector<Estimate> better = evaluate_sampled(backend, again, again_options, round, &round_stats, {}, start);
        for (std::size_t k = 0; k < where.size(); ++k) results[where[k]] = better[k];
        if (stats) {
            stats->rerun += round_stats.rerun;
            stats->seconds = round_stats.seconds;
            if (r == 1) stats->resampled = where.size();  // later rounds take a subset of these
            stats->most_samples = round.samples;
        }
    }
    return results;
}

namespace {
std::vector<Estimate> evaluate_sampled(TermBackend& backend, const std::vector<Query>& queries,
                                       const std::vector<TermOptions>& options, const SamplingPlan& plan, EvalStats* stats,
                                       const std::function<void(std::size_t, std::size_t)>& progress,
                                       std::chrono::steady_clock::time_point start) {
    return run_batches(
        backend, queries, options, term::queries_per_item(backend.scheduler(), plan, backend.config()), stats, progress,
        start,
        [&](std::uint64_t items, term::TermIntegrand::Source source, term::TermIntegrand::Sink sink) {
            return std::make_unique<term::TermIntegrand>(items, std::move(source), std::move(sink), plan, backend.config());
        },
        [](const term::TermIntegrand& integrand, EvalStats& s) {
            s.sampled = integrand.stats().sampled;
            s.exact_zero = integrand.stats().exact_zero;
            s.exact_one = integrand.stats().exact_one;
        });
}

}  // namespace

}  // namespace ms
