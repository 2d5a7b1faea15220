#include "integrands/term/term_integrand.hpp"

#include <algorithm>
#include <cfloat>
#include <map>
#include <mutex>
#include <stdexcept>

#include "core/cancel.hpp"
#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "core/query.hpp"
#include "microshadow_shared.h"
#include "oracle/oracle.hpp"

namespace ms::term {

static_assert(sizeof(ms_query) == 48, "ms_query layout must match the OpenCL C struct");
static_assert(sizeof(ms_tally) == 8, "ms_tally layout must match the OpenCL C struct");

namespace {

// A component that is positive in double must stay positive in float: a light 1e-46 above the horizon
// would underflow to wo_z = 0, which the kernel reads as "on the horizon, term 0" (the oracle gives
// 0.959 there). FLT_MIN moves it by less than 1.2e-38, far below anything the term resolves.
float positive_float(double x) { return x > 0 ? std::max(float(x), FLT_MIN) : float(x); }

class DeviceTallier final : public Tallier {
public:
    DeviceTallier(ocl::Device& device, RoutineConfig config) : device_(device), config_(std::move(config)) {
        ocl::require_build_support(device_.info(), config_.build);
    }

    void tally(const Query* queries, const TermOptions* options, std::size_t count, const PointSet& points,
               Tallies& out, std::size_t out_offset) override {
        for (std::size_t first = 0; first < count; first += config_.max_batch_queries)
            run_batch(queries + first, options + first, std::min(config_.max_batch_queries, count - first), points, out,
                      out_offset + first);
    }

private:
    // Points are uploaded once and reused while the same point set is passed again.
    void upload(const PointSet& points) {
        // The address alone is not enough: a freed point set's address can be reused by another plan.
        if (uploaded_ == &points && seed_ == points.seed && total_ == points.total() && replicates_ == points.replicates &&
            sequence_ == points.sequence)
            return;
        const ocl::PointBuffers b = ocl::upload_points(device_, points.u1, points.u2);
        u1_ = b.u1;
        u2_ = b.u2;
        uploaded_ = &points;
        seed_ = points.seed;
        total_ = points.total();
        replicates_ = points.replicates;
        sequence_ = points.sequence;
    }

    void run_batch(const Query* queries, const TermOptions* options, std::size_t count, const PointSet& points,
                   Tallies& out, std::size_t out_offset) {
        const std::uint32_t R = points.replicates;
        const std::uint32_t n = points.points_per_replicate;
        // Split replicates into chunks until the device has enough work-items to stay busy: a few per
        // CPU core, thousands per GPU compute unit. Chunks keep a multiple of MS_LANES points.
        const std::size_t target = std::size_t(device_.info().compute_units) * (device_.info().type == "GPU" ? 2048 : 8);
        std::uint32_t chunks = 1;
        while (count * R * chunks < target && n / (chunks * 2) >= 256) chunks *= 2;

        std::vector<ms_query> packed(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Query& q = queries[i];
            ms_query& p = packed[i];
            p = ms_query{};
            p.cos_theta = float(cone_cos_theta(q.visibility, options[i].ao_weighting));
            p.sin2_cone = float(cone_sin2_theta(q.visibility, options[i].ao_weighting));
            p.alpha_x = float(q.alpha_x);
            p.alpha_y = float(q.alpha_y);
            p.wi_x = float(q.wi.x), p.wi_y = float(q.wi.y), p.wi_z = positive_float(q.wi.z);
            p.wo_x = float(q.wo.x), p.wo_y = float(q.wo.y), p.wo_z = positive_float(q.wo.z);
        }
        upload(points);
        const std::size_t items = count * R * chunks;
        std::vector<ms_tally> tallies(items);
        ocl::checked([&] {
            cl::Kernel kernel = device_.kernel("term/generic_term.cl", "ms_tally_queries", config_.build);
            const std::size_t local = ocl::local_size(kernel, device_.info(), config_.local_size);
            const std::size_t global = ocl::round_up(items, local);  // the kernel checks its range
            cl::Buffer qbuf(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(ms_query),
                            packed.data());
            cl::Buffer tbuf(device_.context(), CL_MEM_WRITE_ONLY, items * sizeof(ms_tally));
            kernel.setArg(0, qbuf);
            kernel.setArg(1, cl_uint(count));
            kernel.setArg(2, u1_);
            kernel.setArg(3, u2_);
            kernel.setArg(4, cl_uint(n));
            kernel.setArg(5, cl_uint(R));
            kernel.setArg(6, cl_uint(chunks));
            kernel.setArg(7, tbuf);
            device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global), cl::NDRange(local));
            device_.queue().enqueueReadBuffer(tbuf, CL_TRUE, 0, items * sizeof(ms_tally), tallies.data());
            return 0;
        });
        for (std::size_t q = 0; q < count; ++q)
            for (std::uint32_t r = 0; r < R; ++r) {
                double cone = 0, hemi = 0;
                for (std::uint32_t c = 0; c < chunks; ++c) {
                    const ms_tally& t = tallies[(q * R + r) * chunks + c];
                    cone += t.cone;
                    hemi += t.hemisphere;
                }
                out.cone[(out_offset + q) * R + r] = out.cone_count[(out_offset + q) * R + r] = cone;
                out.hemisphere[(out_offset + q) * R + r] = out.hemisphere_count[(out_offset + q) * R + r] = hemi;
            }
    }

    ocl::Device& device_;
    RoutineConfig config_;
    const PointSet* uploaded_ = nullptr;
    std::uint64_t seed_ = 0, total_ = 0;
    std::uint32_t replicates_ = 0;
    Sequence sequence_ = Sequence::sobol;
    cl::Buffer u1_, u2_;
};

class OracleTallier final : public Tallier {
public:
    void tally(const Query* queries, const TermOptions* options, std::size_t count, const PointSet& points, Tallies& out,
               std::size_t out_offset) override {
        const std::size_t R = points.replicates;
        for (std::size_t q = 0; q < count; ++q) {
            throw_if_cancelled();
            const oracle::Tally one = oracle::tally(queries[q], options[q], points);
            for (std::size_t r = 0; r < R; ++r) {
                out.cone[(out_offset + q) * R + r] = one.cone[r];
                out.hemisphere[(out_offset + q) * R + r] = one.hemisphere[r];
                out.cone_count[(out_offset + q) * R + r] = one.cone_count[r];
                out.hemisphere_count[(out_offset + q) * R + r] = one.hemisphere_count[r];
            }
        }
    }
};

class TermWorker final : public schedule::Worker {
public:
    TermWorker(TermIntegrand& integrand, std::unique_ptr<Tallier> tallier, TermIntegrand::Source& source,
               TermIntegrand::Sink& sink)
        : integrand_(integrand), tallier_(std::move(tallier)), source_(source), sink_(sink) {}
    void run(std::uint64_t id) override { sink_(id, integrand_.evaluate(*tallier_, source_(id))); }

private:
    TermIntegrand& integrand_;
    std::unique_ptr<Tallier> tallier_;
    TermIntegrand::Source& source_;
    TermIntegrand::Sink& sink_;
};

}  // namespace

std::unique_ptr<Tallier> make_device_tallier(ocl::Device& device, const RoutineConfig& config) {
    return std::make_unique<DeviceTallier>(device, config);
}
std::unique_ptr<Tallier> make_oracle_tallier() { return std::make_unique<OracleTallier>(); }

TermIntegrand::TermIntegrand(std::uint64_t items, Source source, Sink sink, const SamplingPlan& plan, RoutineConfig config)
    : items_(items), source_(std::move(source)), sink_(std::move(sink)), plan_(plan), config_(std::move(config)) {}

const PointSet& TermIntegrand::points() {
    std::lock_guard<std::mutex> lock(points_mutex_);
    if (!points_) points_ = shared_point_set(plan_);
    return *points_;
}

std::unique_ptr<schedule::Worker> TermIntegrand::device_worker(ocl::Device& device) {
    return std::make_unique<TermWorker>(*this, make_device_tallier(device, config_), source_, sink_);
}

std::unique_ptr<schedule::Worker> TermIntegrand::oracle_worker() {
    return std::make_unique<TermWorker>(*this, make_oracle_tallier(), source_, sink_);
}

std::vector<Estimate> TermIntegrand::evaluate(Tallier& tallier, const Batch& batch) {
    if (batch.options.size() != batch.queries.size()) throw std::invalid_argument("term batch: one option set per query");
    std::vector<Estimate> results(batch.queries.size());
    std::vector<Query> to_sample;
    std::vector<TermOptions> sample_options;
    std::vector<std::size_t> where;
    for (std::size_t i = 0; i < batch.queries.size(); ++i) {
        validate_query(batch.queries[i]);
        const Query q = normalised(batch.queries[i]);
        const double cos_theta = cone_cos_theta(q.visibility, batch.options[i].ao_weighting);
        if (in_zero_region(cos_theta, q.wo.z)) {
            ++stats_.exact_zero;  // results[i] stays {0, 0}
        } else if (q.visibility == 1.0) {
            results[i] = {1.0, 0.0};  // the cone is the hemisphere: numerator == denominator
            ++stats_.exact_one;
        } else {
            to_sample.push_back(q);
            sample_options.push_back(batch.options[i]);
            where.push_back(i);
        }
    }
    if (to_sample.empty()) return results;
    const PointSet& pts = points();
    const std::size_t R = pts.replicates;
    Tallies t;
    t.resize(to_sample.size() * R);
    tallier.tally(to_sample.data(), sample_options.data(), to_sample.size(), pts, t, 0);
    // Few rare samples, agreeing replicates, or no sample in the denominator: the bar from the pooled
    // counts (the derivation is above reduce_count_replicates, core/estimate.hpp).
    for (std::size_t k = 0; k < to_sample.size(); ++k) {
        Estimate e = reduce_count_replicates(
            {&t.cone[k * R], &t.hemisphere[k * R], &t.cone_count[k * R], &t.hemisphere_count[k * R]}, R);
        results[where[k]] = e;
    }
    stats_.sampled += to_sample.size();
    return results;
}

std::uint64_t queries_per_item(const schedule::Scheduler& scheduler, const SamplingPlan& plan, const RoutineConfig& config) {
    // Samples per item: 2^28 is ~0.13 s of the kernel on 2 CPU cores (2e9 samples/s, far less on a GPU);
    // 2^21 is ~0.3 s of one oracle thread (7.5e6 samples/s). Cancellation waits for the items in flight.
    const std::uint64_t budget = std::uint64_t(1) << (scheduler.is_oracle() ? 21 : 28);
    const std::uint64_t per_item = std::max<std::uint64_t>(1, budget / std::max<std::uint64_t>(1, plan.samples));
    return std::min<std::uint64_t>(per_item, config.max_batch_queries);
}

namespace {
// Items of a raw tally: fixed slices of the query list, tallied straight into one Tallies.
class RawTally final : public schedule::Integrand {
public:
    RawTally(const std::vector<Query>& queries, const TermOptions& options, const PointSet& points,
             const RoutineConfig& config, std::size_t per_item)
        : queries_(queries), options_(queries.size(), options), points_(points), config_(config), per_item_(per_item) {
        out_.resize(queries.size() * points.replicates);
    }
    std::string name() const override { return "term tallies"; }
    std::uint64_t work_items() const override { return (queries_.size() + per_item_ - 1) / per_item_; }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override {
        return std::make_unique<Slicer>(*this, make_device_tallier(device, config_));
    }
    std::unique_ptr<schedule::Worker> oracle_worker() override { return std::make_unique<Slicer>(*this, make_oracle_tallier()); }
    Tallies take() { return std::move(out_); }

private:
    class Slicer final : public schedule::Worker {
    public:
        Slicer(RawTally& owner, std::unique_ptr<Tallier> tallier) : owner_(owner), tallier_(std::move(tallier)) {}
        void run(std::uint64_t id) override {
            const std::size_t first = id * owner_.per_item_;
            const std::size_t count = std::min(owner_.per_item_, owner_.queries_.size() - first);
            tallier_->tally(owner_.queries_.data() + first, owner_.options_.data() + first, count, owner_.points_, owner_.out_,
                            first);
        }

    private:
        RawTally& owner_;
        std::unique_ptr<Tallier> tallier_;
    };
    const std::vector<Query>& queries_;
    std::vector<TermOptions> options_;
    const PointSet& points_;
    RoutineConfig config_;
    std::size_t per_item_;
    Tallies out_;
};
}  // namespace

Tallies tally(schedule::Scheduler& scheduler, const std::vector<Query>& queries, const TermOptions& options,
              const PointSet& points, const RoutineConfig& config) {
    if (queries.empty()) return {};
    SamplingPlan plan;
    plan.samples = points.total();
    const std::size_t per_item = std::size_t(queries_per_item(scheduler, plan, config));
    RawTally raw(queries, options, points, config, per_item);
    scheduler.run(raw);
    return raw.take();
}

}  // namespace ms::term
