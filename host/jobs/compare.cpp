#include "jobs/compare.hpp"

#include "io/text.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "core/query.hpp"
#include "jobs/design.hpp"
#include "lut/shader/alu_count.hpp"
#include "lut/shader/shader_gen.hpp"

namespace ms::compare {

double isotropic_roughness(double alpha_x, double alpha_y) { return std::sqrt(std::sqrt(alpha_x * alpha_y)); }

ComparatorInputs inputs_of(const Query& q, AoWeighting weighting) {
    const Query n = normalised(q);
    ComparatorInputs in;
    in.visibility = q.visibility;
    in.n_dot_l = n.wo.z;
    in.n_dot_v = n.wi.z;
    in.roughness = isotropic_roughness(q.alpha_x, q.alpha_y);
    in.weighting = weighting;
    // atan2 of the cross and dot products of the projections: robust for any lengths, in [0, pi].
    const double dot = n.wi.x * n.wo.x + n.wi.y * n.wo.y;
    const double cross = n.wi.x * n.wo.y - n.wi.y * n.wo.x;
    in.relative_azimuth = (dot == 0 && cross == 0) ? 0.0 : std::atan2(std::fabs(cross), dot);
    return in;
}

double analytic_value(analytic::AnalyticTerm t, const ComparatorInputs& c) {
    analytic::AnalyticInputs in;
    in.visibility = c.visibility;
    in.n_dot_l = c.n_dot_l;
    in.n_dot_v = c.n_dot_v;
    in.ao_weighting = c.weighting;
    // Activision's own non-standard roughness of the GGX alpha; the other terms ignore roughness.
    in.roughness = t == analytic::AnalyticTerm::activision_adjusted
                       ? analytic::activision_roughness_from_alpha(c.roughness * c.roughness)
                       : 0.5;
    return analytic::evaluate(t, in);
}

double lut_value(const sweep::LutLookup& lut, const ComparatorInputs& in) {
    return lut(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness);
}

namespace {

FileComparatorOpener& file_comparator_opener() {
    static FileComparatorOpener opener;
    return opener;
}

// Not an analytic term's name: a path (a '/' or '.'), or an existing file.
bool looks_like_file(const std::string& s) {
    for (auto t : analytic::kAllAnalyticTerms)
        if (to_string(t) == s) return false;
    std::error_code ec;
    return s.find('/') != std::string::npos || s.find('.') != std::string::npos || std::filesystem::exists(s, ec);
}

NamedComparatorOpener& named_comparator_opener() {
    static NamedComparatorOpener opener;
    return opener;
}
std::string& named_comparator_names() {
    static std::string names;
    return names;
}

}  // namespace

void set_file_comparator_opener(FileComparatorOpener opener) { file_comparator_opener() = std::move(opener); }
void set_named_comparator_opener(NamedComparatorOpener opener) { named_comparator_opener() = std::move(opener); }
void set_named_comparator_names(std::string names) { named_comparator_names() = std::move(names); }

Comparator Comparator::open_named(const std::string& column, const std::string& name) {
    Comparator c;
    c.name_ = column;
    c.file_ = "preset:" + name;
    if (const auto& open = named_comparator_opener())
        if ((c.file_comparator_ = open(name))) return c;
    throw std::invalid_argument("no representation preset '" + name + "'" +
                                (named_comparator_names().empty() ? std::string() : " (presets: " + named_comparator_names() + ")"));
}

std::string analytic_term_names() {
    std::string s;
    for (auto t : analytic::kAllAnalyticTerms) s += (s.empty() ? "" : ", ") + to_string(t);
    return s;
}

std::string closest_analytic_term(const std::string& word) {
    std::string best;
    // As the CLI's option suggestions: a few edits, and fewer than half the word's letters.
    std::size_t best_distance = std::min<std::size_t>(4, word.size() / 2 + 1);
    for (auto t : analytic::kAllAnalyticTerms) {
        const std::string name = to_string(t);
        const std::size_t d = edit_distance(word, name);
        if (d < best_distance) best = name, best_distance = d;
    }
    return best;
}

Comparator Comparator::parse(const std::string& argument) {
    Comparator c;
    std::string name, file;
    const auto eq = argument.find('=');
    if (eq != std::string::npos) {
        name = argument.substr(0, eq);
        file = argument.substr(eq + 1);
        if (name.empty() || file.empty())
            throw std::invalid_argument("--compare " + argument + ": expected NAME, FILE or NAME=FILE");
    } else if (looks_like_file(argument)) {
        file = argument;
        name = std::filesystem::path(file).stem().string();
    } else {
        name = argument;
    }
    c.name_ = name;
    if (file.empty()) {
        for (auto t : analytic::kAllAnalyticTerms)
            if (to_string(t) == name) {
                c.term_ = t;
                return c;
            }
        // A representation preset by name (baked now, in memory).
        if (const auto& open = named_comparator_opener())
            if (auto named = open(name)) {
                c.file_ = "preset:" + name;
                c.file_comparator_ = std::move(named);
                return c;
            }
        const std::string close = closest_analytic_term(name);
        throw std::invalid_argument("--compare: no analytic term '" + name + "' (valid: " + analytic_term_names() +
                                    (named_comparator_names().empty() ? std::string() : "; presets: " + named_comparator_names()) +
                                    "; or a LUT file, or NAME=FILE)" + (close.empty() ? "" : "; did you mean " + close + "?"));
    }
    if (name.empty()) throw std::invalid_argument("--compare " + argument + ": the file stem gives no column name; use NAME=FILE");
    if (name.find(',') != std::string::npos || name.find('"') != std::string::npos || name.find('\n') != std::string::npos)
        throw std::invalid_argument("--compare " + argument + ": column name '" + name + "' holds a comma, quote or line break");
    try {
        return open_file(name, file);
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string("--compare: ") + e.what());
    }
}

Comparator Comparator::open_file(const std::string& name, const std::string& file) {
    Comparator c;
    c.name_ = name;
    c.file_ = file;
    // The opener answers null for a file that is not of its kinds (then it is read as a LUT).
    if (const auto& open = file_comparator_opener())
        if ((c.file_comparator_ = open(file))) return c;
    c.lut_ = std::make_shared<const sweep::LutLookup>(sweep::LutLookup::open(file));
    return c;
}

std::optional<ComparatorCost> Comparator::cost() const {
    if (file_comparator_) return file_comparator_->cost();
    ComparatorCost c;
    if (!lut_) {  // part 1's formula: no texture, no fetch
        c.alu_per_light = lutshader::count_alu(design::analytic_glsl(term_));
        c.storage = "none (part 1's formula)";
        return c;
    }
    // Part 2's LUT as an engine ships it: R16F, RG16F, or RGBA16F for three or four channels (no RGB16F
    // on most GPUs), one filtered fetch, and the ALU of the shader `microshadow shader` generates for it.
    const auto& f = lut_->file();
    const std::uint64_t channels = f.channels.size() <= 2 ? f.channels.size() : 4;
    c.bytes = std::uint64_t(f.width) * f.height * channels * 2;
    c.fetches_per_light = 1;
    c.alu_per_light = lutshader::count_alu(lutshader::generate_shader(f, lutshader::ShaderLanguage::glsl, file_));
    const bool three_d = f.n_dot_v().count > 1;
    c.storage = std::string(three_d ? "3D" : "2D") + " texture " + std::to_string(f.visibility().count) + "x" +
                std::to_string(f.n_dot_l().count) + (three_d ? "x" + std::to_string(f.n_dot_v().count) : "") + " " +
                (channels == 1 ? "R16F" : channels == 2 ? "RG16F" : "RGBA16F");
    return c;
}

double Comparator::operator()(const ComparatorInputs& in) const {
    if (file_comparator_) return (*file_comparator_)(in);
    return lut_ ? lut_value(*lut_, in) : analytic_value(term_, in);
}

std::optional<LookupDomain> Comparator::domain() const {
    if (file_comparator_) return file_comparator_->domain();
    if (lut_) return lut_->domain();
    return std::nullopt;
}

bool Comparator::in_domain(const ComparatorInputs& in) const {
    const auto d = domain();
    return !d || d->contains(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness);
}

nlohmann::json domain_report(const std::optional<LookupDomain>& domain, const DomainTally& tally) {
    return {{"domain", domain ? domain->to_json() : nlohmann::json(nullptr)},
            {"lookups", tally.lookups},
            {"outside_domain", tally.outside}};
}

void refuse_outside_domain(const std::string& where, const std::string& name, const LookupDomain& domain,
                           const DomainTally& tally, const std::string& first_outside) {
    if (tally.outside == 0) return;
    throw std::invalid_argument(where + ": --strict-domain: comparator " + name + ": " + std::to_string(tally.outside) + " of " +
                                std::to_string(tally.lookups) + " lookups outside its domain (" + domain.describe() +
                                "), e.g. " + first_outside);
}

nlohmann::json Comparator::provenance() const {
    if (file_comparator_) {
        nlohmann::json j = file_comparator_->provenance();
        j["name"] = name_;
        j["file"] = file_;
        if (const auto d = domain()) j["domain"] = d->to_json();
        return j;
    }
    nlohmann::json j = lut_ ? nlohmann::json{{"name", name_}, {"kind", "lut"}, {"file", file_}}
                            : nlohmann::json{{"name", name_}, {"kind", "analytic"}, {"term", to_string(term_)}};
    if (const auto c = cost())
        j["cost"] = {{"bytes", c->bytes}, {"fetches_per_light", c->fetches_per_light}, {"alu_per_light", c->alu_per_light},
                     {"storage", c->storage}};
    if (!lut_) return j;
    j["domain"] = lut_->domain().to_json();
    const auto& meta = lut_->file().metadata;
    for (const char* key : {"version", "command_line"})
        if (meta.is_object() && meta.contains(key)) j[key] = meta[key];
    return j;
}

std::vector<Comparator> parse_comparators(const std::vector<std::string>& arguments,
                                          const std::vector<std::string>& taken) {
    std::vector<Comparator> out;
    std::set<std::string> names(taken.begin(), taken.end());
    auto claim = [&](const std::string& n) {
        if (!names.insert(n).second)
            throw std::invalid_argument("--compare: duplicate column name '" + n + "'; name it with NAME=FILE");
    };
    for (const auto& a : arguments) {
        out.push_back(Comparator::parse(a));
        claim(out.back().name());
        claim(out.back().name() + "_error");
    }
    return out;
}

void ErrorSummary::add(double e, double n_dot_l) {
    ++count;
    max_abs = std::max(max_abs, std::abs(e));
    sum_sq += e * e;
    const double w = std::max(n_dot_l, 0.0);
    weighted_sq += w * e * e;
    weight += w;
}

double ErrorSummary::rms() const { return count ? std::sqrt(sum_sq / double(count)) : 0; }
double ErrorSummary::weighted_rms() const { return weight > 0 ? std::sqrt(weighted_sq / weight) : 0; }

}  // namespace ms::compare
