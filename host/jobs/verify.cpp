#include "jobs/verify.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/estimate.hpp"
#include "integrands/term/term_integrand.hpp"
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

    // Every (texel, node) query, tallied by the term integrand on the oracle scheduler (cancellable,
    // one work item per few queries), then reduced like the bake: pooled ratio per node, node-weighted
    // mean, std error from the per-replicate node-weighted means (core/estimate.hpp).
    std::vector<Query> queries;
    queries.reserve(k * degrees.size());
    for (std::size_t i = 0; i < k; ++i) {
        const std::size_t at = candidates[i];
        const std::uint32_t c = std::uint32_t(at % result.channels);
        const std::size_t texel = at / result.channels;
        const std::uint32_t iv = std::uint32_t(texel % result.width);
        const std::size_t y = texel / result.width;
        const std::uint32_t il = std::uint32_t(y % result.n_dot_l_count), ivv = std::uint32_t(y / result.n_dot_l_count);
        for (double deg : degrees) queries.push_back(texel_query(spec, c, iv, il, ivv, deg));
    }
    schedule::Scheduler oracle(schedule::Backend::oracle(threads));
    const term::Tallies t = term::tally(oracle, queries, spec.term, points);
    std::vector<Estimate> oracle_rows(k);
    for (std::size_t i = 0; i < k; ++i) {
        ReplicateRatioMean mean{std::uint32_t(R)};
        for (std::size_t a = 0; a < degrees.size(); ++a) {
            const std::size_t q = i * degrees.size() + a;
            mean.add(weights[a], &t.cone[q * R], &t.hemisphere[q * R]);
        }
        oracle_rows[i] = mean.estimate();
    }

    for (std::size_t i = 0; i < k; ++i) {
        const std::size_t at = candidates[i];
        const double lut = result.value[at], se_lut = result.std_error[at];
        const double diff = std::abs(lut - oracle_rows[i].term);
        // Float storage rounds the value by at most half an ulp (2^-24 relative).
        const double sigma = std::sqrt(se_lut * se_lut + oracle_rows[i].std_error * oracle_rows[i].std_error);
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
              << se_lut << ", oracle " << oracle_rows[i].term << " +- " << oracle_rows[i].std_error;
            v.worst_texel = s.str();
        }
    }
    return v;
}

}  // namespace ms
