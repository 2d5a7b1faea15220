// The whole `design` study as one job, shared by the command (cli/cmd_design.cpp) and the library
// (api/design.cpp): the inputs checked before any work, the closed forms fitted to a training set, every
// candidate judged on the evaluation set, the Pareto front, the choice inside the budget, and the
// outputs (pareto.csv, pareto.md, design.json and the chosen candidate's files).
//
// Where the reference sets come from is the caller's: they are cached and resumable
// (jobs/reference_set.hpp), and a command may split them into shards or share them among MPI ranks.
// A study only reads them.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "jobs/design.hpp"
#include "jobs/reference_set.hpp"

namespace ms::design {

// How the caller spells its options in messages: the command's flags, or the library's field names.
struct OptionNames {
    std::string reference = "--reference", fit_reference = "--fit-reference", fit_orders = "--fit-orders";
    std::string lut = "--lut", repr = "--repr", choose = "--choose";
    bool assignments = false;  // values said as `name = 'value'` (the library's fields) or `--name value`
    std::string said(const std::string& option, const std::string& value) const {
        return assignments ? option + " = '" + value + "'" : option + " " + value;
    }
    static OptionNames library() {
        return {"reference", "fit_reference", "fit_orders", "luts", "reprs", "choose", true};
    }
};

struct StudySpec {
    std::string reference, fit_reference;         // reference spec files (TOML)
    std::vector<std::string> luts, reprs;          // FILE or NAME=FILE (reprs: also a preset's name)
    std::vector<std::string> closed_forms;         // fitted closed forms (JSON written by a study)
    std::vector<unsigned> fit_orders{1, 2, 3};     // with fit_reference
    Budget budget;
    std::string choose;                            // this candidate instead of the best inside the budget
    bool analytic = true;                          // part 1's terms as candidates
    bool strict_domain = false;                    // refuse a candidate looked up outside its domain
    std::string backend_label = "opencl";          // where missing references are computed (in their hash)
    ocl::BuildConfig build;                        // the kernels' build they are computed with (in their hash)
    std::string command_line;                      // provenance of the fits and design.json
    OptionNames names;
    // The caller's own check of a sampled reference's plan (the command's limit on samples per replicate).
    std::function<void(const SamplingPlan&)> check_sampling;
};

// NAME=FILE or FILE (named after its stem), the name checked by check_candidate_name. `option`: how
// the caller names the option in the message.
std::pair<std::string, std::string> named_file(const std::string& option, const std::string& text);

// A representation file, or a preset's name (no such file: baked here with the exact method), as a
// candidate: its own cost model with the ALU counted from its GLSL like every other candidate's; bake()
// writes its texture (HALF, as an engine uploads it) and its GLSL/HLSL.
Candidate representation_candidate(const std::string& name, const std::string& file, const std::string& option);

// A reference spec parsed and its sampling checked in full (check_sampling: the caller's own check of a
// sampled plan, may be empty).
ReferenceDefinition checked_definition(const std::string& spec, const std::string& backend_label,
                                       const std::function<void(const SamplingPlan&)>& check_sampling = {},
                                       const ocl::BuildConfig& build = {});

// What the study found: per candidate (in candidate order) its metrics, its points outside its domain
// and its errors per roughness band; the Pareto front, the chosen candidate and the table's order.
struct StudyResult {
    std::vector<Metrics> metrics;
    std::vector<DomainCount> outside;
    std::vector<std::vector<Metrics>> by_roughness;
    std::vector<double> roughness_edges{0.0, 0.2, 0.4, 0.6, 0.8, 1.0};
    std::vector<std::size_t> front;
    std::size_t chosen = 0;
    std::vector<std::size_t> order;  // by weighted RMS, ties in candidate order (pareto.csv's rows)
};

class Study {
public:
    // Checks everything that needs no reference before any work: both reference specs (their sampling,
    // the same AO weighting), every candidate file or preset, the names (unique, also against the fits to
    // come) and the choice. Throws std::invalid_argument naming the option and value.
    explicit Study(StudySpec spec);

    const StudySpec& spec() const { return spec_; }
    const ReferenceDefinition& evaluation_definition() const { return evaluation_; }
    const ReferenceDefinition* fit_definition() const { return fit_ ? &*fit_ : nullptr; }
    const std::vector<Candidate>& candidates() const { return candidates_; }
    // The fits' provenance (design.json's "fits").
    const nlohmann::json& fits() const { return fits_; }

    // Fits a closed form of every fit order to the training set and adds it as a candidate.
    void add_fits(const ReferenceSet& training);

    // Judges every candidate on the evaluation set. warn: a candidate with points outside its domain
    // (refused instead with strict_domain); progress: (candidates done, candidates). Throws
    // std::invalid_argument for a choice over the budget or no candidate inside it, ms::Cancelled.
    StudyResult judge(const ReferenceSet& set, const std::function<void(const std::string&)>& warn = {},
                      const std::function<void(std::size_t, std::size_t)>& progress = {}) const;

    // The outputs' contents.
    std::string pareto_markdown(const StudyResult& result) const;  // the candidates' table
    std::string pareto_csv(const StudyResult& result) const;
    std::string roughness_bands_markdown(const StudyResult& result) const;
    // "reference 'NAME': N points, term std error max X, RMS Y"
    static std::string reference_summary(const ReferenceSet& set);
    nlohmann::json metadata(const StudyResult& result, const ReferenceSet& set) const;

    // The files a study writes into `dir`, added to `outputs` before any work so a bad destination is
    // refused first.
    struct Files {
        std::size_t csv = 0, markdown = 0, json = 0;
    };
    static Files add_outputs(OutputSet& outputs, const std::string& dir);
    // Writes pareto.csv, pareto.md, design.json and the chosen candidate's files (OUT/chosen-NAME.*)
    // into the entries' temporaries (the caller commits). Returns the chosen files' prefix, or "" when
    // the chosen candidate is a formula with nothing to bake.
    std::string write(OutputSet& outputs, const Files& files, const std::string& dir, const StudyResult& result,
                      const ReferenceSet& set) const;

private:
    void check_unique_names() const;
    StudySpec spec_;
    ReferenceDefinition evaluation_;
    std::optional<ReferenceDefinition> fit_;
    std::vector<Candidate> candidates_;
    nlohmann::json fits_ = nlohmann::json::array();
};

}  // namespace ms::design
