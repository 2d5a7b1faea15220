// The micro-shadowing of area lights (core/area_light.hpp) as an integrand: items are runs of queries.
// Three ways to compute an item, one per place:
//   - the kernel routine (kernels/area_light/area_light.cl): light directions and visible normals
//     sampled jointly from one scrambled 4D net per replicate, the term's denominator in closed form;
//   - the scalar double oracle (oracle/area_light_oracle.hpp): outer light directions, an inner
//     sampled term per direction, written apart;
//   - a given inner term T(wo) (AreaRoutineConfig::inner_term, e.g. a deterministic evaluator): the
//     light sampled on the host exactly as the kernel samples it, T(wo) asked per direction, on every
//     place (the kernel and the oracle are then not used).
// Exact answers are classified on the host first and never sampled: no light direction above the
// horizon (0), every light direction in the term's zero region (0), visibility 1 (1).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "core/area_light.hpp"
#include "core/types.hpp"
#include "device/runtime.hpp"
#include "sampling/joint_point_set.hpp"
#include "schedule/integrand.hpp"

namespace ms::area {

struct AreaEstimate {
    Estimate term;           // T_area, std_error a Student-t quantity with R - 1 degrees of freedom
    Estimate lobe_integral;  // Int_light f cos dwo above the horizon (only when sampled)
    // With a given inner term that reports its own error (AreaRoutineConfig::inner_term): a bound on
    // the part of T_area's error the inner values carry, Sum W/p |e(wo)| / Sum W/p over every outer
    // direction of every replicate (the error of a weighted mean is the weighted mean of the errors).
    // A deterministic bound, apart from term.std_error, which is the outer sampling's alone. 0 otherwise.
    double inner_error = 0;
    bool sampled = false;    // false: an exact answer by rule (below)
};

enum class ExactCase { none, below_horizon, zero_region, visibility_one };
// Which exact rule answers a (valid, normalised) query, if any.
ExactCase classify(const AreaQuery& q, AoWeighting ao_weighting);

// T(wo) for a point query (normalised, wo above the horizon) and a bound on its error (0: exact, or
// unknown); called concurrently from every place. A function returning a plain double converts.
struct InnerValue {
    double term = 0, error = 0;
    InnerValue(double t = 0, double e = 0) : term(t), error(e) {}  // NOLINT: implicit from double on purpose
};
using InnerTerm = std::function<InnerValue(const Query&)>;

struct AreaRoutineConfig {
    ocl::BuildConfig build;
    std::size_t local_size = 32;
    std::uint32_t max_points_per_work_item = 4096;  // bounds each lane's float sums (256 terms)
    std::size_t max_batch_queries = 4096;
    InnerTerm inner_term;  // set: every place uses it (see above)
};

struct AreaStats {
    std::atomic<std::uint64_t> sampled{0}, below_horizon{0}, zero_region{0}, visibility_one{0};
};

class AreaIntegrand final : public schedule::Integrand {
public:
    // Queries are validated here (std::invalid_argument naming the first bad one, with its index).
    AreaIntegrand(std::vector<AreaQuery> queries, TermOptions options, const SamplingPlan& plan,
                  AreaRoutineConfig config, std::size_t queries_per_item);
    std::string name() const override { return "the micro-shadowing of area lights"; }
    std::uint64_t work_items() const override { return (queries_.size() + per_item_ - 1) / per_item_; }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override;
    std::unique_ptr<schedule::Worker> oracle_worker() override;

    const std::vector<AreaEstimate>& results() const { return results_; }
    const AreaStats& stats() const { return stats_; }

    // The pieces the workers share (public for the workers in the .cpp).
    const std::vector<AreaQuery>& queries() const { return queries_; }
    const TermOptions& options() const { return options_; }
    const SamplingPlan& plan() const { return plan_; }
    const AreaRoutineConfig& config() const { return config_; }
    std::size_t queries_per_item() const { return per_item_; }
    const JointPointSet& points();
    // Answers the exact cases of item `id`'s queries; returns the indices left to sample.
    std::vector<std::size_t> answer_exact(std::uint64_t id);
    void store(std::size_t index, const AreaEstimate& e) { results_[index] = e; }
    void count_sampled(std::size_t n) { stats_.sampled += n; }

private:
    std::vector<AreaQuery> queries_;  // normalised
    TermOptions options_;
    SamplingPlan plan_;
    AreaRoutineConfig config_;
    std::size_t per_item_;
    std::vector<AreaEstimate> results_;
    std::unique_ptr<JointPointSet> points_;
    std::mutex mutex_;
    AreaStats stats_;
};

// Queries per work item so one item stays well under a second (device: ~2^26 samples, about 0.3 s of
// the joint kernel on 2 CPU cores; oracle thread: ~2^21 samples; a given inner term: ~2^14 calls, about
// 0.15 s of the exact evaluator at its default tolerance).
std::size_t area_queries_per_item(bool oracle, const SamplingPlan& plan, const AreaRoutineConfig& config);

// From per-replicate sums of a ratio of integrals: the pooled ratio, its replicate standard error, and
// (like the term) the binomial bound when no sample passed the cones in any replicate.
Estimate reduce_area_replicates(const std::vector<double>& numerator, const std::vector<double>& denominator,
                                double passed, double weighted);

}  // namespace ms::area
