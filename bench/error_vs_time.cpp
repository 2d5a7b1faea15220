// Run time against error for the eval-based methods: plain random points and scrambled nets (ms::evaluate
// on the OpenCL backend) over a ladder of sample budgets, scored against the reference queries. The
// bake's methods (shared samples, adaptive stopping) are added by run_bake() on the reference texels.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ostream>

#include "bench.hpp"
#include "jobs/eval.hpp"
#include "device/runtime.hpp"

namespace ms::bench {

std::vector<ErrorPoint> run_error_vs_time(const Options& opt, const std::vector<RefEntry>& reference) {
    std::vector<Query> queries;
    std::vector<double> truth;
    for (const auto& e : reference)
        if (e.kind == 0) queries.push_back(e.query), truth.push_back(e.value);
    auto backend = make_opencl_backend({ocl::select_devices(opt.device).front()});
    // Build the kernel before timing anything (build time is reported on its own).
    SamplingPlan warm;
    warm.samples = 128;
    evaluate(*backend, queries, TermOptions{}, warm);

    const int first = 10, last = opt.smoke ? 12 : 22;
    std::vector<ErrorPoint> out;
    for (Sequence seq : {Sequence::random, Sequence::sobol}) {
        for (int m = first; m <= last; m += 2) {
            SamplingPlan plan;
            plan.sequence = seq;
            plan.samples = 1ull << m;
            plan.replicates = 8;
            plan.seed = 1000 + std::uint64_t(m);  // the reference used other seeds: independent errors
            // Best of 3 (same plan, so the point set is generated once and cached, as in a sweep's
            // chunks): single runs of a few ms swing by 3x on a shared machine.
            std::vector<Estimate> est;
            double seconds = 1e300;
            for (int rep = 0; rep < 3; ++rep) {
                const auto start = std::chrono::steady_clock::now();
                est = evaluate(*backend, queries, TermOptions{}, plan);
                seconds = std::min(seconds, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
            }
            ErrorPoint p;
            p.method = seq == Sequence::random ? "eval: plain random points" : "eval: scrambled nets";
            p.samples = plan.samples;
            p.seconds = seconds;
            p.values = queries.size();
            p.seconds_per_value = seconds / double(queries.size());
            double sq = 0;
            for (std::size_t i = 0; i < est.size(); ++i) {
                const double err = std::fabs(est[i].term - truth[i]);
                p.max_error = std::max(p.max_error, err);
                p.max_reported_error = std::max(p.max_reported_error, est[i].std_error);
                sq += err * err;
            }
            p.rms_error = std::sqrt(sq / double(est.size()));
            *opt.log << "error-vs-time: " << p.method << ", " << p.samples << " samples: " << fmt(seconds, 3)
                     << " s, max error " << fmt(p.max_error, 3) << ", rms " << fmt(p.rms_error, 3) << "\n"
                     << std::flush;
            out.push_back(p);
        }
    }
    return out;
}

}  // namespace ms::bench
