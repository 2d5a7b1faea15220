#include "integrands/exact_term/exact_term_integrand.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <thread>

#include "core/cancel.hpp"
#include "core/cone.hpp"
#include "core/query.hpp"
#include "exact/azimuth_grid.hpp"

namespace ms::exact_term {

namespace {

class CpuEvaluator final : public Evaluator {
public:
    void terms(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting, double tolerance,
               std::vector<exact::ExactValue>& out) override {
        out.resize(queries.size());
        for (std::size_t i = 0; i < queries.size(); ++i) {
            // ~10 us a value: checking every 256 keeps cancellation well under a millisecond.
            if ((i & 255) == 0 && cancel_requested()) throw Cancelled();
            out[i] = exact::exact_term(queries[i], weighting[i], tolerance);
        }
    }
    void texels(const std::vector<ExactTexel>& texels, AoWeighting weighting, bool azimuth_mean, double azimuth,
                double tolerance, std::vector<exact::ExactValue>& out) override {
        out.resize(texels.size());
        // Texels of one (visibility, alpha, NdotL) row share the azimuth grid's precomputation (its
        // circle's quartic), which every value of the row reuses.
        std::unique_ptr<exact::AzimuthGrid> grid;
        for (std::size_t i = 0; i < texels.size(); ++i) {
            if ((i & 15) == 0 && cancel_requested()) throw Cancelled();
            const ExactTexel& t = texels[i];
            if (!grid || !grid->same_row(t.visibility, t.alpha, t.n_dot_l, weighting))
                grid = std::make_unique<exact::AzimuthGrid>(t.visibility, t.alpha, t.n_dot_l, weighting);
            out[i] = azimuth_mean ? grid->mean(t.n_dot_v, tolerance) : grid->term(t.n_dot_v, azimuth, tolerance);
        }
    }
};

// CpuEvaluator over `threads` threads: each call is cut into contiguous parts, the first on the calling
// thread; a part's exception (Cancelled included) is rethrown after every part has stopped.
class ThreadedCpuEvaluator final : public Evaluator {
public:
    explicit ThreadedCpuEvaluator(unsigned threads) : threads_(std::max(1u, threads)) {}
    void terms(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting, double tolerance,
               std::vector<exact::ExactValue>& out) override {
        out.resize(queries.size());
        split(queries.size(), [&](std::size_t lo, std::size_t hi) {
            std::vector<Query> q(queries.begin() + lo, queries.begin() + hi);
            std::vector<AoWeighting> w(weighting.begin() + lo, weighting.begin() + hi);
            std::vector<exact::ExactValue> part;
            CpuEvaluator().terms(q, w, tolerance, part);
            std::copy(part.begin(), part.end(), out.begin() + lo);
        });
    }
    void texels(const std::vector<ExactTexel>& texels, AoWeighting weighting, bool azimuth_mean, double azimuth,
                double tolerance, std::vector<exact::ExactValue>& out) override {
        out.resize(texels.size());
        // Texels differ in cost by orders of magnitude (exact zeros against grazing smooth rows), so equal
        // contiguous parts leave threads idle: the threads take small runs of texels in turn instead.
        split_dynamic(texels.size(), 4, [&](std::size_t lo, std::size_t hi) {
            std::vector<ExactTexel> t(texels.begin() + lo, texels.begin() + hi);
            std::vector<exact::ExactValue> part;
            CpuEvaluator().texels(t, weighting, azimuth_mean, azimuth, tolerance, part);
            std::copy(part.begin(), part.end(), out.begin() + lo);
        });
    }

private:
    // part(lo, hi) over runs of `run` items, handed to the threads as they become free (the values do not
    // depend on which thread computes a run).
    template <class Part>
    void split_dynamic(std::size_t n, std::size_t run, const Part& part) {
        std::atomic<std::size_t> next{0};
        const std::size_t runs = (n + run - 1) / run;
        split(std::min<std::size_t>(runs, threads_), [&](std::size_t, std::size_t) {
            for (std::size_t k; (k = next.fetch_add(1)) < runs;) part(k * run, std::min(n, (k + 1) * run));
        });
    }

    template <class Part>
    void split(std::size_t n, const Part& part) {
        const std::size_t parts = std::min<std::size_t>(threads_, n);
        if (parts <= 1) {
            if (n) part(0, n);
            return;
        }
        std::vector<std::exception_ptr> failures(parts);
        auto run = [&](std::size_t k) {
            try {
                part(n * k / parts, n * (k + 1) / parts);
            } catch (...) {
                failures[k] = std::current_exception();
            }
        };
        std::vector<std::thread> helpers;
        for (std::size_t k = 1; k < parts; ++k) helpers.emplace_back(run, k);
        run(0);
        for (auto& t : helpers) t.join();
        for (const auto& f : failures)
            if (f) std::rethrow_exception(f);
    }
    unsigned threads_;
};

class TermWorker final : public schedule::Worker {
public:
    TermWorker(ExactTermIntegrand& integrand, std::unique_ptr<Evaluator> evaluator, ExactTermIntegrand::Source& source,
               ExactTermIntegrand::Sink& sink)
        : integrand_(integrand), evaluator_(std::move(evaluator)), source_(source), sink_(sink) {}
    void run(std::uint64_t id) override { sink_(id, integrand_.evaluate(*evaluator_, source_(id))); }

private:
    ExactTermIntegrand& integrand_;
    std::unique_ptr<Evaluator> evaluator_;
    ExactTermIntegrand::Source& source_;
    ExactTermIntegrand::Sink& sink_;
};

}  // namespace

std::unique_ptr<Evaluator> make_cpu_evaluator(unsigned threads) {
    if (threads <= 1) return std::make_unique<CpuEvaluator>();
    return std::make_unique<ThreadedCpuEvaluator>(threads);
}

bool runs_host_code(const ocl::DeviceInfo& device, const ExactConfig& config) {
    return device.type == "CPU" && !config.kernel_on_cpu_devices && !config.force_float;
}

std::string describe_engines(const ExactConfig& config) {
    const std::string kernel = config.force_float ? "the float kernel" : "the kernel in double where the device has fp64, else float";
    if (config.kernel_on_cpu_devices || config.force_float) return kernel + " on every device";
    return "the C++ evaluator (double) on a CPU device's compute units; " + kernel + " on other devices";
}

std::unique_ptr<Evaluator> make_place_evaluator(ocl::Device& device, const ExactConfig& config) {
    const ocl::DeviceInfo& info = device.info();
    if (runs_host_code(info, config)) return make_cpu_evaluator(std::max(1u, info.compute_units));
    return make_device_evaluator(device, device_build(info, config));
}

void validate_tolerance(double tolerance) {
    if (!(tolerance >= kMinTolerance && tolerance <= 0.1))
        throw std::invalid_argument("the exact method's tolerance must be in [1e-13, 0.1] (below 1e-13 rounding "
                                    "dominates every estimate)");
}

ocl::BuildConfig device_build(const ocl::DeviceInfo& device, const ExactConfig& config) {
    ocl::BuildConfig build = config.build;
    build.double_precision = device.fp64 && !config.force_float;
    return build;
}

ExactTermIntegrand::ExactTermIntegrand(std::uint64_t items, Source source, Sink sink, ExactConfig config)
    : items_(items), source_(std::move(source)), sink_(std::move(sink)), config_(std::move(config)) {
    validate_tolerance(config_.tolerance);
}

std::unique_ptr<schedule::Worker> ExactTermIntegrand::device_worker(ocl::Device& device) {
    return std::make_unique<TermWorker>(*this, make_place_evaluator(device, config_), source_, sink_);
}

std::unique_ptr<schedule::Worker> ExactTermIntegrand::oracle_worker() {
    return std::make_unique<TermWorker>(*this, make_cpu_evaluator(), source_, sink_);
}

std::vector<Estimate> ExactTermIntegrand::evaluate(Evaluator& evaluator, const term::Batch& batch) {
    if (batch.options.size() != batch.queries.size()) throw std::invalid_argument("term batch: one option set per query");
    std::vector<Query> queries;
    std::vector<AoWeighting> weighting;
    queries.reserve(batch.queries.size());
    weighting.reserve(batch.queries.size());
    std::uint64_t zero = 0, one = 0;
    for (std::size_t i = 0; i < batch.queries.size(); ++i) {
        validate_exact_query(batch.queries[i]);
        const Query q = normalised(batch.queries[i]);
        const AoWeighting w = batch.options[i].ao_weighting;
        if (in_zero_region(cone_cos_theta(q.visibility, w), q.wo.z)) ++zero;
        else if (q.visibility == 1.0) ++one;
        queries.push_back(q);
        weighting.push_back(w);
    }
    std::vector<exact::ExactValue> values;
    evaluator.terms(queries, weighting, config_.tolerance, values);
    std::vector<Estimate> results(values.size());
    std::uint64_t pieces = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
        results[i] = {values[i].term, values[i].error};
        pieces += std::uint64_t(values[i].quadrature_pieces);
    }
    stats_.evaluated += values.size() - zero - one;
    stats_.exact_zero += zero;
    stats_.exact_one += one;
    stats_.quadrature_pieces += pieces;
    return results;
}

std::uint64_t queries_per_item(const schedule::Scheduler& scheduler) {
    // ~20 ms of one CPU thread (about 10 us a query at the default tolerance), so that a few thousand
    // queries already spread over every thread; a device batch is 4x that (its launch costs ~0.1 ms).
    return scheduler.is_oracle() ? 2048 : 8192;
}

}  // namespace ms::exact_term
