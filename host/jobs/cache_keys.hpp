// The parts every job's cache key shares (schedule/cache_key.hpp): the sampling plan, the term's
// options, the kernels' build and the kind of place the bits come from, each option by one name in
// every job's key. The jobs' own keys: bake_cache_key (jobs/bake.hpp), scene_cache_key (jobs/scene.hpp),
// repr_cache_key (jobs/repr_bake.hpp), sweep::sweep_cache_key (jobs/sweep/runner.hpp) and
// ReferenceDefinition::cache_key (jobs/reference_set.hpp).
#pragma once

#include <string>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "schedule/cache_key.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

// plan.method, plan.samples, plan.replicates, plan.seed, plan.sequence, plan.tolerance,
// plan.single_precision, plan.kernel_on_cpu_devices, and for the exact method plan.exact_rule and
// plan.exact_azimuth_rule (the arcs' and the azimuth means' rules its tolerance selects: a change of a
// rule moves the key).
void add_sampling_plan(schedule::CacheKey& key, const SamplingPlan& plan);
// plan.exact_rule and plan.exact_azimuth_rule alone, for jobs that keep their own tolerance field.
void add_exact_rules(schedule::CacheKey& key, double tolerance);
// term.form, term.ao_weighting.
void add_term_options(schedule::CacheKey& key, const TermOptions& term);
// build.fast_math, build.double_precision, build.defines: the kernels' build (--fast-math,
// --double-kernels), which decides a device's bits.
void add_build(schedule::CacheKey& key, const ocl::BuildConfig& build);
// results: the kind of place (Scheduler::results_label: the oracle, or the OpenCL device kinds), not
// how many of them: a run begun on one device resumes on all of that kind.
void add_results_place(schedule::CacheKey& key, const schedule::Scheduler& scheduler);

}  // namespace ms
