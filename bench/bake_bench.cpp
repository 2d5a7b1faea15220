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
#include <cmath>
#include <ostream>
#include <stdexcept>

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

    // The max error; the smoke run uses a looser one so its naive bake stays tiny.
    const double kTarget = opt.smoke ? 1e-2 : 1e-3;
    BakeBenchResult out;
    out.available = true;
    BakeSpec base = default_bake_spec(LutLayout::seed_3d, size);
    base.device = opt.device;
    base.command_line = "microshadow_bench (bake benchmark)";
    {
        BakeSpec warm = default_bake_spec(LutLayout::seed_3d, 2);  // compiles the kernels before timing
        warm.device = opt.device;
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
