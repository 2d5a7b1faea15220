// Throughput in one run: VNDF samples per second of the OpenCL kernel (enqueued directly, and through
// ms::evaluate with its host work), of a naive kernel (bench/naive_term.cl), of the scalar double
// oracle on one thread, and of the vectorised C++ OpenMP baseline (bench/baseline/), on the reference
// queries and the same point buffer. The baseline's counts are checked against the kernel's.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "baseline/baseline_tally.hpp"
#include "bench.hpp"
#include "core/cone.hpp"
#include "jobs/eval.hpp"
#include "microshadow_shared.h"
#include "device/runtime.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"

namespace ms::bench {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Median of `reps` timings of f() (after one untimed warm-up run that also triggers PoCL's lazy
// work-group compilation), so one slow run on a shared machine does not decide the figure.
template <class F>
double median_seconds(int reps, F&& f) {
    f();
    std::vector<double> t;
    for (int i = 0; i < reps; ++i) {
        const auto start = Clock::now();
        f();
        t.push_back(since(start));
    }
    std::sort(t.begin(), t.end());
    return t[t.size() / 2];
}

std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + path);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// bench/naive_term.cl with the shared layout header inlined, as cmake/EmbedKernels.cmake does for kernels/.
std::string naive_source() {
    std::string text = read_text(std::string(MICROSHADOW_BENCH_DIR) + "/naive_term.cl");
    const std::string include = "#include \"microshadow_shared.h\"";
    const auto pos = text.find(include);
    if (pos == std::string::npos) throw std::runtime_error("naive_term.cl does not include microshadow_shared.h");
    text.replace(pos, include.size(), read_text(std::string(MICROSHADOW_BENCH_DIR) + "/../kernels/common/microshadow_shared.h"));
    return text;
}

std::vector<ms_query> pack(const std::vector<Query>& queries) {
    std::vector<ms_query> out;
    for (const Query& q : queries) {
        ms_query p{};
        p.cos_theta = float(cone_cos_theta(q.visibility, AoWeighting::cosine));
        p.sin2_cone = float(cone_sin2_theta(q.visibility, AoWeighting::cosine));
        p.alpha_x = float(q.alpha_x), p.alpha_y = float(q.alpha_y);
        p.wi_x = float(q.wi.x), p.wi_y = float(q.wi.y), p.wi_z = float(q.wi.z);
        p.wo_x = float(q.wo.x), p.wo_y = float(q.wo.y), p.wo_z = float(q.wo.z);
        out.push_back(p);
    }
    return out;
}

}  // namespace

ThroughputResult run_throughput(const Options& opt, const std::vector<RefEntry>& reference) {
    std::ostream& log = *opt.log;
    std::vector<Query> queries;
    for (const auto& e : reference)
        if (e.kind == 0) {
            const Query q = normalised(e.query);
            if (!in_zero_region(cone_cos_theta(q.visibility, AoWeighting::cosine), q.wo.z) && q.visibility < 1)
                queries.push_back(q);
        }
    if (queries.empty()) throw std::runtime_error("the reference set has no sampled queries");
    const std::vector<ms_query> packed = pack(queries);

    SamplingPlan plan;
    plan.samples = opt.smoke ? (1u << 11) : (1u << 20);
    plan.replicates = 8;
    plan.seed = 11;
    const PointSet points = make_point_set(plan);
    const std::uint32_t R = points.replicates, n = points.points_per_replicate;
    const double total_samples = double(queries.size()) * double(points.total());
    const int reps = opt.smoke ? 1 : 5;

    ThroughputResult res;
    auto infos = ocl::select_devices(opt.device);
    ocl::Device device(infos.front());
    const ocl::BuildConfig build;

    // --- the kernel, enqueued directly: device time plus the launch, no host-side preparation -------
    std::vector<ms_tally> kernel_tallies(queries.size() * R);
    {
        const std::size_t target = std::size_t(device.info().compute_units) * (device.info().type == "GPU" ? 2048 : 8);
        std::uint32_t chunks = 1;  // the same chunking rule as the OpenCL backend (host/engine/evaluator.cpp)
        while (queries.size() * R * chunks < target && n / (chunks * 2) >= 256) chunks *= 2;
        const std::size_t items = queries.size() * R * chunks;
        std::vector<ms_tally> raw(items);
        ocl::checked([&] {
            cl::Kernel kernel = device.kernel("term/generic_term.cl", "ms_tally_queries", build);
            cl::Buffer qbuf(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(ms_query),
                            const_cast<ms_query*>(packed.data()));
            cl::Buffer u1(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, points.u1.size() * sizeof(float),
                          const_cast<float*>(points.u1.data()));
            cl::Buffer u2(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, points.u2.size() * sizeof(float),
                          const_cast<float*>(points.u2.data()));
            cl::Buffer tbuf(device.context(), CL_MEM_WRITE_ONLY, items * sizeof(ms_tally));
            kernel.setArg(0, qbuf), kernel.setArg(1, cl_uint(queries.size())), kernel.setArg(2, u1);
            kernel.setArg(3, u2), kernel.setArg(4, cl_uint(n)), kernel.setArg(5, cl_uint(R));
            kernel.setArg(6, cl_uint(chunks)), kernel.setArg(7, tbuf);
            const double s = median_seconds(reps, [&] {
                device.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(items), cl::NullRange);
                device.queue().finish();
            });
            res.kernel_direct = total_samples / s;
            device.queue().enqueueReadBuffer(tbuf, CL_TRUE, 0, items * sizeof(ms_tally), raw.data());

            // --- the naive kernel on the same buffers -----------------------------------------------
            cl::Program naive(device.context(), naive_source());
            try {
                naive.build({device.info().device}, ocl::build_options(build).c_str());
            } catch (const cl::Error&) {
                throw ocl::BuildError(device.info().label(), ocl::build_options(build),
                                      naive.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device.info().device));
            }
            cl::Kernel nk(naive, "ms_naive_tally");
            cl::Buffer sbuf(device.context(), CL_MEM_WRITE_ONLY, items * sizeof(cl_float2));
            nk.setArg(0, qbuf), nk.setArg(1, cl_uint(queries.size())), nk.setArg(2, u1), nk.setArg(3, u2);
            nk.setArg(4, cl_uint(n)), nk.setArg(5, cl_uint(R)), nk.setArg(6, cl_uint(chunks)), nk.setArg(7, sbuf);
            const double sn = median_seconds(opt.smoke ? 1 : 3, [&] {
                device.queue().enqueueNDRangeKernel(nk, cl::NullRange, cl::NDRange(items), cl::NullRange);
                device.queue().finish();
            });
            res.naive_kernel = total_samples / sn;
            return 0;
        });
        for (std::size_t g = 0; g < items; ++g) {
            kernel_tallies[g / chunks].cone += raw[g].cone;
            kernel_tallies[g / chunks].hemisphere += raw[g].hemisphere;
        }
    }

    // --- the kernel through ms::evaluate: point generation, packing, batching, reduction included ----
    {
        OpenClBackendConfig cfg;
        cfg.build = build;
        auto backend = make_opencl_backend({infos.front()}, cfg);
        const double s = median_seconds(opt.smoke ? 1 : 3, [&] { evaluate(*backend, queries, TermOptions{}, plan); });
        res.kernel_evaluate = total_samples / s;
    }

    // --- the C++ OpenMP baseline on the same buffers --------------------------------------------------
    std::vector<ms_tally> base_tallies;
    {
        const double s = median_seconds(reps, [&] {
            baseline_tally(packed, points.u1.data(), points.u2.data(), n, R, base_tallies);
        });
        res.baseline_omp = total_samples / s;
    }

    // --- the scalar double oracle on one thread, on fewer points (it is ~100x slower) -----------------
    {
        SamplingPlan small = plan;
        small.samples = opt.smoke ? (1u << 7) : (1u << 15);
        const PointSet few = make_point_set(small);
        const std::size_t m = opt.smoke ? std::min<std::size_t>(4, queries.size()) : queries.size();
        const double s = median_seconds(1, [&] {
            for (std::size_t q = 0; q < m; ++q) oracle::tally(queries[q], TermOptions{}, few);
        });
        res.oracle_1t = double(m) * double(few.total()) / s;
    }

    // --- agreement of baseline and kernel: equal, or different only by samples on a threshold ---------
    res.tallies_agree = true;
    for (std::size_t g = 0; g < kernel_tallies.size(); ++g) {
        const auto diff = [](std::uint32_t a, std::uint32_t b) { return std::uint64_t(a > b ? a - b : b - a); };
        const std::uint64_t d = std::max(diff(kernel_tallies[g].cone, base_tallies[g].cone),
                                         diff(kernel_tallies[g].hemisphere, base_tallies[g].hemisphere));
        res.max_count_difference = std::max(res.max_count_difference, d);
        if (d == 0) continue;
        const std::size_t q = g / R, r = g % R;
        // 1e-5 relative is ~80 float ulps: the spread between two orders of evaluation of this short
        // chain (fma contraction, rsqrt vs 1/sqrt), far below any change of the sampled direction.
        const std::uint64_t border =
            borderline_samples(packed[q], points.u1.data() + r * n, points.u2.data() + r * n, n, 1e-5f);
        res.max_borderline = std::max(res.max_borderline, border);
        if (d > border) {
            res.tallies_agree = false;
            log << "throughput: query " << q << " replicate " << r << ": kernel and baseline differ by " << d
                << " counts, more than the " << border << " samples within float rounding of a threshold\n";
        }
    }

    res.table.name = "throughput (VNDF samples/s, " + std::to_string(queries.size()) + " reference queries, " +
                     std::to_string(plan.samples) + " samples each; " + infos.front().label() + ")";
    res.table.columns = {"method", "samples_per_s", "vs_kernel", "vs_oracle_1t"};
    const std::vector<std::pair<std::string, double>> rows = {
        {"opencl kernel (direct enqueue)", res.kernel_direct},
        {"opencl kernel via ms::evaluate", res.kernel_evaluate},
        {"naive opencl kernel (bench/naive_term.cl)", res.naive_kernel},
        {"C++ baseline -O3 -march=native, OpenMP " + std::to_string(baseline_threads()) + " threads", res.baseline_omp},
        {"scalar double oracle, 1 thread", res.oracle_1t}};
    for (const auto& [name, v] : rows)
        res.table.rows.push_back({name, fmt(v, 4), fmt(v / res.kernel_direct, 3), fmt(v / res.oracle_1t, 3)});
    log << "throughput: baseline vs kernel counts: max difference " << res.max_count_difference
        << ", max samples within float rounding of a threshold " << res.max_borderline << " -> "
        << (res.tallies_agree ? "agree" : "DISAGREE") << "\n";
    return res;
}

}  // namespace ms::bench
