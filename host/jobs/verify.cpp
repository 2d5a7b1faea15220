#include "jobs/verify.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <thread>

#include "core/estimate.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"

namespace ms {

BakeVerification verify_bake(const BakeSpec& spec, const BakeResult& result, std::size_t count, std::uint64_t samples,
                             unsigned threads) {
    BakeVerification v;
    if (count == 0) return v;
    std::vector<double> degrees, weights;
    azimuth_nodes(spec, degrees, weights);

    // Candidate texels: those that were sampled (std error > 0, or a value strictly between 0 and 1).
    std::vector<std::size_t> candidates;
    for (std::size_t i = 0; i < result.value.size(); ++i)
        if (result.std_error[i] > 0 || (result.value[i] > 0 && result.value[i] < 1)) candidates.push_back(i);
    // Deterministic choice: a partial Fisher-Yates shuffle driven by a splitmix64 stream of the seed.
    std::uint64_t state = spec.seed ^ 0x7e51f1edull;
    auto next = [&state] {
        std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        return z ^ (z >> 31);
    };
    const std::size_t k = std::min(count, candidates.size());
    for (std::size_t i = 0; i < k; ++i) std::swap(candidates[i], candidates[i + next() % (candidates.size() - i)]);
    candidates.resize(k);

    SamplingPlan plan;
    plan.sequence = spec.sequence;
    plan.replicates = spec.replicates;
    plan.samples = round_up_samples(samples ? samples : result.samples_per_batch, spec.replicates);
    // Independent of every batch of the bake (batch 0 uses the seed, later ones mix64 of it).
    plan.seed = spec.seed ^ 0x0a11ce5eed5ull;
    const PointSet points = make_point_set(plan);
    const std::size_t R = plan.replicates;
    v.threshold = student_t_quantile(1.0 - 0.001 / double(std::max<std::size_t>(k, 1)), int(R) - 1);

    struct Row {
        double value = 0, se = 0;
    };
    std::vector<Row> oracle_rows(k);
    const unsigned workers = std::max(1u, threads ? threads : std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    std::atomic<std::size_t> next_index{0};
    for (unsigned w = 0; w < workers; ++w)
        pool.emplace_back([&] {
            for (std::size_t i; (i = next_index.fetch_add(1)) < k;) {
                const std::size_t at = candidates[i];
                const std::uint32_t c = std::uint32_t(at % result.channels);
                const std::size_t texel = at / result.channels;
                const std::uint32_t iv = std::uint32_t(texel % result.width);
                const std::size_t y = texel / result.width;
                const std::uint32_t il = std::uint32_t(y % result.n_dot_l_count), ivv = std::uint32_t(y / result.n_dot_l_count);
                // Same estimator structure as the bake: pooled ratio per node, weighted mean over nodes;
                // std error from the per-replicate node-weighted means.
                std::vector<double> x(R, 0.0);
                double value = 0;
                for (std::size_t a = 0; a < degrees.size(); ++a) {
                    const Query q = texel_query(spec, c, iv, il, ivv, degrees[a]);
                    const oracle::Tally t = oracle::tally(q, spec.term, points);
                    double cone = 0, hemi = 0;
                    for (std::size_t r = 0; r < R; ++r) {
                        cone += t.cone[r];
                        hemi += t.hemisphere[r];
                        x[r] += weights[a] * (t.hemisphere[r] > 0 ? t.cone[r] / t.hemisphere[r] : 0.0);
                    }
                    if (hemi > 0) value += weights[a] * cone / hemi;
                }
                double mean = 0, ss = 0;
                for (double xr : x) mean += xr / double(R);
                for (double xr : x) ss += (xr - mean) * (xr - mean);
                oracle_rows[i] = {value, std::sqrt(ss / (double(R) * double(R - 1)))};
            }
        });
    for (auto& t : pool) t.join();

    for (std::size_t i = 0; i < k; ++i) {
        const std::size_t at = candidates[i];
        const double lut = result.value[at], se_lut = result.std_error[at];
        const double diff = std::abs(lut - oracle_rows[i].value);
        // Float storage rounds the value by at most half an ulp (2^-24 relative).
        const double sigma = std::sqrt(se_lut * se_lut + oracle_rows[i].se * oracle_rows[i].se);
        const double slack = diff - 6e-8 * std::max(1.0, std::abs(lut));
        const double z = slack <= 0 ? 0.0 : sigma > 0 ? slack / sigma : HUGE_VAL;
        ++v.checked;
        if (z > v.threshold) ++v.failed;
        v.worst_abs_diff = std::max(v.worst_abs_diff, diff);
        if (z >= v.worst_z) {
            v.worst_z = z;
            const std::size_t texel = at / result.channels, y = texel / result.width;
            std::ostringstream s;
            s << "channel " << at % result.channels << ", visibility " << texel % result.width << ", n_dot_l "
              << y % result.n_dot_l_count << ", n_dot_v " << y / result.n_dot_l_count << ": lut " << lut << " +- "
              << se_lut << ", oracle " << oracle_rows[i].value << " +- " << oracle_rows[i].se;
            v.worst_texel = s.str();
        }
    }
    return v;
}

}  // namespace ms
