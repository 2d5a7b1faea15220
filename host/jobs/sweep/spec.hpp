// Sweep specifications (TOML, read with toml++): the parameter grid of a study, its comparators and
// its chunking, validated with messages that name the offending key.
//
// Format (every key optional unless marked required):
//
//   [sweep]
//   name = "azimuth study"        # recorded in the outputs
//   chunk_size = 4096             # points per chunk (the unit of streaming, resume and sharding)
//   max_points = 50000000         # raises the default safety limit of 20,000,000 points
//
//   [sampling]                    # defaults for the CLI's --method --tolerance --samples --replicates
//   method = "exact"              # --seed --sequence; a flag given on the command line overrides the
//   tolerance = 1e-10             # value here. method: "exact" (the default) or "sampled"; tolerance:
//   samples = 16384               # the exact method's estimated error of each value
//   replicates = 8
//   seed = 1
//   sequence = "sobol"
//
//   [parameters]                  # each: a number, a list of numbers, or a range table
//   visibility = { start = 0.0, stop = 1.0, count = 17 }            # required, in [0, 1]
//   n_dot_l = { start = 0.0, stop = 1.0, count = 17 }               # required, in [0, 1]
//   n_dot_v = [0.2, 0.5, 1.0]                                       # default [1], in (0, 1]
//   roughness = [0.1, 0.4, 0.7, 1.0]                                # alpha = roughness^2 ...
//   # alpha_x = [...]  alpha_y = [...]                              # ... or both alphas (> 0)
//   phi_i = [0.0]                                                   # azimuth of wi (V), degrees
//   delta_phi = { start = 0, stop = 180, count = 7 }                # azimuth of wo minus phi_i ...
//   # phi_o = [...]                                                 # ... or the azimuth of wo
//   form = ["height-correlated"]  # or "uncorrelated"; default: the CLI's --form
//   ao_weighting = ["cosine"]     # or "uniform";      default: the CLI's --ao-weighting
//
//   [comparators]
//   analytic = ["reference-step", "naughty-dog", "pz-analytic"]     # part 1's terms by name
//   [[comparators.lut]]
//   name = "lut3d-32"             # the column name
//   file = "lut3d-32.exr"         # a LUT of `microshadow bake`, or a representation file of `microshadow
//                                 # repr bake` (told apart by its metadata); relative to the spec file
//
// A range is { start, stop, count, scale = "linear" | "log" }: count values from start to stop
// inclusive (count = 1 gives start). Log ranges need start, stop > 0.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "analytic/part1_terms.hpp"
#include "core/types.hpp"

namespace ms::sweep {

class SpecError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

enum class Scale { linear, log };

struct Range {
    double start = 0, stop = 0;
    std::uint64_t count = 0;
    Scale scale = Scale::linear;
};

// The values of a range; endpoints are exact. Throws SpecError (key = `key`) for count 0, non-finite
// ends, start == stop with count > 1 (a zero-length range), or a log range with an end <= 0.
std::vector<double> generate_range(const Range& range, const std::string& key = "range");

struct LutComparatorSpec {
    std::string name;
    std::string file;    // resolved against the spec file's directory; empty for a preset
    std::string preset;  // a representation preset by name ("full-range"), baked when the sweep opens it
};

// Largest sweep accepted without an explicit [sweep].max_points.
inline constexpr std::uint64_t kDefaultMaxPoints = 20'000'000;
// Hard ceiling on any explicit limit: beyond this a sweep is a mistake, not a study.
inline constexpr std::uint64_t kHardMaxPoints = 10'000'000'000ULL;

struct Spec {
    std::string name;
    std::string source;  // the file it came from, for messages

    std::vector<double> visibility, n_dot_l, n_dot_v;
    bool by_roughness = true;  // roughness given (alpha = r^2), else alpha_x and alpha_y
    std::vector<double> roughness, alpha_x, alpha_y;
    std::vector<double> phi_i;  // degrees
    bool relative_azimuth = true;  // phi_o = phi_i + delta_phi, else phi_o given
    std::vector<double> phi_o_or_delta;
    std::vector<Form> forms;  // empty: the CLI's --form
    std::vector<AoWeighting> weightings;  // empty: the CLI's --ao-weighting

    std::vector<analytic::AnalyticTerm> analytic;
    std::vector<LutComparatorSpec> luts;

    std::uint64_t chunk_size = 4096;
    std::uint64_t max_points = kDefaultMaxPoints;

    std::optional<std::uint64_t> samples, seed;
    std::optional<std::uint32_t> replicates;
    std::optional<std::string> sequence;
    std::optional<Method> method;
    std::optional<double> tolerance;
};

// Parses and validates; throws SpecError naming the file and the key. Unknown keys are errors.
Spec parse_spec(const std::string& toml_text, const std::string& source_name, const std::string& base_dir = ".");
Spec parse_spec_file(const std::string& path);

// The comparator column names, in column order (analytic terms first, then LUTs).
std::vector<std::string> comparator_names(const Spec& spec);

// A canonical text of everything in the spec that decides the output bits (the values, not the
// spelling of the file), hashed into the manifest so a resume never mixes two different sweeps.
std::string canonical_text(const Spec& spec);

}  // namespace ms::sweep
