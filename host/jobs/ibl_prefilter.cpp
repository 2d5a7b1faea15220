#include "jobs/ibl_prefilter.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <time.h>

#include "core/cancel.hpp"
#include "core/error_stats.hpp"
#include "core/estimate.hpp"
#include "env/cubemap_file.hpp"
#include "env/preview.hpp"
#include "io/atomic_file.hpp"
#include "jobs/ibl_env.hpp"
#include "integrands/prefilter/prefilter_integrand.hpp"
#include "lut/formats/texture.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

prefilter::SourceChain pack_chain(const std::vector<env::Cubemap>& chain) {
    prefilter::SourceChain c;
    c.size0 = chain[0].size;
    std::uint32_t offset = 0;
    for (const auto& level : chain) {
        c.offset.push_back(offset);
        for (int f = 0; f < 6; ++f) c.rgb.insert(c.rgb.end(), level.faces[f].data.begin(), level.faces[f].data.end());
        offset += 6 * level.size * level.size;
    }
    return c;
}

namespace {

// Runs `body(i)` for i in [0, count) on `threads` threads (the explicit sums of one mip), rethrowing the first error.
void parallel_for(std::size_t count, unsigned threads, const std::function<void(std::size_t)>& body) {
    std::atomic<std::size_t> next{0};
    std::mutex mutex;
    std::exception_ptr error;
    auto work = [&] {
        try {
            for (;;) {
                const std::size_t start = next.fetch_add(64);
                if (start >= count) break;
                throw_if_cancelled();
                for (std::size_t i = start; i < std::min(count, start + 64); ++i) body(i);
            }
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex);
            if (!error) error = std::current_exception();
            next = count;
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
}

double process_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// The environment's mean radiance (mean of RGB over the sphere, exact texel solid angles).
double mean_radiance(const env::Cubemap& source) {
    double power = 0;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < source.size; ++y)
            for (std::uint32_t x = 0; x < source.size; ++x) {
                const float* v = source.texel(f, x, y);
                power += (double(v[0]) + v[1] + v[2]) / 3 * env::cube_texel_solid_angle(x, y, source.size);
            }
    return power / (4 * 3.14159265358979323846);
}

// One sample round's independent scramble: the run's seed mixed with the round (and the round's size, so
// groups of different sizes in one round differ too).
std::uint64_t round_seed(std::uint64_t seed, std::uint32_t round, std::uint64_t samples) {
    std::uint64_t x = seed ^ (0x9E3779B97F4A7C15ull * (std::uint64_t(round) + 1)) ^ (samples << 40);
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// Smallest replicates x 2^k (k >= 4) >= n, but no more than the largest such count within `cap` (the smallest
// admissible count when even that is above cap).
std::uint64_t admissible_samples(double n, std::uint32_t replicates, std::uint64_t cap) {
    std::uint64_t s = std::uint64_t(replicates) * 16;
    while (double(s) < n && 2 * s <= cap) s *= 2;
    return s;
}

}  // namespace

std::uint32_t default_levels(std::uint32_t size) {
    std::uint32_t levels = 1;
    while ((size >> levels) >= 4) ++levels;  // down to 4 x 4
    return levels;
}

PrefilterResult prefilter_cubemap(const env::Cubemap& source, const PrefilterSpec& spec, const PrefilterCallbacks& cb) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = process_cpu_seconds();
    const std::uint32_t size = source.size;
    const std::uint32_t levels = spec.levels ? spec.levels : default_levels(size);
    if ((size >> (levels - 1)) == 0) throw std::invalid_argument("prefilter: too many levels for a face of " + std::to_string(size));
    if (spec.wide_samples_factor == 0 || (spec.wide_samples_factor & (spec.wide_samples_factor - 1)))
        throw std::invalid_argument("--wide-samples-factor must be a power of two (the point sets are nets of 2^m points)");
    if (!(spec.tolerance >= 0)) throw std::invalid_argument("--tolerance must be >= 0");
    const std::uint32_t R = spec.plan.replicates;
    if (R < 2) throw std::invalid_argument("prefilter: at least 2 replicates (error bars)");
    const std::uint64_t first_samples = round_up_samples(spec.plan.samples, R);
    const std::uint64_t max_samples = std::max(first_samples, round_up_samples(spec.max_samples, R));
    const std::vector<env::Cubemap> chain = env::mip_chain(source);
    const unsigned threads = spec.backend.threads ? spec.backend.threads : std::max(1u, std::thread::hardware_concurrency());

    PrefilterResult r;
    r.replicates = R;
    r.t_multiplier = student_t_quantile(0.95, int(R) - 1);
    r.mips.push_back(source);
    r.roughness.push_back(0);
    r.std_error.emplace_back();
    r.explicit_bound.emplace_back();
    r.mean_samples_by_mip.push_back(0);
    std::uint64_t all_texels = 0;
    for (std::uint32_t m = 1; m < levels; ++m) {
        r.mips.emplace_back(size >> m);
        r.std_error.emplace_back(size >> m);
        r.explicit_bound.emplace_back(size >> m);
        r.roughness.push_back(env::mip_roughness(m, levels, spec.mapping));
        all_texels += 6ull * (size >> m) * (size >> m);
    }

    // The bright split: a given threshold, or chosen for the tolerance, or none.
    env::BrightSplit split;
    if (spec.bright_threshold > 0)
        split = env::split_bright_texels(source, spec.bright_threshold, spec.bright_max_texels);
    else if (spec.bright_auto)
        split = env::choose_bright_split(source, spec.tolerance > 0 ? spec.tolerance : 0.01, spec.bright_max_texels, spec.bright_cost_ratio);
    r.bright_texels = split.texels.size();
    r.bright_power_fraction = split.bright_power_fraction;
    r.bright_threshold = split.threshold;
    const bool have_split = !split.texels.empty();
    // A texel's scale floor: the bars of a black texel are relative to a small share of the mean radiance.
    const double scale_floor = 1e-4 * mean_radiance(source);

    // One scheduler for every round (devices compile their program once): OpenCL devices, or the C++
    // estimator on CPU threads as the scheduler's oracle backend.
    schedule::BackendSpec where = spec.backend;
    where.threads = threads;
    schedule::Scheduler scheduler(where);
    const prefilter::SourceChain packed_full = pack_chain(chain);
    const prefilter::SourceChain packed_rest = have_split ? pack_chain(split.rest_chain) : prefilter::SourceChain{};
    prefilter::RoutineConfig config;
    config.filtered = spec.options.filtered;
    config.lod_bias = spec.options.lod_bias;

    std::uint64_t converged_texels = 0;
    for (std::uint32_t m = 1; m < levels; ++m) {
        const std::uint32_t n = size >> m;
        const double rough = r.roughness[m];
        const bool wide = rough >= spec.bright_min_roughness;
        const bool use_split = have_split && wide;
        const std::vector<env::Cubemap>& sampled_chain = use_split ? split.rest_chain : chain;
        const std::size_t T = 6ull * n * n;
        std::vector<prefilter::Target> targets(T);
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x) {
                    const env::Dir d = env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                    targets[(std::size_t(f) * n + y) * n + x] = {d.x, d.y, d.z, rough};
                }
        // The explicit part, once per texel (deterministic).
        std::vector<env::BrightShare> share(T);
        if (use_split)
            parallel_for(T, threads, [&](std::size_t i) {
                share[i] = env::bright_texel_share_bounded(split, {targets[i].x, targets[i].y, targets[i].z}, rough);
            });
        // Rounds: each active texel asks for its next batch of samples (a power-of-two net per replicate);
        // texels asking the same count run together on one independently scrambled point set, and their
        // per-replicate tallies add to the earlier rounds'.
        std::vector<double> sums(T * 4 * R, 0.0);
        std::vector<std::uint64_t> taken(T, 0), next(T, wide ? std::min(max_samples, first_samples * spec.wide_samples_factor) : first_samples);
        std::vector<char> active(T, 1);
        std::vector<double> num(R), den(R);
        std::uint32_t round = 0;
        for (;; ++round) {
            std::map<std::uint64_t, std::vector<std::size_t>> groups;
            for (std::size_t i = 0; i < T; ++i)
                if (active[i]) groups[next[i]].push_back(i);
            if (groups.empty()) break;
            for (const auto& [samples, members] : groups) {
                SamplingPlan plan = spec.plan;
                plan.samples = samples;
                plan.seed = round_seed(spec.plan.seed, round, samples);
                const PointSet points = make_point_set(plan);
                std::vector<prefilter::Target> group_targets;
                group_targets.reserve(members.size());
                for (std::size_t i : members) group_targets.push_back(targets[i]);
                // Items of ~4 M samples: well under a second each, so a cancel or a device failure loses little.
                const std::size_t per_item = std::size_t(std::clamp<std::uint64_t>((std::uint64_t(1) << 22) / samples, 1, 256));
                prefilter::PrefilterIntegrand integrand(
                    use_split ? packed_rest : packed_full, std::move(group_targets), per_item, points, config,
                    [&](const prefilter::Target& t, const PointSet& pts, double* out) {
                        env::PrefilterSums s(pts.replicates);
                        env::prefilter_sums(sampled_chain, {t.x, t.y, t.z}, t.roughness, pts, spec.options, s);
                        for (std::uint32_t q = 0; q < pts.replicates; ++q) {
                            for (int c = 0; c < 3; ++c) out[4 * q + c] = s.num[3 * std::size_t(q) + c];
                            out[4 * q + 3] = s.den[q];
                        }
                    });
                const schedule::RunReport report = scheduler.run(integrand);
                r.rerun_items += report.rerun;
                for (const auto& failed : report.failed_places) r.failed_devices.push_back(failed);
                const std::vector<double>& got = integrand.sums();
                for (std::size_t g = 0; g < members.size(); ++g) {
                    const std::size_t i = members[g];
                    for (std::size_t q = 0; q < 4 * R; ++q) sums[i * 4 * R + q] += got[g * 4 * R + q];
                    taken[i] += samples;
                }
            }
            // Which texels are done, and how many samples the others need (the bar falls as 1 / sqrt(N)).
            for (std::size_t i = 0; i < T; ++i) {
                if (!active[i]) continue;
                std::array<double, 3> value{}, se{};
                for (int c = 0; c < 3; ++c) {
                    for (std::uint32_t q = 0; q < R; ++q) {
                        num[q] = sums[(i * R + q) * 4 + c];
                        den[q] = sums[(i * R + q) * 4 + 3];
                    }
                    const Estimate e = reduce_replicates(num.data(), den.data(), R);
                    value[c] = e.term + share[i].share[c];
                    se[c] = e.std_error;
                }
                const double scale = std::max(scale_floor, (std::abs(value[0]) + std::abs(value[1]) + std::abs(value[2])) / 3);
                double sampled_bar = 0, explicit_bar = 0;
                for (int c = 0; c < 3; ++c) {
                    sampled_bar = std::max(sampled_bar, r.t_multiplier * se[c] / scale);
                    explicit_bar = std::max(explicit_bar, share[i].bound[c] / scale);
                }
                const double target = spec.tolerance - explicit_bar;  // what the sampled part may use
                if (spec.tolerance == 0 || sampled_bar <= target) {
                    active[i] = 0;
                    ++converged_texels;
                } else if (taken[i] >= max_samples || target <= 0) {
                    active[i] = 0;  // out of samples, or the explicit part alone is above the tolerance
                    ++r.unconverged;
                    ++converged_texels;
                } else {
                    // N (bar / target)^2 in all, 10% over (the bar is itself an estimate), at most 4x this texel's
                    // samples per round so a bar estimated from too few samples (a rare bright texel unseen) is
                    // checked again before the texel takes its whole budget.
                    const double want = double(taken[i]) * (sampled_bar / target) * (sampled_bar / target) * 1.1 - double(taken[i]);
                    next[i] = admissible_samples(std::min(want, 4.0 * double(taken[i])), R,
                                                 max_samples - taken[i]);
                }
                if (!active[i]) {
                    const std::size_t f = i / (std::size_t(n) * n), y = (i / n) % n, x = i % n;
                    float* out = r.mips[m].texel(int(f), std::uint32_t(x), std::uint32_t(y));
                    float* out_se = r.std_error[m].texel(int(f), std::uint32_t(x), std::uint32_t(y));
                    float* out_b = r.explicit_bound[m].texel(int(f), std::uint32_t(x), std::uint32_t(y));
                    for (int c = 0; c < 3; ++c) {
                        out[c] = float(value[c] * (1 + spec.test_bias));
                        out_se[c] = float(se[c]);
                        out_b[c] = float(share[i].bound[c]);
                        if (value[c] > 0) r.max_relative_std_error = std::max(r.max_relative_std_error, se[c] / value[c]);
                    }
                    r.max_relative_bar = std::max(r.max_relative_bar, sampled_bar + explicit_bar);
                }
            }
            if (cb.progress) cb.progress(converged_texels, all_texels);
        }
        r.rounds = std::max(r.rounds, round);
        std::uint64_t mip_samples = 0;
        for (std::uint64_t t : taken) mip_samples += t;
        r.samples += mip_samples;
        r.texels += T;
        r.mean_samples_by_mip.push_back(double(mip_samples) / double(T));
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.cpu_seconds = process_cpu_seconds() - cpu_start;
    return r;
}

PrefilterVerification verify_prefilter(const env::Cubemap& source, const PrefilterResult& result, std::uint32_t k, std::uint64_t seed) {
    PrefilterVerification v;
    if (result.mips.size() < 2 || k == 0) return v;
    // Bonferroni over the 3 K channel checks at family-wise level 0.01: two-sided t with R - 1 degrees of freedom.
    const double alpha = 0.01;
    v.z_bound = student_t_quantile(1 - alpha / (3.0 * k), int(std::max(2u, result.replicates)) - 1);
    std::mt19937_64 rng(seed);
    // The relative errors and the relative replicate standard errors, over all checks and per mip
    // (core/error_stats.hpp: the one summary every report uses).
    ErrorStats relative, relative_se;
    double worst_relative = 0;
    std::vector<ErrorStats> relative_by_mip(result.mips.size()), relative_se_by_mip(result.mips.size());
    for (std::uint32_t i = 0; i < k; ++i) {
        const std::uint32_t m = 1 + std::uint32_t(rng() % (result.mips.size() - 1));
        const std::uint32_t n = result.mips[m].size;
        const int f = int(rng() % 6);
        const std::uint32_t x = std::uint32_t(rng() % n), y = std::uint32_t(rng() % n);
        const env::Dir d = env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
        double weight_sum = 0;
        const auto ref = env::prefilter_oracle(source, d, result.roughness[m], &weight_sum);
        // The oracle's value is its rule's weighted mean (normalised by the rule's own sum of weights), the
        // estimate's explicit part is normalised by the exact Z: they may differ by the oracle's normalisation
        // error |sum / Z - 1| of the value, an allowance of its own.
        const double alpha = result.roughness[m] * result.roughness[m];
        const double norm_error = std::abs(weight_sum / env::ggx_prefilter_normalisation(alpha) - 1);
        const float* got = result.mips[m].texel(f, x, y);
        const float* se = result.std_error[m].texel(f, x, y);
        const float* bound = result.explicit_bound[m].texel(f, x, y);
        const double scale = std::max(1e-30, (std::abs(ref[0]) + std::abs(ref[1]) + std::abs(ref[2])) / 3);
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(double(got[c]) - ref[c]);
            const double rel = diff / scale;
            relative.add(rel);
            relative_by_mip[m].add(rel);
            std::ostringstream where;
            where << "mip " << m << " face " << f << " texel (" << x << ", " << y << ") channel " << c << ": " << got[c] << " vs oracle "
                  << ref[c];
            // The first check with the largest error names the worst texel (strictly larger than the
            // largest before it; max_relative itself comes from the summary below).
            if (rel > worst_relative) {
                worst_relative = rel;
                v.worst_texel = where.str();
            }
            // The float the file stores is within 2^-24 |value| of the estimate; twice that for the oracle's own rounding.
            const double excess =
                std::max(0.0, diff - double(bound[c]) - std::ldexp(std::abs(double(got[c])), -23) - norm_error * std::abs(ref[c]));
            const double z = excess == 0 ? 0 : se[c] > 0 ? excess / double(se[c]) : std::numeric_limits<double>::infinity();
            if (z > v.worst_z) {
                v.worst_z = z;
                where << " (se " << se[c] << ", bound " << bound[c] << ")";
                v.worst_z_texel = where.str();
            }
            relative_se.add(se[c] / scale);
            relative_se_by_mip[m].add(se[c] / scale);
        }
        ++v.checked;
    }
    v.passed = v.worst_z <= v.z_bound;
    v.max_relative = relative.max_abs();
    v.rms_relative = relative.rms();
    v.rms_relative_std_error = relative_se.rms();
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        v.rms_relative_by_mip.push_back(relative_by_mip[m].rms());
        v.rms_std_error_by_mip.push_back(relative_se_by_mip[m].rms());
    }
    return v;
}

nlohmann::json verification_json(const PrefilterVerification& check) {
    return {{"texels", check.checked},
            {"reference", "the brute-force oracle (every source texel, exact solid angles)"},
            {"rms_relative", check.rms_relative},
            {"max_relative", check.max_relative},
            {"worst_z", std::isfinite(check.worst_z) ? nlohmann::json(check.worst_z) : nlohmann::json("inf")},
            {"z_bound", check.z_bound},
            {"z_bound_meaning", "Bonferroni: two-sided Student-t (R - 1 degrees of freedom) at family-wise level 0.01 over 3 x texels channels"},
            {"passed", check.passed},
            {"worst", check.worst_texel},
            {"worst_z_texel", check.worst_z_texel},
            {"rms_relative_std_error", check.rms_relative_std_error},
            {"rms_relative_by_mip", check.rms_relative_by_mip},
            {"rms_std_error_by_mip", check.rms_std_error_by_mip}};
}

nlohmann::json prefilter_metadata(const PrefilterSpec& spec, const PrefilterResult& result) {
    nlohmann::json m;
    m["layout"] = "prefiltered specular cubemap, one horizontal cross per mip (+Y above +Z; -X +Z +X -Z; -Y below +Z)";
    m["integral"] = "P(n) = int L(l) (n.l) D(h) dl / int (n.l) D(h) dl, GGX D, alpha = roughness^2, N = V = R";
    m["source"] = spec.source;
    m["mapping"] = to_string(spec.mapping);
    m["roughness"] = result.roughness;
    m["levels"] = result.mips.size();
    m["base_size"] = result.mips.empty() ? 0 : result.mips[0].size;
    m["estimator"] = spec.options.filtered ? "filtered importance sampling (Krivanek & Colbert 2008)" : "importance sampling of the full-resolution source";
    m["lod_bias"] = spec.options.lod_bias;
    if (result.bright_texels > 0)
        m["bright_texels"] = {{"chosen", spec.bright_threshold > 0 ? "by threshold" : "automatically (choose_bright_split for the tolerance)"},
                              {"threshold_times_mean_radiance", result.bright_threshold}, {"max_texels", spec.bright_max_texels},
                              {"min_roughness", spec.bright_min_roughness},
                              {"count", result.bright_texels}, {"power_fraction", result.bright_power_fraction},
                              {"method", "summed explicitly over their solid angles, removed from the sampled environment"},
                              {"error_bound", "per texel: difference from the rule at half the spacing plus the double summation's rounding bound"}};
    else
        m["bright_texels"] = {{"count", 0}};
    if (spec.test_bias != 0) m["test_bias"] = spec.test_bias;  // a corrupted estimator (test hook)
    m["tolerance"] = spec.tolerance;  // 0: a fixed sample count
    m["error_bar"] = "per texel and channel: t_{0.975, R-1} x replicate std error + the explicit part's bound, "
                     "relative to max(mean of RGB, 1e-4 x the mean radiance)";
    m["t_multiplier"] = result.t_multiplier;
    m["max_relative_bar"] = result.max_relative_bar;
    m["unconverged_texels"] = result.unconverged;
    m["max_samples"] = spec.max_samples;
    m["rounds"] = result.rounds;
    m["mean_samples_by_mip"] = result.mean_samples_by_mip;
    m["sequence"] = to_string(spec.plan.sequence);
    m["samples"] = spec.plan.samples;  // the first round's (with a tolerance) or every texel's
    m["wide_samples_factor"] = spec.wide_samples_factor;  // on mips of roughness >= bright_min_roughness
    m["wide_min_roughness"] = spec.bright_min_roughness;
    m["samples_total"] = result.samples;
    m["replicates"] = spec.plan.replicates;
    m["seed"] = spec.plan.seed;
    m["max_relative_std_error"] = result.max_relative_std_error;
    m["seconds"] = result.seconds;
    m["cpu_seconds"] = result.cpu_seconds;  // the process's CPU time: stable on a shared machine
    m["device"] = spec.backend.is_oracle() ? "CPU threads (C++ double)" : "opencl: " + spec.backend.device + " (kernels/prefilter/prefilter.cl, float)";
    m["rerun_items"] = result.rerun_items;  // rerun on another device after one failed (failover)
    m["failed_devices"] = result.failed_devices;
    m["version"] = MICROSHADOW_VERSION;
    m["command_line"] = spec.command_line;
    return m;
}

namespace {

lutfmt::PixelEncoding cubemap_encoding(const std::string& encoding_name) {
    const lutfmt::PixelEncoding encoding = lutfmt::parse_pixel_encoding(encoding_name);
    if (encoding != lutfmt::PixelEncoding::float16 && encoding != lutfmt::PixelEncoding::float32)
        throw std::invalid_argument("cubemap encoding " + encoding_name + ": float16 or float32 (unorm clips radiance above 1)");
    return encoding;
}

lutfmt::TextureData prefilter_texture(const PrefilterResult& result, const nlohmann::json& metadata, lutfmt::TextureFormat format,
                                      lutfmt::PixelEncoding encoding) {
    if (result.mips.empty()) throw std::invalid_argument("cubemap: no mips");
    std::vector<const env::Cubemap*> levels;
    for (const env::Cubemap& mip : result.mips) levels.push_back(&mip);
    lutfmt::TextureData t = env::cubemap_texture(levels, metadata);
    // The float16 rounding of the stored values, absolute and relative.
    double max_abs = 0, max_rel = 0;
    if (encoding == lutfmt::PixelEncoding::float16)
        for (const auto& level : t.levels)
            for (float v : level) {
                const double err = std::abs(double(lutfmt::half_to_float(lutfmt::float_to_half(v))) - v);
                max_abs = std::max(max_abs, err);
                if (v != 0) max_rel = std::max(max_rel, err / std::abs(double(v)));
            }
    t.metadata["file_format"] = lutfmt::to_string(format) + "-cubemap";
    t.metadata["mip_roughness"] = result.roughness;
    t.metadata["texture_channels"] = 4;
    t.metadata["padding"] = "A = 1 (RGB radiance)";
    t.metadata["encoding"] = lutfmt::to_string(encoding);
    t.metadata["quantisation"] = {{"kind", lutfmt::quantisation_kind(encoding)}, {"max_abs", max_abs}, {"max_relative", max_rel}};
    return t;
}

env::Canvas prefilter_preview_canvas(const PrefilterResult& result, double exposure) {
    // Each mip's cross magnified (nearest) to the base size, side by side in two rows.
    const std::uint32_t n = result.mips[0].size;
    const std::uint32_t cols = std::uint32_t((result.mips.size() + 1) / 2);
    const std::uint32_t cw = 4 * n + 8, ch = 3 * n + 28;
    // A strip at the bottom names the tone map.
    env::Image img(std::max(cols * cw, env::text_width(env::tone_map_caption(exposure), 1) + 8), 2 * ch + 14, {"R", "G", "B"});
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        const env::Image cross = env::cross_image(result.mips[m]);
        const std::uint32_t zoom = n / result.mips[m].size;
        const std::uint32_t ox = std::uint32_t(m % cols) * cw, oy = std::uint32_t(m / cols) * ch;
        for (std::uint32_t y = 0; y < 3 * n; ++y)
            for (std::uint32_t x = 0; x < 4 * n; ++x)
                for (int c = 0; c < 3; ++c) img.at(ox + x, oy + y, c) = cross.at(x / zoom, y / zoom, c);
    }
    env::Canvas canvas = env::tone_map(img, exposure);
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        // The largest of these labels that fits its cell's width (none in a cell too small for any): a
        // label wider than the cell ran into the next one ("roughnesmi0.000").
        char full[96], brief[48];
        std::snprintf(full, sizeof full, "mip %zu  %ux%u  roughness %.3f", m, result.mips[m].size, result.mips[m].size,
                      result.roughness[m]);
        std::snprintf(brief, sizeof brief, "m%zu r %.3f", m, result.roughness[m]);
        std::string label;
        std::uint32_t scale = 1;
        for (const auto& [text, size] : {std::pair<const char*, std::uint32_t>{full, 2}, {full, 1}, {brief, 2}, {brief, 1}})
            if (env::text_width(text, size) + 4 <= cw) {
                label = text, scale = size;
                break;
            }
        const std::int64_t ox = std::int64_t(m % cols) * cw, oy = std::int64_t(m / cols) * ch;
        if (!label.empty()) canvas.text(ox + 2, oy + 3 * n + 4, label, scale, 255);
        env::label_cross_faces(canvas, ox, oy, n);
    }
    canvas.text(4, 2 * ch + 3, env::tone_map_caption(exposure), 1, 255);
    return canvas;
}

// "specular_m<digits>.exr"
bool is_mip_file(const std::string& name) {
    const std::string head = "specular_m", tail = ".exr";
    if (name.size() <= head.size() + tail.size() || name.compare(0, head.size(), head) != 0 ||
        name.compare(name.size() - tail.size(), tail.size(), tail) != 0)
        return false;
    for (std::size_t i = head.size(); i < name.size() - tail.size(); ++i)
        if (name[i] < '0' || name[i] > '9') return false;
    return true;
}

}  // namespace

PrefilterFiles add_prefilter_files(OutputSet& outputs, const std::string& dir, std::uint32_t levels, const std::string& format,
                                   const std::string& encoding) {
    PrefilterFiles files;
    files.format = lutfmt::parse_texture_format(format, lutfmt::TextureUse::cubemap);
    files.encoding = encoding;
    if (files.format == lutfmt::TextureFormat::exr) {
        // An EXR holds one image: a cross per mip.
        for (std::uint32_t m = 0; m < levels; ++m)
            files.mips.push_back(lutfmt::add_texture_files(outputs, dir + "/specular_m" + std::to_string(m) + ".exr", files.format));
    } else {
        cubemap_encoding(encoding);
        files.cubemap = lutfmt::add_texture_files(outputs, lutfmt::file_name(dir + "/specular", files.format), files.format);
    }
    files.preview = outputs.add(dir + "/specular_preview.png");
    return files;
}

void write_prefilter_files(OutputSet& outputs, const PrefilterFiles& files, const PrefilterResult& result,
                           const nlohmann::json& metadata, double exposure) {
    if (files.format == lutfmt::TextureFormat::exr) {
        if (files.mips.size() != result.mips.size())
            throw std::logic_error("write_prefilter_files: " + std::to_string(files.mips.size()) + " mip files for " +
                                   std::to_string(result.mips.size()) + " mips");
        for (std::size_t m = 0; m < result.mips.size(); ++m) {
            throw_if_cancelled();  // a signal during a long chain of writes stops it here (nothing is committed)
            nlohmann::json meta = metadata;
            meta["mip"] = m;
            meta["mip_roughness"] = result.roughness[m];
            lutfmt::write_texture(outputs, files.mips[m], env::image_texture(env::cross_image(result.mips[m]), meta),
                                  lutfmt::PixelEncoding::float32);
        }
    } else {
        const lutfmt::PixelEncoding encoding = cubemap_encoding(files.encoding);
        lutfmt::write_texture(outputs, files.cubemap.value(), prefilter_texture(result, metadata, files.format, encoding), encoding);
    }
    env::write_png_file(outputs.temp_path(files.preview), prefilter_preview_canvas(result, exposure));
}

std::vector<std::string> stale_prefilter_files(const std::string& dir, const std::set<std::string>& written) {
    static const std::set<std::string> kOthers = {"specular.ktx2", "specular.dds", "specular.dds.json", "dfg.exr", "dfg.ktx2",
                                                  "dfg.dds",       "dfg.dds.json", "dfg_preview.png",   "irradiance.exr",
                                                  "irradiance.ktx2", "irradiance.dds", "irradiance.dds.json"};
    return stale_job_files(dir, written, [](const std::string& name) { return is_mip_file(name) || kOthers.count(name) > 0; });
}

}  // namespace ms
