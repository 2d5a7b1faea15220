// Comparators: the approximations (approx/approximation.hpp) a study judges against the term, each
// under a column name, opened by name (part 1's terms, representation presets) or by file (LUTs and
// representations in every format the tool writes). eval --compare, sweeps, scenes and design open
// them here.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "approx/approximation.hpp"
#include "core/lookup_domain.hpp"

namespace ms::compare {

// One comparator column: a name and the approximation it judges.
class Comparator {
public:
    // NAME (an analytic term or a representation preset, baked when opened), FILE (a LUT or a
    // representation, the column named after the file stem) or NAME=FILE.
    // Throws std::invalid_argument: an unknown name (listing the valid ones, with "did you mean" when
    // one is close) or an unreadable file (its reader's message).
    static Comparator parse(const std::string& argument);
    // The comparator of a file under a given column name: a representation file (OpenEXR, KTX2 or DDS
    // whose metadata says so) or else a part 2 LUT in any format the bake writes. Sweeps open their
    // [[comparators.lut]] files here, so a spec names a representation exactly as it names a LUT.
    // Throws std::runtime_error naming the file.
    static Comparator open_file(const std::string& name, const std::string& file);
    // A named comparator that is no file (a representation preset, "full-range"), under a column name.
    // Throws std::invalid_argument for a name that is no preset.
    static Comparator open_named(const std::string& column, const std::string& name);

    const std::string& name() const { return name_; }
    const approx::Approximation& approximation() const { return *approximation_; }
    std::shared_ptr<const approx::Approximation> shared_approximation() const { return approximation_; }
    bool is_lut() const { return approximation_->kind() == "lut"; }
    bool is_representation() const { return !is_lut() && approximation_->kind() != "analytic"; }
    // Its cost as an engine ships it (approx::Approximation::cost).
    approx::Cost cost() const { return approximation_->cost(); }
    double operator()(const approx::Inputs& in) const { return (*approximation_)(in); }
    // A file's domain (a LUT's or a representation's; core/lookup_domain.hpp); none for part 1's formulas,
    // which answer everywhere.
    std::optional<LookupDomain> domain() const { return approximation_->domain(); }
    // True when `in` lies inside the domain (always without one).
    bool in_domain(const approx::Inputs& in) const;
    // The approximation's provenance with the column's name and file ({name, kind, term} or
    // {name, kind, file, version, command_line, ...}).
    nlohmann::json provenance() const;

private:
    std::string name_;
    std::string file_;  // "" for part 1's terms, "preset:NAME" for a preset
    std::shared_ptr<const approx::Approximation> approximation_;
};

// Every argument parsed, in order; column names must be unique and differ from `taken` (the other
// columns of the output, including each comparator's "<name>_error"). Throws std::invalid_argument.
std::vector<Comparator> parse_comparators(const std::vector<std::string>& arguments,
                                          const std::vector<std::string>& taken);

// The per-comparator record of lookups outside the domain that eval, sweeps, scenes and design write:
// {"domain": {...} or null, "lookups": N, "outside_domain": M}.
nlohmann::json domain_report(const std::optional<LookupDomain>& domain, const DomainTally& tally);
// Refuses, with --strict-domain, a comparator that looked up outside its domain: std::invalid_argument
// "<where>: --strict-domain: comparator NAME: M of N lookups outside its domain (...), e.g. <first>".
// Does nothing when tally.outside is 0.
void refuse_outside_domain(const std::string& where, const std::string& name, const LookupDomain& domain,
                           const DomainTally& tally, const std::string& first_outside);

}  // namespace ms::compare
