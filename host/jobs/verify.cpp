#include "jobs/verify.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "core/estimate.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "integrands/term/term_integrand.hpp"
#include "jobs/eval.hpp"
#include "sampling/point_set.hpp"

namespace ms {

namespace {

// Float storage rounds the value by at most half an ulp (2^-24 relative).
double storage_rounding(double lut) { return 6e-8 * std::max(1.0, std::abs(lut)); }

// One azimuth rule (degrees, weights summing to 1) the bake may have estimated a texel with.
struct AzimuthRule {
    std::vector<double> degrees, weights;
};

// The rules a texel of this bake was estimated with: the adaptive default ends each row at its own K
// (nested trapezoids), and the result says which K occurred; every other policy has one rule.
std::vector<AzimuthRule> bake_rules(const BakeSpec& spec, const BakeResult& result) {
    std::vector<AzimuthRule> rules;
    const bool adaptive = spec.azimuth_mean && spec.azimuth_quadrature == AzimuthQuadrature::nodes &&
                          spec.azimuth_intervals == 0 && effective_azimuth_cells(spec) == 0;
    if (adaptive)
        for (const auto& [intervals, rows] : result.azimuth_rows_by_intervals) {
            if (rows == 0 || intervals == 0) continue;
            BakeSpec fixed = spec;
            fixed.azimuth_intervals = intervals;
            AzimuthRule r;
            azimuth_nodes(fixed, r.degrees, r.weights);
            rules.push_back(std::move(r));
        }
    if (rules.empty()) {
        AzimuthRule r;
        azimuth_nodes(spec, r.degrees, r.weights);
        rules.push_back(std::move(r));
    }
    return rules;
}

std::string texel_name(const BakeResult& result, std::size_t at) {
    const std::size_t texel = at / result.channels, y = texel / result.width;
    std::ostringstream s;
    s << "channel " << at % result.channels << ", visibility " << texel % result.width << ", n_dot_l "
      << y % result.n_dot_l_count << ", n_dot_v " << y / result.n_dot_l_count;
    return s.str();
}

}  // namespace

BakeVerification verify_bake(const BakeSpec& spec, const BakeResult& result, std::size_t count, std::uint64_t samples,
                             unsigned threads, Method reference) {
    BakeVerification v;
    v.reference = reference;
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

    auto texel_indices = [&](std::size_t at, std::uint32_t& c, std::uint32_t& iv, std::uint32_t& il, std::uint32_t& ivv) {
        c = std::uint32_t(at % result.channels);
        const std::size_t texel = at / result.channels;
        iv = std::uint32_t(texel % result.width);
        const std::size_t y = texel / result.width;
        il = std::uint32_t(y % result.n_dot_l_count);
        ivv = std::uint32_t(y / result.n_dot_l_count);
    };
    v.threshold = student_t_quantile(1.0 - 0.001 / double(std::max<std::size_t>(k, 1)), int(spec.replicates) - 1);

    if (reference == Method::exact && spec.method == Method::exact && spec.azimuth_mean) {
        // An exact bake's texels are azimuth means by the exact method's own quadrature, not a node rule:
        // the reference is the same mean at the evaluator's default tolerance. A texel's recorded error is
        // an error bound's estimate, not a standard error, so the limit is 1: a texel fails as soon as it is
        // further from the reference than its recorded error, the reference's and the float rounding.
        v.threshold = 1.0;
        std::vector<exact_term::ExactTexel> texels;
        for (std::size_t i = 0; i < k; ++i) {
            std::uint32_t c, iv, il, ivv;
            texel_indices(candidates[i], c, iv, il, ivv);
            const double r = spec.roughness.at(c);
            texels.push_back({spec.visibility.value(iv), r * r, std::max(spec.n_dot_v.value(ivv), kMinNdotV),
                              std::max(spec.n_dot_l.value(il), kMinNdotL)});
        }
        std::vector<exact::ExactValue> values;
        exact_term::make_cpu_evaluator(std::max(1u, threads))
            ->texels(texels, spec.term.ao_weighting, true, 0.0, exact::kDefaultTolerance, values);
        for (std::size_t i = 0; i < k; ++i) {
            const std::size_t at = candidates[i];
            const double lut = result.value[at], se_lut = result.std_error[at];
            const double diff = std::abs(lut - values[i].term);
            const double slack = diff - values[i].error - storage_rounding(lut);
            const double z = slack <= 0 ? 0.0 : se_lut > 0 ? slack / se_lut : HUGE_VAL;
            ++v.checked;
            if (z > v.threshold) ++v.failed;
            v.worst_abs_diff = std::max(v.worst_abs_diff, diff);
            v.max_reference_error = std::max(v.max_reference_error, values[i].error);
            if (z >= v.worst_z) {
                v.worst_z = z;
                std::ostringstream s;
                s << texel_name(result, at) << ": lut " << lut << " +- " << se_lut << ", exact mean " << values[i].term
                  << " (error " << values[i].error << ")";
                v.worst_texel = s.str();
            }
        }
        return v;
    }
    if (reference == Method::exact) {
        // Every (texel, rule, node) query through the exact method on oracle-backend threads.
        const std::vector<AzimuthRule> rules = bake_rules(spec, result);
        std::vector<Query> queries;
        for (std::size_t i = 0; i < k; ++i) {
            std::uint32_t c, iv, il, ivv;
            texel_indices(candidates[i], c, iv, il, ivv);
            for (const AzimuthRule& rule : rules)
                for (double deg : rule.degrees) queries.push_back(texel_query(spec, c, iv, il, ivv, deg));
        }
        SamplingPlan plan;
        plan.method = Method::exact;
        plan.tolerance = exact::kDefaultTolerance;
        const auto backend = make_oracle_backend(threads);
        const std::vector<Estimate> values = evaluate(*backend, queries, spec.term, plan);
        std::size_t q = 0;
        for (std::size_t i = 0; i < k; ++i) {
            const std::size_t at = candidates[i];
            const double lut = result.value[at], se_lut = result.std_error[at];
            // The texel is judged against the rule it is closest to (one rule unless adaptive).
            double best_slack = HUGE_VAL, best_ref = 0, best_error = 0;
            for (const AzimuthRule& rule : rules) {
                double ref = 0, error = 0;
                for (std::size_t a = 0; a < rule.degrees.size(); ++a, ++q) {
                    ref += rule.weights[a] * values[q].term;
                    error += rule.weights[a] * values[q].std_error;  // the estimated errors add (weights >= 0)
                }
                const double slack = std::abs(lut - ref) - error - storage_rounding(lut);
                if (slack < best_slack) {
                    best_slack = slack;
                    best_ref = ref;
                    best_error = error;
                }
            }
            const double diff = std::abs(lut - best_ref);
            const double z = best_slack <= 0 ? 0.0 : se_lut > 0 ? best_slack / se_lut : HUGE_VAL;
            ++v.checked;
            if (z > v.threshold) ++v.failed;
            v.worst_abs_diff = std::max(v.worst_abs_diff, diff);
            v.max_reference_error = std::max(v.max_reference_error, best_error);
            if (z >= v.worst_z) {
                v.worst_z = z;
                std::ostringstream s;
                s << texel_name(result, at) << ": lut " << lut << " +- " << se_lut << ", exact " << best_ref << " (error "
                  << best_error << ")";
                v.worst_texel = s.str();
            }
        }
        return v;
    }

    SamplingPlan plan;
    plan.sequence = spec.sequence;
    plan.replicates = spec.replicates;
    plan.samples = round_up_samples(samples ? samples : result.samples_per_batch, spec.replicates);
    // Independent of every batch of the bake (batch 0 uses the seed, later ones mix64 of it).
    plan.seed = spec.seed ^ 0x0a11ce5eed5ull;
    const PointSet points = make_point_set(plan);
    const std::size_t R = plan.replicates;

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
        const double sigma = std::sqrt(se_lut * se_lut + oracle_rows[i].std_error * oracle_rows[i].std_error);
        const double slack = diff - storage_rounding(lut);
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

nlohmann::json verification_record(const BakeVerification& check) {
    return {{"method", to_string(check.reference)}, {"texels", check.checked}, {"failed", check.failed},
            {"worst_z", check.worst_z}, {"threshold", check.threshold}, {"worst_abs_diff", check.worst_abs_diff},
            {"max_reference_error", check.max_reference_error}};
}

void throw_if_failed(const BakeVerification& check) {
    if (check.failed == 0) return;
    std::ostringstream s;
    s << "verification failed: " << check.failed << " of " << check.checked << " texels differ from the "
      << (check.reference == Method::exact ? "exact method" : "oracle") << " beyond their error bars (worst z "
      << std::setprecision(3) << check.worst_z << " > " << check.threshold << "; " << check.worst_texel
      << "); nothing was written";
    throw std::runtime_error(s.str());
}

}  // namespace ms
