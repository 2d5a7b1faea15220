// The per-query micro-shadowing term as an integrand: items are batches of queries; the kernel routine
// is kernels/term/generic_term.cl, the oracle host/oracle/. Exact answers (the provable zero region, a
// light at or below the horizon, v = 1) are classified in double on the host and never sampled.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "sampling/point_set.hpp"
#include "schedule/integrand.hpp"
#include "schedule/scheduler.hpp"

namespace ms::term {

// Per-(query, replicate) tallies: cone[q * R + r], hemisphere[q * R + r], and how many samples passed
// each (the kernels count, so there the counts are the tallies; the oracle sums weights and counts apart).
struct Tallies {
    std::vector<double> cone, hemisphere;
    std::vector<double> cone_count, hemisphere_count;
    void resize(std::size_t n) {
        for (auto* v : {&cone, &hemisphere, &cone_count, &hemisphere_count}) v->assign(n, 0.0);
    }
};

// How the kernel routine runs (the oracle has no options).
struct RoutineConfig {
    ocl::BuildConfig build;
    std::size_t max_batch_queries = 1 << 15;  // bounds device memory per enqueue
    // Work-group size of the tally kernel (clamped to the device's limit). Fixed rather than left to
    // the runtime: PoCL compiles a work-group function per distinct local size, and with NullRange it
    // picks a new one for most new batch sizes. Results do not depend on it (tested).
    std::size_t local_size = 32;
};

// Tallies queries (normalised, outside the exact cases) on one place, over every replicate of a point set.
class Tallier {
public:
    virtual ~Tallier() = default;
    virtual void tally(const Query* queries, const TermOptions* options, std::size_t count, const PointSet& points,
                       Tallies& out, std::size_t out_offset) = 0;
};
std::unique_ptr<Tallier> make_device_tallier(ocl::Device& device, const RoutineConfig& config);
std::unique_ptr<Tallier> make_oracle_tallier();

// A batch: queries (valid, see core/query.hpp) and the options of each.
struct Batch {
    std::vector<Query> queries;
    std::vector<TermOptions> options;
};

struct Stats {
    std::atomic<std::uint64_t> sampled{0}, exact_zero{0}, exact_one{0};
};

class TermIntegrand final : public schedule::Integrand {
public:
    using Source = std::function<Batch(std::uint64_t item)>;                       // thread-safe
    using Sink = std::function<void(std::uint64_t item, std::vector<Estimate>&&)>;  // on the worker's thread
    TermIntegrand(std::uint64_t items, Source source, Sink sink, const SamplingPlan& plan, RoutineConfig config);

    std::string name() const override { return "the micro-shadowing term"; }
    std::uint64_t work_items() const override { return items_; }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override;
    std::unique_ptr<schedule::Worker> oracle_worker() override;
    const Stats& stats() const { return stats_; }

    // Estimates of one batch on a tallier: exact answers by rule, the rest sampled.
    std::vector<Estimate> evaluate(Tallier& tallier, const Batch& batch);

private:
    std::uint64_t items_;
    Source source_;
    Sink sink_;
    SamplingPlan plan_;
    RoutineConfig config_;
    std::shared_ptr<const PointSet> points_;  // made on first use, shared by every place
    std::mutex points_mutex_;
    Stats stats_;
    const PointSet& points();
};

// Queries per work item so one item stays well under a second (cancellation latency, progress):
// a device takes up to config.max_batch_queries; an oracle thread about 2^21 samples (~0.3 s).
std::uint64_t queries_per_item(const schedule::Scheduler& scheduler, const SamplingPlan& plan, const RoutineConfig& config);

// Raw per-replicate tallies of normalised queries on a given point set, on the scheduler's places
// (tests compare backends and kernels on the same points; benchmarks time them).
Tallies tally(schedule::Scheduler& scheduler, const std::vector<Query>& queries, const TermOptions& options,
              const PointSet& points, const RoutineConfig& config = {});

}  // namespace ms::term
