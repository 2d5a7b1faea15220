// microshadow::area_evaluate: `microshadow area eval` (jobs/area_run.hpp) as a call on queries in memory.
#include "microshadow/area.hpp"

#include <stdexcept>
#include <string>

#include "api/facade.hpp"
#include "core/area_light.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "jobs/area_run.hpp"
#include "sampling/point_set.hpp"

namespace microshadow {

namespace {

ms::Vec3 to_ms(const Direction& d) { return {d.x, d.y, d.z}; }

// The job's query, checked as `area eval` checks a CSV row (the half-angle in degrees as given).
ms::area::AreaQuery to_ms(const AreaQuery& q, ms::area::Lobe lobe, std::size_t index) {
    const std::string where = "microshadow::area_evaluate: query " + std::to_string(index) + ": ";
    ms::area::AreaQuery out;
    out.visibility = q.visibility;
    out.alpha_x = q.alpha_x;
    out.alpha_y = q.alpha_y;
    out.wi = to_ms(q.wi);
    out.lobe = lobe;
    out.light.shape = q.light == LightShape::sphere ? ms::area::LightShape::sphere : ms::area::LightShape::rect;
    if (q.light == LightShape::sphere) {
        out.light.sphere.centre = to_ms(q.light_direction);
        if (!(q.half_angle_deg > 0 && q.half_angle_deg < 90))
            throw std::invalid_argument(where + "half_angle_deg = " + std::to_string(q.half_angle_deg) +
                                        " must be in (0, 90) degrees");
        out.light.sphere.half_angle = ms::area::radians(q.half_angle_deg);
    } else {
        for (int k = 0; k < 4; ++k) out.light.rect.corners[k] = to_ms(q.corners[k]);
    }
    try {
        ms::area::validate(out);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(where + e.what());
    }
    return out;
}

}  // namespace

std::vector<AreaEstimate> area_evaluate(const std::vector<AreaQuery>& queries, const AreaOptions& options,
                                        const Progress& progress) {
    const SamplingOptions& o = options.sampling;
    const bool exact = o.method == Method::exact;
    if (o.replicates < 2)
        throw std::invalid_argument("microshadow::area_evaluate: replicates = " + std::to_string(o.replicates) + " (at least 2)");
    if (!exact && o.tolerance != 0)
        throw std::invalid_argument("microshadow::area_evaluate: tolerance applies to the exact method only (the inner term's tolerance)");
    // As the command: the exact method samples the outer integral over the light (jobs/area.hpp,
    // exact_inner_term) with a sampled plan of fewer samples by default; the tolerance is the inner term's.
    const std::uint64_t samples = o.samples ? o.samples : exact ? ms::area::kExactOuterSamples : 65536;
    ms::SamplingPlan plan;
    plan.method = ms::Method::sampled;
    plan.sequence = detail::to_ms(o.sequence);
    plan.replicates = o.replicates;
    plan.seed = o.seed;
    plan.samples = ms::round_up_samples(samples, o.replicates);
    ms::area::AreaEvalMethod method;
    method.plan = plan;
    method.exact = exact;
    method.inner_tolerance = o.tolerance > 0 ? o.tolerance : ms::area::kExactInnerTolerance;
    if (exact) ms::exact_term::validate_tolerance(method.inner_tolerance);
    method.term = detail::term_options(o.ao_weighting, o.form);
    method.make_backend = [&] { return detail::make_backend(o.backend, o.device, o.fast_math); };

    const ms::area::Lobe lobe = options.lobe == Lobe::ggx ? ms::area::Lobe::ggx : ms::area::Lobe::lambert;
    std::vector<ms::area::AreaQuery> qs;
    qs.reserve(queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) qs.push_back(to_ms(queries[i], lobe, i));
    const std::vector<ms::area::AreaEstimate> got = detail::run_with_progress(progress, [&](const auto& report) {
        ms::JobCallbacks callbacks;
        callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { report(done, total); };
        return ms::area::evaluate_area_queries(method, qs, callbacks).estimates;
    });
    std::vector<AreaEstimate> out;
    out.reserve(got.size());
    for (const auto& e : got) out.push_back({e.term.term, e.term.std_error, e.inner_error});
    return out;
}

}  // namespace microshadow
