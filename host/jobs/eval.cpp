#include "jobs/eval.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "microshadow_shared.h"
#include "oracle/oracle.hpp"

namespace ms {

static_assert(sizeof(ms_query) == 48, "ms_query layout must match the OpenCL C struct");
static_assert(sizeof(ms_tally) == 8, "ms_tally layout must match the OpenCL C struct");

namespace {

// hypot: no intermediate underflow or overflow, so (1e-200, 0, 1e-200) is a valid direction, not zero.
double length(const Vec3& v) { return std::hypot(v.x, v.y, v.z); }
bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Runs job(i) for i in [0, count) on `workers` threads pulling indices from a shared counter;
// rethrows the first exception after all threads stop.
void parallel_for(std::size_t count, unsigned workers, const std::function<void(std::size_t, unsigned)>& job) {
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    std::vector<std::thread> threads;
    for (unsigned w = 0; w < workers; ++w) {
        threads.emplace_back([&, w] {
            for (std::size_t i; (i = next.fetch_add(1)) < count;) {
                try {
                    job(i, w);
                } catch (...) {
                    std::lock_guard<std::mutex> lock(failure_mutex);
                    if (!failure) failure = std::current_exception();
                    next = count;
                }
            }
        });
    }
    for (auto& t : threads) t.join();
    if (failure) std::rethrow_exception(failure);
}

class OracleBackend final : public TermBackend {
public:
    explicit OracleBackend(unsigned threads)
        : threads_(threads ? threads : std::max(1u, std::thread::hardware_concurrency())) {}
    std::string name() const override { return "oracle (scalar double, " + std::to_string(threads_) + " threads)"; }
    Tallies tally(const std::vector<Query>& queries, const TermOptions& options, const PointSet& points) override {
        const std::size_t R = points.replicates;
        Tallies t{std::vector<double>(queries.size() * R), std::vector<double>(queries.size() * R)};
        parallel_for(queries.size(), threads_, [&](std::size_t q, unsigned) {
            const oracle::Tally one = oracle::tally(queries[q], options, points);
            for (std::size_t r = 0; r < R; ++r) {
                t.cone[q * R + r] = one.cone[r];
                t.hemisphere[q * R + r] = one.hemisphere[r];
            }
        });
        return t;
    }

private:
    unsigned threads_;
};

class OpenClBackend final : public TermBackend {
public:
    OpenClBackend(const std::vector<ocl::DeviceInfo>& devices, OpenClBackendConfig config) : config_(std::move(config)) {
        if (devices.empty()) throw ocl::NoDeviceError("no OpenCL device selected");
        for (const auto& d : devices) devices_.push_back(std::make_unique<ocl::Device>(d));
    }
    std::string name() const override {
        std::string s = "opencl (";
        for (std::size_t i = 0; i < devices_.size(); ++i) s += (i ? "; " : "") + devices_[i]->info().label();
        return s + ")";
    }

    Tallies tally(const std::vector<Query>& queries, const TermOptions& options, const PointSet& points) override {
        const std::size_t R = points.replicates;
        Tallies t{std::vector<double>(queries.size() * R), std::vector<double>(queries.size() * R)};
        const std::size_t batch = config_.max_batch_queries;
        const std::size_t batches = (queries.size() + batch - 1) / batch;
        // One host thread per device; each pulls the next batch, so faster devices take more.
        parallel_for(batches, unsigned(devices_.size()), [&](std::size_t b, unsigned worker) {
            const std::size_t first = b * batch;
            const std::size_t count = std::min(batch, queries.size() - first);
            run_batch(*devices_[worker], queries.data() + first, count, options, points, t, first);
        });
        return t;
    }

private:
    struct DevicePoints {
        const PointSet* identity = nullptr;
        std::uint64_t seed = 0, total = 0;
        std::uint32_t replicates = 0;
        Sequence sequence = Sequence::sobol;
        cl::Buffer u1, u2;
    };

    // Points are uploaded once per device and reused while the same point set is passed again.
    DevicePoints& points_on(ocl::Device& device, const PointSet& points) {
        std::lock_guard<std::mutex> lock(points_mutex_);
        DevicePoints& dp = device_points_[&device];
        // The address alone is not enough: a freed point set's address can be reused by another plan.
        if (dp.identity != &points || dp.seed != points.seed || dp.total != points.total() ||
            dp.replicates != points.replicates || dp.sequence != points.sequence) {
            ocl::checked([&] {
                dp.u1 = cl::Buffer(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, points.u1.size() * sizeof(float),
                                   const_cast<float*>(points.u1.data()));
                dp.u2 = cl::Buffer(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, points.u2.size() * sizeof(float),
                                   const_cast<float*>(points.u2.data()));
                return 0;
            });
            dp.identity = &points;
            dp.seed = points.seed;
            dp.total = points.total();
            dp.replicates = points.replicates;
            dp.sequence = points.sequence;
        }
        return dp;
    }

    void run_batch(ocl::Device& device, const Query* queries, std::size_t count, const TermOptions& options,
                   const PointSet& points, Tallies& out, std::size_t out_offset) {
        const std::uint32_t R = points.replicates;
        const std::uint32_t n = points.points_per_replicate;
        // Split replicates into chunks until the device has enough work-items to stay busy: a few per
        // CPU core, thousands per GPU compute unit. Chunks keep a multiple of MS_LANES points.
        const std::size_t target = std::size_t(device.info().compute_units) * (device.info().type == "GPU" ? 2048 : 8);
        std::uint32_t chunks = 1;
        while (count * R * chunks < target && n / (chunks * 2) >= 256) chunks *= 2;

        std::vector<ms_query> packed(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Query& q = queries[i];
            ms_query& p = packed[i];
            p = ms_query{};
            p.cos_theta = float(cone_cos_theta(q.visibility, options.ao_weighting));
            p.sin2_cone = float(cone_sin2_theta(q.visibility, options.ao_weighting));
            p.alpha_x = float(q.alpha_x);
            p.alpha_y = float(q.alpha_y);
            p.wi_x = float(q.wi.x), p.wi_y = float(q.wi.y), p.wi_z = float(q.wi.z);
            p.wo_x = float(q.wo.x), p.wo_y = float(q.wo.y), p.wo_z = float(q.wo.z);
        }
        DevicePoints& dp = points_on(device, points);
        const std::size_t items = count * R * chunks;
        std::vector<ms_tally> tallies(items);
        ocl::checked([&] {
            cl::Kernel kernel = device.kernel("term/generic_term.cl", "ms_tally_queries", config_.build);
            const std::size_t limit = kernel.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device.info().device);
            const std::size_t local = std::max<std::size_t>(1, std::min(config_.local_size, limit));
            const std::size_t global = (items + local - 1) / local * local;  // the kernel checks its range
            cl::Buffer qbuf(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(ms_query),
                            packed.data());
            cl::Buffer tbuf(device.context(), CL_MEM_WRITE_ONLY, items * sizeof(ms_tally));
            kernel.setArg(0, qbuf);
            kernel.setArg(1, cl_uint(count));
            kernel.setArg(2, dp.u1);
            kernel.setArg(3, dp.u2);
            kernel.setArg(4, cl_uint(n));
            kernel.setArg(5, cl_uint(R));
            kernel.setArg(6, cl_uint(chunks));
            kernel.setArg(7, tbuf);
            device.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global), cl::NDRange(local));
            device.queue().enqueueReadBuffer(tbuf, CL_TRUE, 0, items * sizeof(ms_tally), tallies.data());
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
                out.cone[(out_offset + q) * R + r] = cone;
                out.hemisphere[(out_offset + q) * R + r] = hemi;
            }
    }

    OpenClBackendConfig config_;
    std::vector<std::unique_ptr<ocl::Device>> devices_;
    std::mutex points_mutex_;
    std::map<ocl::Device*, DevicePoints> device_points_;
};

}  // namespace

std::unique_ptr<TermBackend> make_oracle_backend(unsigned threads) { return std::make_unique<OracleBackend>(threads); }

std::unique_ptr<TermBackend> make_opencl_backend(const std::vector<ocl::DeviceInfo>& devices,
                                                 const OpenClBackendConfig& config) {
    return std::make_unique<OpenClBackend>(devices, config);
}

void validate_query(const Query& q) {
    if (!std::isfinite(q.visibility) || q.visibility < 0 || q.visibility > 1)
        throw std::invalid_argument("visibility must be in [0, 1]");
    if (!std::isfinite(q.alpha_x) || !(q.alpha_x > 0)) throw std::invalid_argument("alpha_x must be a finite number > 0");
    if (!std::isfinite(q.alpha_y) || !(q.alpha_y > 0)) throw std::invalid_argument("alpha_y must be a finite number > 0");
    if (!finite(q.wi) || !(length(q.wi) > 0) || !std::isfinite(length(q.wi)))
        throw std::invalid_argument("wi must be a finite non-zero vector");
    if (!finite(q.wo) || !(length(q.wo) > 0) || !std::isfinite(length(q.wo)))
        throw std::invalid_argument("wo must be a finite non-zero vector");
    if (!(q.wi.z / length(q.wi) > 0)) throw std::invalid_argument("wi must be above the horizon (wi_z > 0)");
}

Query normalised(const Query& q) {
    Query out = q;
    const double li = length(q.wi), lo = length(q.wo);
    out.wi = {q.wi.x / li, q.wi.y / li, q.wi.z / li};
    out.wo = {q.wo.x / lo, q.wo.y / lo, q.wo.z / lo};
    return out;
}

std::vector<Estimate> evaluate(TermBackend& backend, const std::vector<Query>& queries, const TermOptions& options,
                               const SamplingPlan& plan, EvalStats* stats,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
    const auto start = std::chrono::steady_clock::now();
    EvalStats local;
    std::vector<Estimate> results(queries.size());
    std::vector<Query> to_sample;
    std::vector<std::size_t> where;
    for (std::size_t i = 0; i < queries.size(); ++i) {
        validate_query(queries[i]);
        const Query q = normalised(queries[i]);
        const double cos_theta = cone_cos_theta(q.visibility, options.ao_weighting);
        if (in_zero_region(cos_theta, q.wo.z)) {
            ++local.exact_zero;  // results[i] stays {0, 0}
        } else if (q.visibility == 1.0) {
            results[i] = {1.0, 0.0};  // the cone is the hemisphere: numerator == denominator
            ++local.exact_one;
        } else {
            to_sample.push_back(q);
            where.push_back(i);
        }
    }
    if (!to_sample.empty()) {
        const auto shared_points = shared_point_set(plan);
        const PointSet& points = *shared_points;
        const std::size_t R = points.replicates;
        // Progress in slices so a long evaluation reports as it goes.
        const std::size_t slice = std::min<std::size_t>(1 << 15, std::max<std::size_t>(256, to_sample.size() / 20 + 1));
        for (std::size_t first = 0; first < to_sample.size(); first += slice) {
            const std::size_t count = std::min(slice, to_sample.size() - first);
            std::vector<Query> part(to_sample.begin() + first, to_sample.begin() + first + count);
            const Tallies t = backend.tally(part, options, points);
            for (std::size_t k = 0; k < count; ++k)
                results[where[first + k]] = reduce_replicates(&t.cone[k * R], &t.hemisphere[k * R], R);
            if (progress) progress(first + count, to_sample.size());
        }
    }
    local.sampled = to_sample.size();
    local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stats) *stats = local;
    return results;
}

}  // namespace ms
