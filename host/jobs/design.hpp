// `microshadow design` as a job: every candidate representation of the term (part 1's
// analytic terms, baked LUTs, the fitted closed form, the azimuth-keeping representations) is judged
// against one cached reference set (jobs/reference_set.hpp); the Pareto front of error against cost
// (texture bytes, fetches per light, ALU per light) and the best candidate inside a budget.
//
// Errors are comparator - term at each reference point, weighted by w_i = weight_i x max(NdotL_i, 0)
// (the lighting multiplies the term by NdotL): the weighted RMS sqrt(sum w e^2 / sum w), the weighted
// 99th percentile of |e| (the smallest |e| below which 99 % of the weight lies) and the max |e| over
// points of non-zero weight.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/error_stats.hpp"
#include "core/lookup_domain.hpp"
#include "io/atomic_file.hpp"
#include "approx/analytic.hpp"
#include "jobs/compare.hpp"
#include "jobs/reference_set.hpp"
#include "lut/shader/alu_count.hpp"

namespace ms::design {

// A candidate's name goes into CSV and Markdown rows and into file names (OUT/chosen-NAME.*): 1 to 64
// letters, digits, '.', '_', '+' or '-', not starting with '.' or '-'. Throws std::invalid_argument
// naming the first character that is not allowed.
void check_candidate_name(const std::string& name);

struct Candidate {
    std::string name;
    std::string kind;  // "analytic", "lut", "closed-form", or the representation's own kind
    approx::Cost cost;
    std::function<double(const approx::Inputs&)> value;
    nlohmann::json provenance;
    // Where it answers as measured (a file's or a fit's "domain"); none: everywhere (part 1's formulas).
    std::optional<LookupDomain> domain;
    // Adds the representation's files (its data and its GLSL/HLSL) to `outputs` as `prefix` + a
    // suffix, written but not committed (the caller commits them with its other outputs).
    std::function<void(OutputSet& outputs, const std::string& prefix)> bake;
};

// What design ranks a candidate by, over the points of positive weight w = weight x max(N.L, 0) (points
// of weight 0 do not count at all): their number, sqrt(sum w e^2 / sum w), the weighted 99th percentile
// of |e| (the error below which 99 % of the weight lies) and max |e| (core/error_stats.hpp).
struct Metrics {
    std::size_t points = 0;
    double weighted_rms = 0, weighted_p99 = 0, max_abs = 0;
};
// The metrics of statistics that kept their values (ErrorStats::Keep::values).
Metrics metrics_of(const ErrorStats& stats);

// The comparator inputs of a reference point (roughness as stored, the set's AO weighting).
approx::Inputs inputs_of(const ReferencePoint& p, AoWeighting weighting);

// The candidate's errors against the set. A candidate that throws at a point (std::domain_error: a
// roughness outside its domain) is an std::invalid_argument naming the candidate and the point.
Metrics evaluate_candidate(const Candidate& c, const ReferenceSet& set);

// The same per roughness band [edges[k], edges[k + 1]) (the last band includes its upper edge): where
// a candidate's error lives. Bands without points have points = 0.
std::vector<Metrics> evaluate_candidate_by_roughness(const Candidate& c, const ReferenceSet& set,
                                                     const std::vector<double>& edges);

// The set's points outside the candidate's domain (none without one), and the first in words.
struct DomainCount {
    DomainTally tally;
    std::string first_outside;
};
DomainCount count_outside_domain(const Candidate& c, const ReferenceSet& set);

// The `count` points of non-zero weight where |candidate - term| is largest, largest first: (index, error).
std::vector<std::pair<std::size_t, double>> worst_points(const Candidate& c, const ReferenceSet& set, std::size_t count);

// Weighted metrics of errors e_i with weights w_i >= 0, those of weight 0 left out (exposed for the tests).
Metrics error_metrics(const std::vector<double>& errors, const std::vector<double>& weights);

// Indices of the candidates no other candidate dominates: another with weighted RMS, bytes, fetches
// and ALU all <= and one of them < is better in every respect that counts.
std::vector<std::size_t> pareto_front(const std::vector<Candidate>& candidates, const std::vector<Metrics>& metrics);

struct Budget {
    std::uint64_t max_bytes = UINT64_MAX;
    unsigned max_fetches = UINT32_MAX;
    unsigned max_alu = UINT32_MAX;
    bool fits(const approx::Cost& c) const {
        return c.bytes <= max_bytes && c.fetches_per_light <= max_fetches && c.alu_per_light <= max_alu;
    }
};

// The candidate with the lowest weighted RMS inside the budget (ties: fewer bytes, then fewer ALU);
// std::invalid_argument when none fits (naming the cheapest candidate's cost).
std::size_t choose(const std::vector<Candidate>& candidates, const std::vector<Metrics>& metrics, const Budget& budget);

// Part 1's terms as candidates (cost: 0 bytes, 0 fetches, ALU counted from their GLSL,
// approx/analytic.hpp's analytic_glsl).
std::vector<Candidate> analytic_candidates(AoWeighting weighting);
// A baked LUT as a candidate: bytes at float16 per channel (as engines ship it), 1 fetch, ALU counted
// from its generated GLSL; bake() copies the file and writes its GLSL and HLSL.
// Throws std::invalid_argument (unreadable file).
Candidate lut_candidate(const std::string& name, const std::string& file);

// The ALU rule of every candidate's cost (lut/shader/alu_count.hpp).
using lutshader::count_alu;

}  // namespace ms::design
