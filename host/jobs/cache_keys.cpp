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
    if (plan.method == Method::exact) {
        // The rule the tolerance selects (0: the default tolerance's): the same tolerance under a new
        // rule gives other bits.
        const exact::ArcRule rule = exact::arc_rule_for(plan.tolerance > 0 ? plan.tolerance : exact::kDefaultTolerance);
        key.add("plan.exact_rule", {rule.high, rule.low, rule.rho});
    }
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
