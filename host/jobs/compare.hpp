// Comparators of the generic term: part 1's analytic terms (analytic/part1_terms.hpp) and baked LUTs
// read through sweep::LutLookup, evaluated at (visibility, NdotL, NdotV, roughness). Sweeps
// (jobs/sweep/runner.cpp) and `microshadow eval --compare` both compute their columns here.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analytic/part1_terms.hpp"
#include "core/lookup_domain.hpp"
#include "core/query.hpp"
#include "core/types.hpp"
#include "lut/lookup.hpp"

namespace ms::compare {

// What every comparator reads. roughness is the perceptual roughness (alpha = roughness^2); for an
// anisotropic query the isotropic equivalent (see isotropic_roughness).
struct ComparatorInputs {
    double visibility = 1;
    double n_dot_l = 1;
    double n_dot_v = 1;
    double roughness = 0.5;
    AoWeighting weighting = AoWeighting::cosine;
    // The relative azimuth between the projections of V and L on the surface, in radians in [0, pi]
    // (0: L on V's side, pi: opposite). Part 2's LUTs and part 1's terms ignore it; representations
    // that keep the azimuth read it. 0 when either direction is along the normal.
    double relative_azimuth = 0;
};

// What a comparator costs a renderer per light: texture memory, filtered fetches and an ALU estimate
// (arithmetic instructions of its shader after the fetches, counted from the generated code).
struct ComparatorCost {
    std::uint64_t bytes = 0;
    unsigned fetches_per_light = 0;
    unsigned alu_per_light = 0;
    std::string storage;  // e.g. "3D texture 32x32x32 RGBA16F"
};

// A comparator read from a file that is not a part 2 LUT: host/repr/'s representations (which keep the
// relative azimuth). jobs cannot include repr (that layer sits above it), so repr installs an opener
// here (repr::install_comparators(); the CLI calls it at start-up) and Comparator::parse asks it first.
class FileComparator {
public:
    virtual ~FileComparator() = default;
    virtual std::string name() const = 0;
    virtual ComparatorCost cost() const = 0;
    virtual double operator()(const ComparatorInputs& in) const = 0;
    virtual nlohmann::json provenance() const = 0;
    // Where the file answers as its measured errors say (its metadata's "domain"); none: everywhere.
    virtual std::optional<LookupDomain> domain() const { return std::nullopt; }
};
// Returns null when `path` is not a file of its kinds; throws std::runtime_error for one it cannot read.
using FileComparatorOpener = std::function<std::shared_ptr<const FileComparator>(const std::string& path)>;
void set_file_comparator_opener(FileComparatorOpener opener);
// The same for a named comparator that is no file (host/repr/'s presets, baked when opened): null when
// `name` is not one of its names.
using NamedComparatorOpener = std::function<std::shared_ptr<const FileComparator>(const std::string& name)>;
void set_named_comparator_opener(NamedComparatorOpener opener);
// The names the named opener takes ("" when none is installed), for messages.
void set_named_comparator_names(std::string names);

// The isotropic-equivalent roughness of (alpha_x, alpha_y): (alpha_x alpha_y)^(1/4), the square root
// of the geometric-mean alpha (it keeps the area of the slope distribution's footprint).
double isotropic_roughness(double alpha_x, double alpha_y);

// The comparator inputs of an eval query: NdotV = wi_z and NdotL = wo_z of the normalised
// directions, roughness = isotropic_roughness(alpha_x, alpha_y), relative_azimuth = the angle between
// the tangent-plane projections of wi and wo.
ComparatorInputs inputs_of(const Query& q, AoWeighting weighting);

// Part 1's term `t` at `in`. Activision's adjusted term reads its own non-standard roughness of the
// GGX alpha roughness^2 (analytic::activision_roughness_from_alpha; std::domain_error for alpha
// outside (0, sqrt 2)); the other terms ignore roughness.
double analytic_value(analytic::AnalyticTerm t, const ComparatorInputs& in);

// A LUT's renderer-style lookup at `in` (the LUT knows no AO weighting: it was baked with one).
double lut_value(const sweep::LutLookup& lut, const ComparatorInputs& in);

// One comparator column of `eval --compare`.
class Comparator {
public:
    // NAME (an analytic term or a representation preset, baked when opened), FILE (a LUT, the column
    // named after the file stem) or NAME=FILE.
    // Throws std::invalid_argument: an unknown name (listing the valid ones, with "did you mean" when
    // one is close) or an unreadable LUT (read_lut's message).
    static Comparator parse(const std::string& argument);
    // The comparator of a file under a given column name: a representation file (through the installed
    // opener, set_file_comparator_opener) or else a part 2 LUT. Sweeps open their [[comparators.lut]]
    // files here, so a spec names a representation exactly as it names a LUT. Throws std::runtime_error
    // naming the file (read_lut's or the opener's message).
    static Comparator open_file(const std::string& name, const std::string& file);
    // A named comparator that is no file (a representation preset, "full-range"), under a column name.
    // Throws std::invalid_argument for a name the installed opener does not know.
    static Comparator open_named(const std::string& column, const std::string& name);

    const std::string& name() const { return name_; }
    bool is_lut() const { return lut_ != nullptr; }
    bool is_representation() const { return file_comparator_ != nullptr; }
    // A representation's cost (its own model); a LUT's as an engine uploads it (R16F, RG16F or RGBA16F,
    // one fetch, the ALU of its generated shader); an analytic term's: no texture, no fetch, the ALU of
    // its GLSL (jobs/design.hpp's analytic_glsl). ALU by lut/shader/alu_count.hpp for all.
    std::optional<ComparatorCost> cost() const;
    double operator()(const ComparatorInputs& in) const;
    // A file's domain (a LUT's or a representation's; core/lookup_domain.hpp); none for part 1's formulas,
    // which answer everywhere.
    std::optional<LookupDomain> domain() const;
    // True when `in` lies inside the domain (always without one).
    bool in_domain(const ComparatorInputs& in) const;
    // {name, kind, term} or {name, kind, file, version, command_line} (the LUT metadata's, when present).
    nlohmann::json provenance() const;

private:
    std::string name_;
    analytic::AnalyticTerm term_ = analytic::AnalyticTerm::reference_step;
    std::string file_;
    std::shared_ptr<const sweep::LutLookup> lut_;
    std::shared_ptr<const FileComparator> file_comparator_;
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

// The analytic term names, comma-separated, and the closest one to `word` ("" when none is close).
std::string analytic_term_names();
std::string closest_analytic_term(const std::string& word);

// Error statistics of one comparator against the term: max |e|, RMS and the NdotL-weighted RMS
// sqrt(sum w e^2 / sum w) with w = max(NdotL, 0) (0 when every weight is 0).
struct ErrorSummary {
    std::size_t count = 0;
    double max_abs = 0, sum_sq = 0, weighted_sq = 0, weight = 0;
    void add(double error, double n_dot_l);
    double rms() const;
    double weighted_rms() const;
};

}  // namespace ms::compare
