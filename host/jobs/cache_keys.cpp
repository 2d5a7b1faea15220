#include "jobs/cache_keys.hpp"

#include "exact/cap_region.hpp"
#include "exact/exact_term.hpp"

namespace ms {

void add_sampling_plan(schedule::CacheKey& key, const SamplingPlan& plan) {
    key.add("plan.method", to_string(plan.method))
        .add("plan.samples", plan.samples)
        .add("plan.replicates", plan.replicates)
        .add("plan.seed", plan.seed)
        .add("plan.sequence", to_string(plan.sequence))
        .add("plan.tolerance", plan.tolerance)
        .add("plan.single_precision", plan.single_precision)
        .add("plan.kernel_on_cpu_devices", plan.kernel_on_cpu_devices);
    if (plan.method == Method::exact) add_exact_rules(key, plan.tolerance > 0 ? plan.tolerance : exact::kDefaultTolerance);
}

void add_exact_rules(schedule::CacheKey& key, double tolerance) {
    // The rules the tolerance selects: the same tolerance under a new rule gives other bits, so results
    // cached under an earlier rule (the azimuth means' were once a Gauss rule on each piece and its
    // halves) are not reused.
    const exact::ArcRule rule = exact::arc_rule_for(tolerance);
    key.add("plan.exact_rule", {rule.high, rule.low, rule.rho});
    const exact::AzimuthRule azimuth = exact::azimuth_rule_for(tolerance);
    key.add("plan.exact_azimuth_rule", "gauss-kronrod " + std::to_string(azimuth.nodes) + "/" +
                                           std::to_string(2 * azimuth.nodes + 1) + " rho " + std::to_string(azimuth.rho));
}

void add_term_options(schedule::CacheKey& key, const TermOptions& term) {
    key.add("term.form", to_string(term.form)).add("term.ao_weighting", to_string(term.ao_weighting));
}

void add_build(schedule::CacheKey& key, const ocl::BuildConfig& build) {
    key.add("build.fast_math", build.fast_math)
        .add("build.double_precision", build.double_precision)
        .add("build.defines", build.defines);
}

void add_results_place(schedule::CacheKey& key, const schedule::Scheduler& scheduler) {
    key.add("results", scheduler.results_label());
}

}  // namespace ms
