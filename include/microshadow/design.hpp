// The design study (included by <microshadow/microshadow.hpp>): `microshadow design` as a call that
// returns its tables. Every candidate representation of the term is judged against one cached reference
// set: N.L-weighted error against cost (texture bytes, fetches and ALU per light), the Pareto front and
// the best candidate inside a budget (docs/study.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// The command's options, with its defaults.
struct DesignOptions {
    std::string reference;            // the reference spec (TOML), required
    std::string fit_reference;        // fit the closed form to this spec at each fit_orders (empty: no fit)
    std::string cache = "out/design-cache";  // folder of cached reference sets
    // Candidates as FILE or NAME=FILE: baked LUTs, representations (files or preset names) and fitted
    // closed forms (JSON written by design).
    std::vector<std::string> luts, reprs, closed_forms;
    std::vector<unsigned> fit_orders{1, 2, 3};
    std::uint64_t max_bytes = UINT64_MAX;  // the budget
    unsigned max_fetches = UINT32_MAX, max_alu = UINT32_MAX;
    std::string choose;               // this candidate instead of the best inside the budget
    bool analytic = true;             // false: leave part 1's terms out
    bool strict_domain = false;       // refuse a candidate whose domain leaves out reference points
    Backend backend = Backend::opencl;  // where a missing reference is computed
    std::string device = "default";
};

// A candidate's errors: N.L-weighted RMS and 99th percentile of |candidate - term|, and the max over
// points of non-zero weight.
struct DesignMetrics {
    std::uint64_t points = 0;
    double weighted_rms = 0, weighted_p99 = 0, max_abs = 0;
};

// One row of pareto.csv.
struct DesignCandidate {
    std::string name, kind, storage;
    std::uint64_t bytes = 0;
    unsigned fetches_per_light = 0, alu_per_light = 0;
    DesignMetrics metrics;
    bool pareto = false, chosen = false, within_budget = false;
    std::uint64_t outside_domain = 0;       // reference points outside its domain
    std::vector<DesignMetrics> by_roughness;  // per band of DesignTable::roughness_edges
};

struct DesignTable {
    std::vector<DesignCandidate> candidates;  // sorted by weighted RMS, as pareto.csv
    std::vector<double> roughness_edges;      // the bands [edges[k], edges[k + 1]) (the last one closed)
    std::string chosen;
    // The evaluation reference set: its cached file, points and standard errors.
    std::string reference_file;
    std::uint64_t reference_points = 0;
    double reference_max_std_error = 0, reference_rms_std_error = 0;
};

// Runs the study. std::invalid_argument, before any work, for a bad spec, candidate file or name, or a
// choice over the budget; `progress` is told (points done, points) while a reference set is computed.
DesignTable design(const DesignOptions& options, const Progress& progress = {});

}  // namespace microshadow
