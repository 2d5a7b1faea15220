#include "jobs/compare.hpp"

#include "io/text.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "approx/analytic.hpp"
#include "approx/lut.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/presets.hpp"

namespace ms::compare {

namespace {

std::string preset_list() {
    std::string names;
    for (const auto& n : repr::preset_names()) names += (names.empty() ? "" : ", ") + n;
    return names;
}

// Not an analytic term's name: a path (a '/' or '.'), or an existing file.
bool looks_like_file(const std::string& s) {
    for (auto t : analytic::kAllAnalyticTerms)
        if (to_string(t) == s) return false;
    std::error_code ec;
    return s.find('/') != std::string::npos || s.find('.') != std::string::npos || std::filesystem::exists(s, ec);
}

}  // namespace

Comparator Comparator::open_named(const std::string& column, const std::string& name) {
    if (!repr::is_preset(name))
        throw std::invalid_argument("no representation preset '" + name + "' (presets: " + preset_list() + ")");
    Comparator c;
    c.name_ = column;
    c.file_ = "preset:" + name;
    c.approximation_ = repr::baked_preset(name);
    return c;
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
        if (const auto t = approx::analytic_term_named(name)) {
            c.approximation_ = approx::analytic_approximation(*t);
            return c;
        }
        // A representation preset by name (baked now, in memory).
        if (repr::is_preset(name)) return open_named(name, name);
        const std::string close = approx::closest_analytic_term(name);
        throw std::invalid_argument("--compare: no analytic term '" + name + "' (valid: " + approx::analytic_term_names() +
                                    "; presets: " + preset_list() + "; or a LUT file, or NAME=FILE)" +
                                    (close.empty() ? "" : "; did you mean " + close + "?"));
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
    if (repr::is_representation_file(file))
        c.approximation_ = repr::open_representation(file);
    else
        c.approximation_ = approx::open_lut(file);
    return c;
}

bool Comparator::in_domain(const approx::Inputs& in) const {
    const auto d = domain();
    return !d || d->contains(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
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
    nlohmann::json j = approximation_->provenance();
    j["name"] = name_;
    if (!file_.empty()) j["file"] = file_;
    if (const auto d = domain()) j["domain"] = d->to_json();
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

}  // namespace ms::compare
