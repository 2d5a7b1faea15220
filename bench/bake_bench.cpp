// The bake benchmark: wall time of a seed-3d LUT bake (ms::bake_lut, host/bake/) against its max error
// at the reference texels, for the shared-sample path over a ladder of batch sizes and for adaptive
// stopping over a ladder of tolerances; and a naive per-texel bake on a subset of the same texels,
// extrapolated per texel, so the speed-up at equal error is a ratio of two timings of one run.
//
// The naive bake integrates each texel on its own: for every azimuth node of the bake's trapezoid rule
// an independent ms::evaluate() call with plain random points (its own seed), the texel being the
// weighted mean. Independent nodes give se^2 = sum_j w_j^2 se_j^2. Its sample count is the one that
// brings t * se to the target error at every texel of the subset (t: 99.9 % Student-t with R - 1 dof),
// found from a pilot run: se scales as N^(-1/2) for random points.
#include <algorithm>
#include <chrono>
#include <map>
#include <cmath>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include <sys/resource.h>

#include "jobs/bake.hpp"
#include "bench.hpp"
#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "device/runtime.hpp"

namespace ms::bench {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }


struct Scored {
    ms::BakeResult result;
    double max_error = 0, rms_error = 0;
};

Scored bake_and_score(const BakeSpec& spec, const std::vector<RefEntry>& texels) {
    Scored s;
    s.result = bake_lut(spec);
    double sq = 0;
    for (const auto& e : texels) {
        const double err = std::fabs(double(s.result.at(e.channel, e.lut_x, e.lut_y, e.lut_z)) - e.value);
        s.max_error = std::max(s.max_error, err);
        sq += err * err;
    }
    s.rms_error = std::sqrt(sq / double(texels.size()));
    return s;
}

struct NaiveTexel {
    double value = 0, std_error = 0, seconds = 0;
};

// One texel integrated on its own: independent random-point integrations at the bake's azimuth nodes.
NaiveTexel naive_texel(TermBackend& backend, const BakeSpec& spec, const RefEntry& e, std::uint64_t samples_per_node,
                       std::uint32_t replicates, std::uint64_t seed) {
    std::vector<double> degrees, weights;
    azimuth_nodes(spec, degrees, weights);
    NaiveTexel t;
    double var = 0;
    const auto start = Clock::now();
    for (std::size_t j = 0; j < degrees.size(); ++j) {
        SamplingPlan plan;
        plan.sequence = Sequence::random;
        plan.samples = samples_per_node;
        plan.replicates = replicates;
        plan.seed = seed * 1000 + j;
        const Query q = texel_query(spec, std::uint32_t(e.channel), std::uint32_t(e.lut_x), std::uint32_t(e.lut_y),
                                    std::uint32_t(e.lut_z), degrees[j]);
        const Estimate est = evaluate(backend, {q}, spec.term, plan).front();
        t.value += weights[j] * est.term;
        var += weights[j] * weights[j] * est.std_error * est.std_error;
    }
    t.seconds = since(start);
    t.std_error = std::sqrt(var);
    return t;
}

}  // namespace

BakeBenchResult run_bake(const Options& opt, const std::vector<RefEntry>& reference, std::vector<ErrorPoint>* error_points) {
    std::ostream& log = *opt.log;
    std::vector<RefEntry> texels;
    for (const auto& e : reference)
        if (e.kind == 1) texels.push_back(e);
    if (texels.empty()) throw std::runtime_error("the reference set has no LUT texels");
    const std::uint32_t size = std::uint32_t(texels.front().lut_size);
    for (const auto& e : texels)
        if (e.lut_size != int(size)) throw std::runtime_error("reference texels of different LUT sizes");

    // The target max error; the smoke run uses a looser one so its naive bake stays tiny.
    const double kTarget = opt.smoke ? 1e-2 : 1e-3;
    BakeBenchResult out;
    out.available = true;
    BakeSpec base = default_bake_spec(LutLayout::seed_3d, size);
    base.backend.device = opt.device;
    base.command_line = "microshadow_bench (bake benchmark)";
    {
        BakeSpec warm = default_bake_spec(LutLayout::seed_3d, 2);  // compiles the kernels before timing
        warm.backend.device = opt.device;
        warm.samples = 256;
        bake_lut(warm);
    }

    out.table.name = "seed-3d bake " + std::to_string(size) + "^3 x 4 against " + std::to_string(texels.size()) +
                     " reference texels";
    out.table.columns = {"run", "samples_per_batch", "tolerance", "seconds", "max_error", "rms_error",
                         "max_reported_std_error", "batches", "max_error<=1e-3"};
    double best = -1, best_error = 0;
    std::uint64_t sampled_texels = 0;
    auto record = [&](const std::string& run, const std::string& method, const BakeSpec& spec, const Scored& s) {
        const auto& r = s.result;
        sampled_texels = r.texels - r.skipped_zero - r.skipped_one;
        out.table.rows.push_back({run, std::to_string(r.samples_per_batch), fmt(spec.tolerance, 3), fmt(r.seconds, 4),
                                  fmt(s.max_error, 3), fmt(s.rms_error, 3), fmt(r.max_std_error, 3),
                                  std::to_string(r.batches), s.max_error <= kTarget ? "yes" : "no"});
        log << "bake: " << run << ": " << fmt(r.seconds, 3) << " s, max error " << fmt(s.max_error, 3) << "\n"
            << std::flush;
        if (s.max_error <= kTarget && (best < 0 || r.seconds < best)) best = r.seconds, best_error = s.max_error;
        if (error_points && !method.empty()) {
            ErrorPoint p;
            p.method = method;
            p.samples = r.max_samples_per_slice;
            p.seconds = r.seconds;
            p.values = sampled_texels;
            p.seconds_per_value = r.seconds / double(std::max<std::uint64_t>(1, sampled_texels));
            p.max_error = s.max_error;
            p.rms_error = s.rms_error;
            p.max_reported_error = r.max_std_error;
            error_points->push_back(p);
        }
    };

    // The default bake (what `microshadow bake --size N` runs).
    record("default settings", "", base, bake_and_score(base, texels));
    // The shared-sample path at fixed budgets, and adaptive stopping at a ladder of tolerances.
    const std::vector<std::uint64_t> budgets =
        opt.smoke ? std::vector<std::uint64_t>{1024} : std::vector<std::uint64_t>{4096, 16384, 65536, 262144};
    for (std::uint64_t b : budgets) {
        BakeSpec spec = base;
        spec.samples = b, spec.tolerance = 0;
        record("shared samples, one batch", "bake: shared samples", spec, bake_and_score(spec, texels));
    }
    const std::vector<double> tolerances = opt.smoke ? std::vector<double>{1e-2} : std::vector<double>{1e-3, 4e-4, 2e-4};
    for (double tol : tolerances) {
        BakeSpec spec = base;
        spec.samples = opt.smoke ? 1024 : 16384, spec.tolerance = tol;
        record("adaptive stopping", "bake: adaptive stopping", spec, bake_and_score(spec, texels));
    }
    out.bake_seconds = best;
    out.bake_max_error = best_error;

    // The naive per-texel bake on a subset of the reference texels.
    auto backend = make_opencl_backend({ocl::select_devices(opt.device).front()});
    const std::size_t subset = std::min<std::size_t>(texels.size(), opt.smoke ? 1 : 8);
    const std::uint32_t R = 8;
    const double t = student_t_quantile(0.999, int(R) - 1);
    const std::uint64_t pilot = opt.smoke ? 256 : 16384;
    double worst_ratio = 0;  // max over the subset of (t * se / target)^2 at the pilot count
    naive_texel(*backend, base, texels.front(), 128, R, 7);  // warm-up (kernel build, first launch)
    for (std::size_t i = 0; i < subset; ++i) {
        const NaiveTexel p = naive_texel(*backend, base, texels[i], pilot, R, 100 + i);
        worst_ratio = std::max(worst_ratio, std::pow(t * p.std_error / kTarget, 2));
    }
    const std::uint64_t needed = round_up_samples(std::uint64_t(std::ceil(double(pilot) * worst_ratio)), R);
    double naive_seconds = 0, naive_max_error = 0, naive_max_bound = 0, naive_sq = 0;
    for (std::size_t i = 0; i < subset; ++i) {
        const NaiveTexel p = naive_texel(*backend, base, texels[i], needed, R, 200 + i);
        naive_seconds += p.seconds;
        naive_max_error = std::max(naive_max_error, std::fabs(p.value - texels[i].value));
        naive_sq += (p.value - texels[i].value) * (p.value - texels[i].value);
        naive_max_bound = std::max(naive_max_bound, t * p.std_error);
    }
    out.naive_seconds_per_texel = naive_seconds / double(subset);
    out.naive_extrapolated = out.naive_seconds_per_texel * double(sampled_texels);
    out.speedup = best > 0 ? out.naive_extrapolated / best : 0;
    std::vector<double> degrees, weights;
    azimuth_nodes(base, degrees, weights);
    out.table.rows.push_back({"naive per-texel random bake (" + std::to_string(subset) + " texels, " +
                                  std::to_string(degrees.size()) + " azimuth nodes each), extrapolated to " +
                                  std::to_string(sampled_texels) + " sampled texels",
                              std::to_string(needed) + " per node", "", fmt(out.naive_extrapolated, 4),
                              fmt(naive_max_error, 3), "", fmt(naive_max_bound / t, 3), "",
                              naive_max_error <= kTarget ? "yes" : "no"});
    if (error_points) {
        ErrorPoint p;
        p.method = "naive per-texel random";
        p.samples = needed * degrees.size();
        p.seconds = naive_seconds;
        p.values = subset;
        p.seconds_per_value = out.naive_seconds_per_texel;
        p.max_error = naive_max_error;
        p.rms_error = std::sqrt(naive_sq / double(subset));
        p.max_reported_error = naive_max_bound / t;
        error_points->push_back(p);
    }
    log << "bake: naive per-texel bake needs " << needed << " random samples per azimuth node for t*se <= " << kTarget
        << "; " << fmt(out.naive_seconds_per_texel, 3) << " s per texel -> " << fmt(out.naive_extrapolated, 4)
        << " s for the LUT; fastest bake at max error <= 1e-3: " << fmt(best, 4) << " s -> speed-up "
        << fmt(out.speedup, 4) << "x\n";
    return out;
}

}  // namespace ms::bench

// ---- time to error of the bake, old (azimuth nodes) against new (azimuth-stratified) -------
//
// Every configuration is baked `reps` times, the configurations interleaved within each repetition
// (old and new see the same machine load), and the median wall and CPU (user + system, getrusage of the
// process: the PoCL threads are ours) time are reported with the spread. Errors are taken against two
// references: bench/data/reference.csv (64 texels, 2^19 oracle samples per trapezoid node, bound
// <= 2.5e-4: enough to check 1e-3, not 1e-4), and a tighter one computed here for a subset of the same
// texels with the OpenCL term kernel (not the bake kernels): 2^22 samples per node, 16 replicates, 65
// trapezoid nodes over [0, 180] (the term is smooth and periodic in the azimuth: |T_64 - T_32| is part of
// the bound), whose bound is what "max error <= 1e-4" can be checked against.
namespace ms::bench {

namespace {

double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct SpeedConfig {
    std::string method;  // "nodes adaptive", "nodes K=8", "stratified K=32", ...
    bool old_path = true;
    BakeSpec spec;
    std::vector<double> wall, cpu;
    double max_error = 0, rms_error = 0, max_tight = 0, rms_tight = 0, max_se = 0;
    double normals = 0, histogram = 0, reduce = 0;
    std::uint64_t increments = 0;
    BakeResult last;
    std::string worst;  // the texel of max_error
};

struct TightTexel {
    std::size_t index = 0;  // into the texel list
    double value = 0, std_error = 0, bound = 0;
};

std::vector<TightTexel> tight_reference(const Options& opt, const std::vector<RefEntry>& texels, std::size_t count,
                                        std::uint64_t samples, std::ostream& log) {
    const int K = 64;
    const std::size_t n = std::min(count, texels.size());
    std::vector<Query> nodes;
    for (std::size_t k = 0; k < n; ++k) {
        const RefEntry& e = texels[k];
        for (int j = 0; j <= K; ++j)
            nodes.push_back(lut_texel_query(e.lut_x, e.lut_y, e.lut_z, e.channel, e.lut_size, 3.14159265358979323846 * j / K));
    }
    SamplingPlan plan;
    plan.samples = samples;
    plan.replicates = 16;
    plan.seed = 0x7e57ull;  // independent of the bakes (seeds 0..) and of reference.csv
    const auto start = Clock::now();
    auto backend = make_opencl_backend({ocl::select_devices(opt.device).front()});
    const PointSet points = make_point_set(plan);
    const Tallies tl = backend->tally(nodes, TermOptions{}, points);
    const std::size_t R = plan.replicates;
    const double t = student_t_quantile(0.999, int(R) - 1);
    auto ratio = [](double c, double h) { return h > 0 ? c / h : 0.0; };
    std::vector<TightTexel> out;
    for (std::size_t k = 0; k < n; ++k) {
        double full = 0, half = 0;
        std::vector<double> x(R, 0.0);
        for (int j = 0; j <= K; ++j) {
            const std::size_t node = k * (K + 1) + std::size_t(j);
            double c = 0, h = 0;
            for (std::size_t r = 0; r < R; ++r) c += tl.cone[node * R + r], h += tl.hemisphere[node * R + r];
            const double w = (j == 0 || j == K) ? 0.5 / K : 1.0 / K;
            full += w * ratio(c, h);
            if (j % 2 == 0) half += ((j == 0 || j == K) ? 1.0 : 2.0) / K * ratio(c, h);
            for (std::size_t r = 0; r < R; ++r) x[r] += w * ratio(tl.cone[node * R + r], tl.hemisphere[node * R + r]);
        }
        double mean = 0, ss = 0;
        for (double v : x) mean += v / double(R);
        for (double v : x) ss += (v - mean) * (v - mean);
        TightTexel tt;
        tt.index = k;
        tt.value = full;
        tt.std_error = std::sqrt(ss / double(R * (R - 1)));
        tt.bound = t * tt.std_error + std::fabs(full - half);
        out.push_back(tt);
    }
    log << "bake speed: tight reference, " << n << " texels x " << (K + 1) << " nodes x " << samples
        << " samples (OpenCL term kernel): " << fmt(since(start), 3) << " s\n"
        << std::flush;
    return out;
}

}  // namespace

BakeSpeedResult run_bake_speed(const Options& opt, const std::vector<RefEntry>& reference) {
    std::ostream& log = *opt.log;
    std::vector<RefEntry> texels;
    for (const auto& e : reference)
        if (e.kind == 1) texels.push_back(e);
    if (texels.empty()) throw std::runtime_error("the reference set has no LUT texels");
    const std::uint32_t size = std::uint32_t(texels.front().lut_size);
    double ref_bound = 0;
    for (const auto& e : texels) ref_bound = std::max(ref_bound, e.error_bound);

    BakeSpeedResult out;
    BakeSpec base = default_bake_spec(LutLayout::seed_3d, size);
    base.backend.device = opt.device;
    base.command_line = "microshadow_bench --only bake-speed";
    {  // compile both paths' kernels before timing
        BakeSpec warm = default_bake_spec(LutLayout::seed_3d, 2);
        warm.backend.device = opt.device;
        warm.samples = 4096;
        bake_lut(warm);
        warm.azimuth_quadrature = AzimuthQuadrature::stratified;
        bake_lut(warm);
    }
    std::vector<TightTexel> tight;
    if (opt.smoke || opt.speed_tight_texels)
        tight = tight_reference(opt, texels, opt.smoke ? 2 : opt.speed_tight_texels,
                                opt.smoke ? (1u << 12) : opt.speed_tight_samples, log);
    double tight_bound = 0;
    for (const auto& t : tight) tight_bound = std::max(tight_bound, t.bound);

    std::vector<SpeedConfig> configs;
    auto add = [&](const std::string& method, bool old_path, std::uint64_t samples, std::uint32_t intervals,
                   std::uint32_t cells, double tolerance = 0) {
        SpeedConfig c;
        c.method = method;
        c.old_path = old_path;
        c.spec = base;
        c.spec.samples = samples;
        c.spec.tolerance = tolerance;
        if (old_path || cells == 0) {
            c.spec.azimuth_intervals = intervals;
        } else {
            c.spec.azimuth_quadrature = AzimuthQuadrature::stratified;
            c.spec.azimuth_cells = cells;
        }
        configs.push_back(c);
    };
    if (opt.smoke) {
        add("nodes adaptive (old default)", true, 1024, 0, 0);
        add("stratified K=32", false, 4096, 0, 32);
    } else {
        for (std::uint64_t n : opt.speed_old_samples) add("nodes adaptive (old default)", true, n, 0, 0);
        for (std::uint64_t n : opt.speed_old_k8_samples) add("nodes K=8", true, n, 8, 0);
        for (std::uint64_t n : opt.speed_new_samples) add("stratified K=32", false, n, 0, 32);
        for (std::uint64_t n : opt.speed_k16_samples) add("stratified K=16", false, n, 0, 16);
        // --tolerance (whole slices; 16384-sample batches): old path and stratified.
        for (double t : opt.speed_old_tolerances) add("nodes adaptive, --tolerance", true, 16384, 0, 0, t);
        for (double t : opt.speed_new_tolerances) add("stratified K=32, --tolerance", false, 16384, 0, 32, t);
    }
    const int reps = opt.smoke ? 1 : opt.speed_reps;
    for (int rep = 0; rep < reps; ++rep)
        for (auto& c : configs) {
            const double cpu0 = cpu_seconds();
            const auto t0 = Clock::now();
            c.last = bake_lut(c.spec);
            c.wall.push_back(since(t0));
            c.cpu.push_back(cpu_seconds() - cpu0);
            c.normals += c.last.normals_seconds / reps;
            c.histogram += c.last.histogram_seconds / reps;
            c.reduce += c.last.reduce_seconds / reps;
            c.increments = c.last.sample_node_rows;
            log << "bake speed: rep " << rep << " " << c.method << " " << c.spec.samples << " samples: " << fmt(c.wall.back(), 3)
                << " s wall, " << fmt(c.cpu.back(), 3) << " s cpu\n"
                << std::flush;
        }
    for (auto& c : configs) {
        const BakeResult& r = c.last;
        double sq = 0, sq_tight = 0;
        for (const auto& e : texels) {
            const double err = std::fabs(double(r.at(e.channel, e.lut_x, e.lut_y, e.lut_z)) - e.value);
            if (err >= c.max_error) {
                const AtlasShape shape{r.width, r.n_dot_l_count, r.height / r.n_dot_l_count, r.channels};
                const std::size_t at = shape.index(std::uint32_t(e.channel), std::uint32_t(e.lut_x), std::uint32_t(e.lut_y),
                                                   std::uint32_t(e.lut_z));
                std::ostringstream w;
                w << "channel " << e.channel << " v " << e.lut_x << " NdotL " << e.lut_y << " NdotV " << e.lut_z << ": bake "
                  << r.value[at] << " +- " << r.std_error[at] << ", reference " << e.value << " (bound " << fmt(e.error_bound, 2) << ")";
                c.worst = w.str();
            }
            c.max_error = std::max(c.max_error, err);
            sq += err * err;
        }
        c.rms_error = std::sqrt(sq / double(texels.size()));
        for (const auto& t : tight) {
            const RefEntry& e = texels[t.index];
            const double err = std::fabs(double(r.at(e.channel, e.lut_x, e.lut_y, e.lut_z)) - t.value);
            c.max_tight = std::max(c.max_tight, err);
            sq_tight += err * err;
        }
        c.rms_tight = tight.empty() ? 0.0 : std::sqrt(sq_tight / double(tight.size()));
        c.max_se = r.max_std_error;
    }

    out.curves.name = "seed-3d " + std::to_string(size) + "^3 x 4 bake: time to error (median of " + std::to_string(reps) +
                      " interleaved runs)";
    out.curves.columns = {"method", "samples_per_slice", "wall_s", "wall_min_s", "wall_max_s", "cpu_s",
                          "max_error", "rms_error", "max_error_tight", "rms_error_tight", "max_reported_std_error",
                          "normals_s", "histogram_s", "reduce_s", "increments", "increments_per_histogram_s"};
    for (const auto& c : configs) {
        const double w = median(c.wall);
        const std::string samples = c.spec.tolerance > 0 ? std::to_string(c.last.samples_per_batch) + "x" +
                                                               std::to_string(c.last.batches) + "/" +
                                                               std::to_string(c.last.slices) + " tol " + fmt(c.spec.tolerance, 2)
                                                         : std::to_string(c.last.samples_per_batch);
        out.curves.rows.push_back({c.method, samples, fmt(w, 4),
                                   fmt(*std::min_element(c.wall.begin(), c.wall.end()), 4),
                                   fmt(*std::max_element(c.wall.begin(), c.wall.end()), 4), fmt(median(c.cpu), 4),
                                   fmt(c.max_error, 3), fmt(c.rms_error, 3), fmt(c.max_tight, 3), fmt(c.rms_tight, 3),
                                   fmt(c.max_se, 3), fmt(c.normals, 3), fmt(c.histogram, 3), fmt(c.reduce, 3),
                                   std::to_string(c.increments), fmt(double(c.increments) / std::max(1e-9, c.histogram), 3)});
    }

    // Target 1: max error <= 1e-3 against reference.csv; fastest old setting against fastest new one.
    // Target 2: max error <= 1e-4 against the tight reference (what the references can resolve is stated).
    auto fastest = [&](bool old_path, double target, bool use_tight) -> const SpeedConfig* {
        const SpeedConfig* best = nullptr;
        for (const auto& c : configs) {
            if (c.old_path != old_path) continue;
            if ((use_tight ? c.max_tight : c.max_error) > target) continue;
            if (!best || median(c.wall) < median(best->wall)) best = &c;
        }
        return best;
    };
    const double t1 = opt.smoke ? 1e-2 : 1e-3;
    std::ostringstream rep;
    const SpeedConfig* o1 = fastest(true, t1, false);
    const SpeedConfig* n1 = fastest(false, t1, false);
    rep << "target 1 (max error <= " << fmt(t1, 2) << " against " << texels.size() << " reference texels, bound "
        << fmt(ref_bound, 2) << "): ";
    if (o1 && n1) {
        const double ratio = median(o1->wall) / median(n1->wall);
        const double cpu_ratio = median(o1->cpu) / median(n1->cpu);
        out.speedup_1e3 = ratio;
        rep << "old fastest " << o1->method << " at " << o1->last.samples_per_batch << " samples: " << fmt(median(o1->wall), 3)
            << " s wall / " << fmt(median(o1->cpu), 3) << " s cpu (max error " << fmt(o1->max_error, 2) << "); new fastest "
            << n1->method << " at " << n1->last.samples_per_batch << " samples: " << fmt(median(n1->wall), 3) << " s wall / "
            << fmt(median(n1->cpu), 3) << " s cpu (max error " << fmt(n1->max_error, 2) << "); speed-up " << fmt(ratio, 3)
            << "x wall, " << fmt(cpu_ratio, 3) << "x cpu (target 2.5x): " << (ratio >= 2.5 ? "MET" : "MISSED") << "\n";
    } else {
        rep << "no " << (o1 ? "new" : "old") << " configuration reached it\n";
    }
    const SpeedConfig* n2 = tight.empty() ? nullptr : fastest(false, 1e-4, true);
    rep << "target 2 (max error <= 1e-4 in <= 10 s, against the tight reference: " << tight.size() << " texels, bound "
        << fmt(tight_bound, 2) << "): ";
    if (n2) {
        out.seconds_1e4 = median(n2->wall);
        rep << n2->method << " at " << n2->last.samples_per_batch << " samples: " << fmt(median(n2->wall), 3) << " s wall / "
            << fmt(median(n2->cpu), 3) << " s cpu, max error " << fmt(n2->max_tight, 2) << " (" << fmt(n2->max_error, 2)
            << " against reference.csv, whose bound is " << fmt(ref_bound, 2) << "): "
            << (median(n2->wall) <= 10 ? "MET" : "MISSED (time)") << "\n";
    } else {
        rep << (tight.empty() ? "not checked (no tight reference)\n" : "no new configuration reached it\n");
    }
    for (const auto& c : configs)
        rep << "  breakdown " << c.method << " " << c.last.samples_per_batch << ": normals+points " << fmt(c.normals, 3)
            << " s, histogram kernel+read-back " << fmt(c.histogram, 3) << " s (" << c.increments << " increments, "
            << fmt(double(c.increments) / std::max(1e-9, c.histogram) , 3) << "/s), host reduction " << fmt(c.reduce, 3)
            << " s, rest " << fmt(median(c.wall) - c.normals - c.histogram - c.reduce, 3) << " s (scheduler, set-up, result);"
            << " worst texel " << c.worst << "\n";
    // Agreement of the LUTs, all sampled texels: the old default at its largest budget against each
    // stratified configuration at its largest budget (independent points: seed 0 both, different sets).
    const SpeedConfig* old_big = nullptr;
    for (const auto& c : configs)
        if (c.old_path && c.spec.azimuth_intervals == 0 && c.spec.tolerance == 0 &&
            (!old_big || c.spec.samples > old_big->spec.samples))
            old_big = &c;
    std::map<std::string, const SpeedConfig*> new_big;
    for (const auto& c : configs)
        if (!c.old_path && (!new_big[c.method] || c.spec.samples > new_big[c.method]->spec.samples)) new_big[c.method] = &c;
    if (old_big)
        for (const auto& [method, nb] : new_big) {
            const BakeResult &a = old_big->last, &b = nb->last;
            std::size_t n = 0, over = 0;
            double worst_z = 0, worst_diff = 0;
            std::size_t worst_at = 0;
            std::vector<double> zs;
            for (std::size_t i = 0; i < a.value.size(); ++i) {
                if (a.std_error[i] <= 0 || b.std_error[i] <= 0) continue;
                const double se = std::sqrt(double(a.std_error[i]) * a.std_error[i] + double(b.std_error[i]) * b.std_error[i]);
                const double diff = std::fabs(double(a.value[i]) - b.value[i]);
                zs.push_back(diff / se);
                ++n;
                worst_diff = std::max(worst_diff, diff);
                if (diff / se > worst_z) worst_z = diff / se, worst_at = i;
            }
            const double t = student_t_quantile(1 - 1e-3 / double(std::max<std::size_t>(n, 1)), int(base.replicates) - 1);
            for (double z : zs) over += z > t;
            const std::size_t texel = worst_at / a.channels, y = texel / a.width;
            rep << "agreement: old default at " << old_big->spec.samples << " samples vs " << method << " at " << nb->spec.samples
                << ": " << n << " sampled texels, max |diff| " << fmt(worst_diff, 2) << ", max z " << fmt(worst_z, 3)
                << " (Bonferroni 99.9% t bound " << fmt(t, 3) << ", " << over << " texels above it; median z "
                << fmt(median(zs), 2) << "); worst at channel " << worst_at % a.channels << " v " << texel % a.width
                << " NdotL " << y % a.n_dot_l_count << " NdotV " << y / a.n_dot_l_count << "\n";
        }
    out.report = rep.str();
    return out;
}

}  // namespace ms::bench
