// microshadow::design: `microshadow design` as a call that returns its tables: the command's study
// (jobs/design_study.hpp) on reference sets from the same cache, the table sorted as pareto.csv.
#include "microshadow/design.hpp"

#include <set>

#include "api/facade.hpp"
#include "jobs/design_study.hpp"

namespace microshadow {

namespace {

namespace design = ms::design;

const char* const kDesignCommandLine = "microshadow::design (library " MICROSHADOW_VERSION ")";

DesignMetrics to_public(const design::Metrics& m) { return {m.points, m.weighted_rms, m.weighted_p99, m.max_abs}; }

}  // namespace

DesignTable design(const DesignOptions& o, const Progress& progress) {
    design::StudySpec spec;
    spec.reference = o.reference;
    spec.fit_reference = o.fit_reference;
    spec.luts = o.luts;
    spec.reprs = o.reprs;
    spec.closed_forms = o.closed_forms;
    spec.fit_orders = o.fit_orders;
    spec.budget.max_bytes = o.max_bytes;
    spec.budget.max_fetches = o.max_fetches;
    spec.budget.max_alu = o.max_alu;
    spec.choose = o.choose;
    spec.analytic = o.analytic;
    spec.strict_domain = o.strict_domain;
    spec.backend_label = detail::backend_spec(o.backend, o.device).kind_name();
    spec.command_line = kDesignCommandLine;
    spec.names = design::OptionNames::library();
    // Every input checked before any work.
    design::Study study(std::move(spec));

    std::unique_ptr<ms::TermBackend> owned;
    const auto reference_set = [&](const design::ReferenceDefinition& def, const auto& report) {
        design::CacheConfig config;
        config.dir = o.cache;
        config.command_line = kDesignCommandLine;
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
        const design::ReferenceSet set = reference_set(study.evaluation_definition(), report);
        if (study.fit_definition()) study.add_fits(reference_set(*study.fit_definition(), report));
        const design::StudyResult result = study.judge(set);

        // pareto.csv's rows, in its order.
        const std::set<std::size_t> on_front(result.front.begin(), result.front.end());
        DesignTable table;
        table.roughness_edges = result.roughness_edges;
        for (std::size_t i : result.order) {
            const design::Candidate& c = study.candidates()[i];
            DesignCandidate row;
            row.name = c.name;
            row.kind = c.kind;
            row.storage = c.cost.storage;
            row.bytes = c.cost.bytes;
            row.fetches_per_light = c.cost.fetches_per_light;
            row.alu_per_light = c.cost.alu_per_light;
            row.metrics = to_public(result.metrics[i]);
            row.pareto = on_front.count(i) > 0;
            row.chosen = i == result.chosen;
            row.within_budget = study.spec().budget.fits(c.cost);
            row.outside_domain = result.outside[i].tally.outside;
            for (const auto& m : result.by_roughness[i]) row.by_roughness.push_back(to_public(m));
            table.candidates.push_back(std::move(row));
        }
        table.chosen = study.candidates()[result.chosen].name;
        table.reference_file = set.file;
        table.reference_points = set.points.size();
        table.reference_max_std_error = set.max_std_error;
        table.reference_rms_std_error = set.rms_std_error;
        return table;
    });
}

}  // namespace microshadow
