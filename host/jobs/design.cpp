#include "approx/analytic.hpp"
#include "jobs/design.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "io/csv.hpp"
#include "io/text.hpp"
#include "approx/lut.hpp"
#include "lut/shader/compose.hpp"
#include "lut/shader/shader_gen.hpp"

namespace ms::design {

void check_candidate_name(const std::string& name) {
    auto refuse = [&](const std::string& why) {
        std::string shown;  // one line whatever the name holds: other bytes as \xHH
        for (unsigned char ch : name) {
            char code[8];
            std::snprintf(code, sizeof code, "\\x%02x", ch);
            shown += ch >= 0x20 && ch < 0x7f ? std::string(1, char(ch)) : std::string(code);
        }
        throw std::invalid_argument("candidate name '" + shown + "': " + why +
                                    " (names are 1 to 64 letters, digits, '.', '_', '+' or '-', not starting with '.' or '-')");
    };
    if (name.empty() || name.size() > 64) refuse("length " + std::to_string(name.size()));
    if (name[0] == '.' || name[0] == '-') refuse("starts with '" + std::string(1, name[0]) + "'");
    for (std::size_t i = 0; i < name.size(); ++i) {
        const unsigned char ch = static_cast<unsigned char>(name[i]);
        if (std::isalnum(ch) || ch == '.' || ch == '_' || ch == '+' || ch == '-') continue;
        char code[8];
        std::snprintf(code, sizeof code, "0x%02x", ch);
        refuse("character " + std::to_string(i + 1) + " (" + code + ") is not allowed");
    }
}

approx::Inputs inputs_of(const ReferencePoint& p, AoWeighting weighting) {
    approx::Inputs in;
    in.visibility = p.visibility;
    in.n_dot_l = p.n_dot_l;
    in.n_dot_v = p.n_dot_v;
    in.roughness = p.roughness;
    in.weighting = weighting;
    in.relative_azimuth = p.relative_azimuth;
    return in;
}

Metrics metrics_of(const ErrorStats& stats) {
    Metrics m;
    m.points = std::size_t(stats.count());
    m.max_abs = stats.max_abs();
    m.weighted_rms = stats.weighted_rms();
    m.weighted_p99 = stats.weighted_quantile(0.99);
    return m;
}

Metrics error_metrics(const std::vector<double>& errors, const std::vector<double>& weights) {
    if (errors.size() != weights.size()) throw std::invalid_argument("error_metrics: one weight per error");
    ErrorStats stats(ErrorStats::Keep::values);
    for (std::size_t i = 0; i < errors.size(); ++i)
        if (weights[i] > 0) stats.add(errors[i], weights[i]);
    return metrics_of(stats);
}

namespace {

// Errors (candidate - term) and weights (weight x NdotL) at every point of the set.
void errors_of(const Candidate& c, const ReferenceSet& set, std::vector<double>& errors, std::vector<double>& weights) {
    errors.assign(set.points.size(), 0);
    weights.assign(set.points.size(), 0);
    for (std::size_t i = 0; i < set.points.size(); ++i) {
        const ReferencePoint& p = set.points[i];
        weights[i] = p.weight * std::max(p.n_dot_l, 0.0);
        try {
            errors[i] = c.value(inputs_of(p, set.definition.options.ao_weighting)) - set.values[i].term;
        } catch (const std::domain_error& e) {
            throw std::invalid_argument("candidate " + c.name + " cannot take reference point " + std::to_string(i + 1) +
                                        " (roughness " + format_number(p.roughness) + "): " + e.what());
        }
    }
}

}  // namespace

DomainCount count_outside_domain(const Candidate& c, const ReferenceSet& set) {
    DomainCount out;
    if (!c.domain) return out;
    for (std::size_t i = 0; i < set.points.size(); ++i) {
        const ReferencePoint& p = set.points[i];
        const bool inside = c.domain->contains(p.visibility, p.n_dot_l, p.n_dot_v, p.roughness);
        out.tally.add(inside);
        if (!inside && out.first_outside.empty())
            out.first_outside = "reference point " + std::to_string(i + 1) + ": " +
                                c.domain->first_outside(p.visibility, p.n_dot_l, p.n_dot_v, p.roughness);
    }
    return out;
}

Metrics evaluate_candidate(const Candidate& c, const ReferenceSet& set) {
    std::vector<double> errors, weights;
    errors_of(c, set, errors, weights);
    return error_metrics(errors, weights);
}

std::vector<std::pair<std::size_t, double>> worst_points(const Candidate& c, const ReferenceSet& set, std::size_t count) {
    std::vector<double> errors, weights;
    errors_of(c, set, errors, weights);
    std::vector<std::pair<std::size_t, double>> out;
    for (std::size_t i = 0; i < errors.size(); ++i)
        if (weights[i] > 0) out.emplace_back(i, errors[i]);
    const std::size_t k = std::min(count, out.size());
    std::partial_sort(out.begin(), out.begin() + std::ptrdiff_t(k), out.end(),
                      [](const auto& a, const auto& b) { return std::fabs(a.second) > std::fabs(b.second); });
    out.resize(k);
    return out;
}

std::vector<Metrics> evaluate_candidate_by_roughness(const Candidate& c, const ReferenceSet& set,
                                                     const std::vector<double>& edges) {
    std::vector<double> errors, weights;
    errors_of(c, set, errors, weights);
    const std::size_t bands = edges.size() < 2 ? 0 : edges.size() - 1;
    GroupedErrorStats by_band(1, bands, ErrorStats::Keep::values);
    for (std::size_t i = 0; i < errors.size(); ++i) {
        if (!(weights[i] > 0)) continue;
        const double r = set.points[i].roughness;
        for (std::size_t k = 0; k < bands; ++k) {
            const bool last = k + 1 == bands;
            if (r >= edges[k] && (r < edges[k + 1] || (last && r == edges[k + 1]))) by_band.at(0, k).add(errors[i], weights[i]);
        }
    }
    std::vector<Metrics> out;
    for (std::size_t k = 0; k < bands; ++k) out.push_back(metrics_of(by_band.at(0, k)));
    return out;
}

std::vector<std::size_t> pareto_front(const std::vector<Candidate>& candidates, const std::vector<Metrics>& metrics) {
    auto no_worse = [&](std::size_t a, std::size_t b) {  // a is at least as good as b everywhere
        const auto &ca = candidates[a].cost, &cb = candidates[b].cost;
        return metrics[a].weighted_rms <= metrics[b].weighted_rms && ca.bytes <= cb.bytes &&
               ca.fetches_per_light <= cb.fetches_per_light && ca.alu_per_light <= cb.alu_per_light;
    };
    auto better = [&](std::size_t a, std::size_t b) {
        const auto &ca = candidates[a].cost, &cb = candidates[b].cost;
        return metrics[a].weighted_rms < metrics[b].weighted_rms || ca.bytes < cb.bytes ||
               ca.fetches_per_light < cb.fetches_per_light || ca.alu_per_light < cb.alu_per_light;
    };
    std::vector<std::size_t> front;
    for (std::size_t b = 0; b < candidates.size(); ++b) {
        bool dominated = false;
        for (std::size_t a = 0; a < candidates.size() && !dominated; ++a)
            dominated = a != b && no_worse(a, b) && better(a, b);
        if (!dominated) front.push_back(b);
    }
    return front;
}

std::size_t choose(const std::vector<Candidate>& candidates, const std::vector<Metrics>& metrics, const Budget& budget) {
    std::size_t best = candidates.size();
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        if (!budget.fits(candidates[i].cost)) continue;
        if (best == candidates.size()) {
            best = i;
            continue;
        }
        const auto key = [&](std::size_t k) {
            return std::make_tuple(metrics[k].weighted_rms, candidates[k].cost.bytes, candidates[k].cost.alu_per_light);
        };
        if (key(i) < key(best)) best = i;
    }
    if (best == candidates.size()) {
        std::size_t cheapest = 0;
        for (std::size_t i = 1; i < candidates.size(); ++i)
            if (candidates[i].cost.bytes < candidates[cheapest].cost.bytes) cheapest = i;
        std::string why = "no candidate fits the budget";
        if (!candidates.empty())
            why += " (the smallest, " + candidates[cheapest].name + ", needs " +
                   std::to_string(candidates[cheapest].cost.bytes) + " bytes, " +
                   std::to_string(candidates[cheapest].cost.fetches_per_light) + " fetches and " +
                   std::to_string(candidates[cheapest].cost.alu_per_light) + " ALU per light)";
        throw std::invalid_argument(why);
    }
    return best;
}

std::vector<Candidate> analytic_candidates(AoWeighting weighting) {
    std::vector<Candidate> out;
    for (auto t : analytic::kAllAnalyticTerms) {
        Candidate c;
        c.name = analytic::to_string(t);
        c.kind = "analytic";
        c.cost.alu_per_light = count_alu(approx::analytic_glsl(t));
        c.cost.storage = "none (part 1's formula)";
        c.value = [t, weighting](const approx::Inputs& in) {
            approx::Inputs w = in;
            w.weighting = weighting;
            return approx::analytic_value(t, w);
        };
        c.provenance = {{"name", c.name}, {"kind", "analytic"}, {"term", c.name}};
        out.push_back(std::move(c));
    }
    return out;
}

Candidate lut_candidate(const std::string& name, const std::string& file) {
    std::shared_ptr<const LutLookup> lut;
    try {
        lut = std::make_shared<const LutLookup>(LutLookup::open(file));
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string("--lut ") + file + ": " + e.what());
    }
    const LutFile& f = lut->file();
    Candidate c;
    c.name = name;
    c.kind = "lut";
    // The LUT's cost model is the comparator's (compare::Comparator::cost): one for eval, sweeps and design.
    c.cost = compare::Comparator::open_file(name, file).cost();
    c.value = [lut](const approx::Inputs& in) { return approx::lut_value(*lut, in); };
    c.domain = lut->domain();
    c.provenance = {{"name", name}, {"kind", "lut"}, {"file", json_safe(file)}};
    for (const char* key : {"version", "command_line"})
        if (f.metadata.is_object() && f.metadata.contains(key)) c.provenance[key] = f.metadata[key];
    c.bake = [lut, file](OutputSet& outputs, const std::string& prefix) {
        std::ifstream in(file, std::ios::binary);
        if (!in) throw std::runtime_error(file + ": cannot open for reading");
        std::ostringstream bytes;
        bytes << in.rdbuf();
        outputs.stream(outputs.add(prefix + ".exr", true)) << bytes.str();
        const std::string source = std::filesystem::path(prefix + ".exr").filename().string();
        for (const auto language : {lutshader::ShaderLanguage::glsl, lutshader::ShaderLanguage::hlsl})
            outputs.stream(outputs.add(prefix + "." + lutshader::to_string(language)))
                << lutshader::compose(lutshader::generate_shader(lut->file(), language, source), language, lutshader::default_prefix(prefix + ".glsl"));
    };
    return c;
}

}  // namespace ms::design
