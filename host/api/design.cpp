// microshadow::design: `microshadow design` (cli/cmd_design.cpp) as a call that returns its tables. The
// steps are the command's, in its order, on the same jobs (jobs/design.hpp, reference_set.hpp,
// design_closed_form.hpp): every candidate and both reference specs are checked before any work, the
// reference sets come from the same cache, and the table is sorted as pareto.csv.
#include "microshadow/design.hpp"

#include <algorithm>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "api/facade.hpp"
#include "core/cancel.hpp"
#include "fit/closed_form.hpp"
#include "jobs/design.hpp"
#include "jobs/design_closed_form.hpp"
#include "jobs/reference_set.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"

namespace microshadow {

namespace {

namespace fs = std::filesystem;
namespace design = ms::design;

const char* const kCommandLine = "microshadow::design (library " MICROSHADOW_VERSION ")";

// NAME=FILE or FILE (named after its stem), the name checked as the command checks it.
std::pair<std::string, std::string> named_file(const std::string& option, const std::string& text) {
    const auto eq = text.find('=');
    const std::string file = eq == std::string::npos ? text : text.substr(eq + 1);
    const std::string name = eq == std::string::npos ? fs::path(text).stem().string() : text.substr(0, eq);
    if (name.empty() || file.empty()) throw std::invalid_argument(option + " " + text + ": expected FILE or NAME=FILE");
    try {
        design::check_candidate_name(name);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(option + " " + text + ": " + e.what() +
                                    (eq == std::string::npos ? " (the name is the file's stem: give one with NAME=FILE)" : ""));
    }
    return {name, file};
}

// A representation file, or a preset's name (baked here with the exact method), as a candidate: its
// own cost model with the ALU counted from its GLSL like every other candidate's.
design::Candidate representation_candidate(const std::string& name, const std::string& file) {
    std::shared_ptr<const ms::repr::Representation> r;
    try {
        std::error_code ec;
        if (ms::repr::is_preset(file) && !fs::exists(file, ec)) {
            auto backend = ms::make_oracle_backend();
            r = ms::repr::bake_preset(ms::repr::preset(file), *backend, "preset " + file);
        } else {
            r = ms::repr::open_representation(file);
        }
    } catch (const std::exception& e) {
        throw std::invalid_argument("reprs " + file + ": " + e.what());
    }
    design::Candidate c;
    c.name = name;
    c.kind = r->kind();
    c.cost = r->cost();
    c.cost.alu_per_light = design::count_alu(r->shader(ms::repr::ShaderLanguage::glsl, file));
    c.value = [r](const ms::approx::Inputs& in) { return (*r)(in); };
    c.domain = r->domain();
    c.provenance = r->provenance();
    return c;
}

design::ReferenceDefinition checked_definition(const std::string& spec, Backend backend) {
    design::ReferenceDefinition def = design::parse_reference_spec_file(spec);
    def.backend_label = backend == Backend::oracle ? "oracle" : "opencl";
    try {
        design::check_plan(def);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(spec + ": [sampling]: " + e.what());
    }
    return def;
}

void check_unique_names(const std::vector<design::Candidate>& candidates) {
    std::set<std::string> names;
    for (const auto& c : candidates)
        if (!names.insert(c.name).second)
            throw std::invalid_argument("two candidates named '" + c.name + "'; name LUTs with NAME=FILE");
}

DesignMetrics to_public(const design::Metrics& m) { return {m.points, m.weighted_rms, m.weighted_p99, m.max_abs}; }

}  // namespace

DesignTable design(const DesignOptions& o, const Progress& progress) {
    if (o.reference.empty()) throw std::invalid_argument("microshadow::design: reference: the reference spec is required");
    design::Budget budget;
    budget.max_bytes = o.max_bytes;
    budget.max_fetches = o.max_fetches;
    budget.max_alu = o.max_alu;
    const bool has_fit = !o.fit_reference.empty();
    if (has_fit && o.fit_orders.empty()) throw std::invalid_argument("fit_orders: at least one order");
    for (unsigned order : o.fit_orders)
        if (order < 1 || order > ms::fit::kMaxClosedFormOrder)
            throw std::invalid_argument("fit_orders: " + std::to_string(order) + " (1 to " +
                                        std::to_string(ms::fit::kMaxClosedFormOrder) + ")");

    // Both specs and every candidate that needs no reference, before any work.
    const design::ReferenceDefinition evaluation_def = checked_definition(o.reference, o.backend);
    design::ReferenceDefinition fit_def;
    if (has_fit) {
        fit_def = checked_definition(o.fit_reference, o.backend);
        if (fit_def.options.ao_weighting != evaluation_def.options.ao_weighting)
            throw std::invalid_argument("fit_reference: its AO weighting differs from reference's");
    }
    std::vector<design::Candidate> candidates;
    if (o.analytic) candidates = design::analytic_candidates(evaluation_def.options.ao_weighting);
    for (const auto& l : o.luts) {
        const auto [name, file] = named_file("luts", l);
        candidates.push_back(design::lut_candidate(name, file));
    }
    for (const auto& l : o.reprs) {
        const auto [name, file] = named_file("reprs", l);
        candidates.push_back(representation_candidate(name, file));
    }
    for (const auto& f : o.closed_forms) candidates.push_back(design::closed_form_candidate(ms::fit::read_closed_form(f), f));
    if (candidates.empty() && !has_fit)
        throw std::invalid_argument("no candidates (analytic off, and no luts, reprs, closed_forms or fit_reference)");
    check_unique_names(candidates);
    std::vector<std::string> known;
    for (const auto& c : candidates) known.push_back(c.name);
    if (has_fit)
        for (unsigned order : o.fit_orders) {
            const std::string name = "closed-form-" + std::to_string(order);
            if (std::find(known.begin(), known.end(), name) != known.end())
                throw std::invalid_argument("two candidates named '" + name + "' (a closed_forms file and fit_orders " +
                                            std::to_string(order) + ")");
            known.push_back(name);
        }
    if (!o.choose.empty() && std::find(known.begin(), known.end(), o.choose) == known.end()) {
        std::string list;
        for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
        throw std::invalid_argument("choose = '" + o.choose + "': no such candidate (candidates: " + list + ")");
    }

    std::unique_ptr<ms::TermBackend> owned;
    const auto reference_set = [&](const design::ReferenceDefinition& def, const auto& report) {
        design::CacheConfig config;
        config.dir = o.cache;
        config.command_line = kCommandLine;
        // The backend (device start-up) only when something has to be computed.
        config.backend = owned.get();
        config.open_backend = [&]() {
            if (!owned) owned = detail::make_backend(o.backend, o.device, false);
            return owned.get();
        };
        config.progress = [&](std::size_t done, std::size_t total) { report(done, total); };
        return design::load_or_compute(def, config);
    };
    return detail::run_with_progress(progress, [&](const auto& report) {
        const design::ReferenceSet set = reference_set(evaluation_def, report);
        if (has_fit) {
            const design::ReferenceSet training = reference_set(fit_def, report);
            for (unsigned order : o.fit_orders) {
                ms::throw_if_cancelled();
                ms::fit::ClosedForm form = design::fit_closed_form(training, order);
                form.provenance["command_line"] = kCommandLine;
                candidates.push_back(design::closed_form_candidate(form, ""));
            }
        }
        check_unique_names(candidates);

        std::vector<design::DomainCount> outside;
        for (const auto& c : candidates) {
            outside.push_back(design::count_outside_domain(c, set));
            if (o.strict_domain && c.domain)
                ms::compare::refuse_outside_domain(o.reference, c.name, *c.domain, outside.back().tally,
                                                   outside.back().first_outside);
        }
        std::vector<design::Metrics> metrics;
        for (const auto& c : candidates) {
            ms::throw_if_cancelled();
            metrics.push_back(design::evaluate_candidate(c, set));
        }
        const std::vector<std::size_t> front = design::pareto_front(candidates, metrics);
        std::size_t chosen = candidates.size();
        if (!o.choose.empty()) {
            for (std::size_t i = 0; i < candidates.size(); ++i)
                if (candidates[i].name == o.choose) chosen = i;
            if (!budget.fits(candidates[chosen].cost))
                throw std::invalid_argument("choose = '" + o.choose + "': over the budget (" +
                                            std::to_string(candidates[chosen].cost.bytes) + " bytes, " +
                                            std::to_string(candidates[chosen].cost.fetches_per_light) + " fetches, " +
                                            std::to_string(candidates[chosen].cost.alu_per_light) + " ALU)");
        } else {
            chosen = design::choose(candidates, metrics, budget);
        }

        // pareto.csv's order: by weighted RMS, ties in candidate order.
        std::vector<std::size_t> order(candidates.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
        std::stable_sort(order.begin(), order.end(), [&](auto a, auto b) { return metrics[a].weighted_rms < metrics[b].weighted_rms; });
        const std::set<std::size_t> on_front(front.begin(), front.end());
        DesignTable table;
        table.roughness_edges = {0.0, 0.2, 0.4, 0.6, 0.8, 1.0};
        for (std::size_t i : order) {
            const design::Candidate& c = candidates[i];
            DesignCandidate row;
            row.name = c.name;
            row.kind = c.kind;
            row.storage = c.cost.storage;
            row.bytes = c.cost.bytes;
            row.fetches_per_light = c.cost.fetches_per_light;
            row.alu_per_light = c.cost.alu_per_light;
            row.metrics = to_public(metrics[i]);
            row.pareto = on_front.count(i) > 0;
            row.chosen = i == chosen;
            row.within_budget = budget.fits(c.cost);
            row.outside_domain = outside[i].tally.outside;
            for (const auto& m : design::evaluate_candidate_by_roughness(c, set, table.roughness_edges))
                row.by_roughness.push_back(to_public(m));
            table.candidates.push_back(std::move(row));
        }
        table.chosen = candidates[chosen].name;
        table.reference_file = set.file;
        table.reference_points = set.points.size();
        table.reference_max_std_error = set.max_std_error;
        table.reference_rms_std_error = set.rms_std_error;
        return table;
    });
}

}  // namespace microshadow
