#include "integrands/exact_term/exact_term_integrand.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <thread>
#include <tuple>

#include "core/cancel.hpp"
#include "core/cone.hpp"
#include "core/query.hpp"
#include "exact/azimuth_grid.hpp"

namespace ms::exact_term {

namespace {

// Queries of one batch in the order the evaluator takes them: isotropic queries (alpha_x == alpha_y <= 1,
// the azimuth grid's domain) grouped by their row (weighting, visibility, alpha, NdotL), each row's
// values computed through one AzimuthGrid; the others (anisotropic, alpha above 1) one by one by
// exact_term. An isotropic surface is invariant under rotation about e_z, so an isotropic query is
// determined by its row, NdotV = wi.z and the relative azimuth of wo from wi.
//
// A query alone in its row costs about what exact_term costs (bench/exact_rows.cpp: medians 0.88-1.18x
// over 16,384-query sets of the design region and the whole domain, in the LUT's frame and at random
// orientations, at 1e-10 and 1e-6; the grid's closed-form hemisphere pays for building the row), and
// each further value of a row saves the row's precomputation (0.6-0.8 us; rows of 9 cost 0.57-0.59x).
// So every isotropic query goes through a grid: one path per query keeps each value independent of the
// rest of its batch (a threshold on the row's size would not).
struct RowPlan {
    std::vector<std::size_t> order;  // query indices, rows contiguous
    struct Row {
        std::size_t first, last;  // [first, last) of order
        bool grid;                // isotropic, one row: through an AzimuthGrid of its parameters
    };
    std::vector<Row> rows;
};

RowPlan plan_rows(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting) {
    // Isotropic first, by row key, ties by position (a total order: the plan does not depend on the
    // sort's implementation). A row's queries have exactly its parameters, so a value depends on its
    // query alone, never on which others share its batch (a job's results do not depend on how its
    // queries are cut into work items). Normalising a query can move wo.z by an ulp with wo's azimuth,
    // splitting a job's row in two or three: measured on repr bake's full-range preset, 96,107 rows
    // against 50,373 with 4 ulps of slack, ~0.03 s of row precomputation in a ~1 s bake.
    struct Key {
        bool off_grid;
        int weighting;
        double visibility, alpha, n_dot_l;
        std::size_t index;
        auto tied() const { return std::tie(off_grid, weighting, visibility, alpha, n_dot_l); }
    };
    std::vector<Key> keys(queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
        const Query& q = queries[i];
        keys[i] = {!on_grid(q), int(weighting[i]), q.visibility, q.alpha_x, q.wo.z, i};
    }
    std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
        return a.tied() < b.tied() || (a.tied() == b.tied() && a.index < b.index);
    });
    RowPlan plan;
    plan.order.resize(keys.size());
    for (std::size_t k = 0; k < keys.size(); ++k) plan.order[k] = keys[k].index;
    // Rows of equal keys; the queries off the grid (sorted last) as one "row" of independent values.
    for (std::size_t k = 0; k < keys.size();) {
        std::size_t end = k + 1;
        while (end < keys.size() && (keys[k].off_grid ? keys[end].off_grid : keys[end].tied() == keys[k].tied())) ++end;
        plan.rows.push_back({k, end, !keys[k].off_grid});
        k = end;
    }
    return plan;
}

// The runs of a plan: [first, last) of its order, all of the row that order[head] heads when `grid`.
struct Run {
    std::size_t head, first, last;
    bool grid;
};

// The values of one run.
void evaluate_run(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting, double tolerance,
                  const RowPlan& plan, const Run& run, std::vector<exact::ExactValue>& out) {
    const std::size_t first = run.first, last = run.last;
    if (run.grid) {
        // The row's grid, made from the row's head whichever run this is (so a value does not depend on
        // where its run starts).
        const Query& head = queries[plan.order[run.head]];
        const exact::AzimuthGrid row(head.visibility, head.alpha_x, head.wo.z, weighting[plan.order[run.head]]);
        for (std::size_t k = first; k < last; ++k) {
            const Query& q = queries[plan.order[k]];
            out[plan.order[k]] = row.term(q.wi.z, relative_azimuth(q), tolerance);
        }
        return;
    }
    for (std::size_t k = first; k < last; ++k)
        out[plan.order[k]] = exact::exact_term(queries[plan.order[k]], weighting[plan.order[k]], tolerance);
}

// A row's values in runs of at most this many, so that one long row still spreads over threads and
// cancellation is checked often (~30 us a run; each run repeats the row's precomputation, ~0.7 us).
constexpr std::size_t kRunLength = 32;

std::vector<Run> runs_of(const RowPlan& plan) {
    std::vector<Run> runs;
    for (const RowPlan::Row& row : plan.rows)
        for (std::size_t k = row.first; k < row.last; k += kRunLength)
            runs.push_back({row.first, k, std::min(row.last, k + kRunLength), row.grid});
    return runs;
}

class CpuEvaluator final : public Evaluator {
public:
    void terms(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting, double tolerance,
               std::vector<exact::ExactValue>& out) override {
        out.resize(queries.size());
        const RowPlan plan = plan_rows(queries, weighting);
        for (const Run& run : runs_of(plan)) {
            if (cancel_requested()) throw Cancelled();
            evaluate_run(queries, weighting, tolerance, plan, run, out);
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
        // The whole batch's rows first (a contiguous split would cut them), then their runs handed to the
        // threads as they become free; each run writes its own queries' values.
        const RowPlan plan = plan_rows(queries, weighting);
        const std::vector<Run> runs = runs_of(plan);
        split_dynamic(runs.size(), 1, [&](std::size_t lo, std::size_t hi) {
            for (std::size_t k = lo; k < hi; ++k) {
                if (cancel_requested()) throw Cancelled();
                evaluate_run(queries, weighting, tolerance, plan, runs[k], out);
            }
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

bool on_grid(const Query& q) { return q.alpha_x == q.alpha_y && q.alpha_x <= 1; }

double relative_azimuth(const Query& q) {
    // atan2 of wi x wo's z and the horizontal dot product: no difference of two angles to wrap round.
    return std::atan2(q.wi.x * q.wo.y - q.wi.y * q.wo.x, q.wi.x * q.wo.x + q.wi.y * q.wo.y);
}

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
