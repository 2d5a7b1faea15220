// Parameter sweeps (included by <microshadow/microshadow.hpp>): `microshadow sweep SPEC.toml` as a call
// that returns the table (docs/sweep-spec.md has the spec's format).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// The spec's [sampling] values are defaults; a field set here wins, as a command-line option does.
struct SweepOptions {
    std::string out;  // the output directory: chunks, sweep.csv and the summary (empty: a temporary one, removed)
    std::optional<Method> method;          // default: the spec's, else exact
    std::optional<double> tolerance;
    std::optional<std::uint64_t> samples;
    std::optional<std::uint32_t> replicates;
    std::optional<std::uint64_t> seed;
    std::optional<Sequence> sequence;
    std::optional<Form> form;              // for specs that do not sweep parameters.form
    std::optional<AoWeighting> ao_weighting;  // for specs that do not sweep parameters.ao_weighting
    Backend backend = Backend::opencl;
    std::string device = "default";
    bool fast_math = false;
    bool exact_float = false;
};

// sweep.csv as columns: every column's name in order, numeric columns as numbers, and the text columns
// ("form", "ao_weighting") as text.
struct SweepTable {
    std::vector<std::string> columns;
    std::vector<std::vector<double>> numbers;     // numbers[k]: column k (empty for a text column)
    std::vector<std::vector<std::string>> texts;  // texts[k]: column k (empty for a numeric column)
    std::string summary_markdown;                 // each comparator's error against the term
};

// Runs the sweep of a spec file. `progress` is told (chunks done, chunks) and may stop it (the finished
// chunks stay in out_dir when one was given). std::invalid_argument naming the spec key for a bad spec.
SweepTable sweep(const std::string& spec_path, const SweepOptions& options = {}, const Progress& progress = {});
// The same for a spec given as TOML text; its relative comparator files are read from base_dir.
SweepTable sweep_toml(const std::string& toml_text, const std::string& base_dir, const SweepOptions& options = {},
                      const Progress& progress = {});

}  // namespace microshadow
