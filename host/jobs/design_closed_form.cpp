#include "jobs/design_closed_form.hpp"

#include "core/error_stats.hpp"

#include <algorithm>
#include <cmath>
#include <array>
#include <memory>

#include <random>

#include "core/lookup_domain.hpp"
#include "exact/exact_term.hpp"
#include "fit/least_squares.hpp"
#include "fit/nelder_mead.hpp"
#include "io/text.hpp"

namespace ms::design {

fit::ClosedForm fit_closed_form(const ReferenceSet& training, unsigned order) {
    fit::ClosedForm form;
    form.order = order;
    form.weighting = training.definition.options.ao_weighting;
    const std::size_t n = training.points.size();
    const std::size_t terms = fit::closed_form_monomials(order).size();
    fit::Design a{terms, std::vector<double>(n * terms)};
    std::vector<double> y(n), w(n), start_target(n);
    for (std::size_t i = 0; i < n; ++i) {
        const ReferencePoint& p = training.points[i];
        const auto x = fit::closed_form_variables(p.visibility, p.n_dot_l, p.n_dot_v, p.roughness, p.relative_azimuth,
                                                  form.weighting);
        const auto basis = fit::closed_form_basis(order, x);
        std::copy(basis.begin(), basis.end(), a.rows.begin() + std::ptrdiff_t(i * terms));
        y[i] = training.values[i].term;
        // The zero region is answered 0 exactly, not by the sigmoid: those points do not shape it.
        w[i] = fit::closed_form_zero_region(p.visibility, p.n_dot_l, form.weighting) ? 0.0 : p.weight * std::max(p.n_dot_l, 0.0);
        // S^-1(s) = q / sqrt(1 - q^2) with q = 2 s - 1: the start solves the linearised problem.
        const double q = 2 * std::clamp(y[i], 0.005, 0.995) - 1;
        start_target[i] = q / std::sqrt(1 - q * q);
    }
    const std::vector<double> start = fit::weighted_least_squares(a, start_target, w);
    fit::GaussNewtonReport report;
    form.coefficients = fit::gauss_newton(a, y, w, {fit::closed_form_link, fit::closed_form_link_derivative}, start, 50, &report);
    // The fit's errors at its points of positive weight (a point of weight 0 adds nothing to the
    // weighted RMS and is no part of the fitted region for the maximum).
    ErrorStats fit_errors;
    for (std::size_t i = 0; i < n; ++i) {
        double z = 0;
        for (std::size_t k = 0; k < terms; ++k) z += a.rows[i * terms + k] * form.coefficients[k];
        const double e = fit::closed_form_link(z) - y[i];
        if (w[i] > 0) fit_errors.add(e, w[i]);
    }
    form.provenance = {{"fitted_to", {{"name", training.definition.name},
                                      {"hash", training.definition.hash()},
                                      {"points", n},
                                      {"definition", training.definition.canonical_text()}}},
                       {"weighting", "weight x NdotL"},
                       {"fit_weighted_rms", fit_errors.weighted_rms()},
                       {"fit_max_abs", fit_errors.max_abs()},
                       {"gauss_newton_steps", report.iterations},
                       {"program", "microshadow " MICROSHADOW_VERSION}};
    const SearchRegion region = region_of(training);
    LookupDomain domain;
    domain.visibility_min = region.visibility_min, domain.visibility_max = region.visibility_max;
    domain.n_dot_v_min = region.n_dot_v_min, domain.n_dot_v_max = region.n_dot_v_max;
    domain.roughness_min = region.roughness_min, domain.roughness_max = region.roughness_max;
    form.provenance["domain"] = domain.to_json("the training points' ranges; outside, the polynomial extrapolates");
    const SearchedMax worst = search_max_error(form, region, training.points);
    form.provenance["max_abs"] = worst.max_abs;
    form.provenance["max_abs_search"] = {
        {"what", "max |form - exact term| over the training region (its points' bounding box, any azimuth in it), found by "
                 "Nelder-Mead from many starts (the largest training errors and uniform points); a lower bound of the true max"},
        {"starts", worst.starts},
        {"evaluations", worst.evaluations},
        {"at", {{"visibility", worst.visibility}, {"n_dot_l", worst.n_dot_l}, {"n_dot_v", worst.n_dot_v}, {"roughness", worst.roughness},
                {"relative_azimuth_deg", worst.relative_azimuth * 180 / 3.14159265358979323846}, {"term", worst.term}}}};
    return form;
}

SearchRegion region_of(const ReferenceSet& set) {
    SearchRegion r;
    if (set.points.empty()) return r;
    // A generated set's region is its definition's (its random points stop short of the ends), when
    // every point lies in it; a CSV's (or a set built otherwise) is its points' bounding box.
    const ReferenceDefinition& d = set.definition;
    if (d.points_csv.empty()) {
        constexpr double kDeg = 3.14159265358979323846 / 180;
        SearchRegion g;
        g.visibility_min = d.visibility.lo, g.visibility_max = d.visibility.hi;
        g.n_dot_l_min = d.n_dot_l.lo, g.n_dot_l_max = d.n_dot_l.hi;
        g.n_dot_v_min = d.n_dot_v.lo, g.n_dot_v_max = d.n_dot_v.hi;
        g.roughness_min = d.roughness.lo, g.roughness_max = d.roughness.hi;
        g.azimuth_min = d.azimuth_deg.lo * kDeg, g.azimuth_max = d.azimuth_deg.hi * kDeg;
        bool inside = true;
        for (const auto& p : set.points)
            inside = inside && p.visibility >= g.visibility_min && p.visibility <= g.visibility_max && p.n_dot_l >= g.n_dot_l_min &&
                     p.n_dot_l <= g.n_dot_l_max && p.n_dot_v >= g.n_dot_v_min && p.n_dot_v <= g.n_dot_v_max &&
                     p.roughness >= g.roughness_min && p.roughness <= g.roughness_max &&
                     p.relative_azimuth >= g.azimuth_min - 1e-12 && p.relative_azimuth <= g.azimuth_max + 1e-12;
        if (inside) return g;
    }
    const auto& p0 = set.points.front();
    r.visibility_min = r.visibility_max = p0.visibility;
    r.n_dot_l_min = r.n_dot_l_max = p0.n_dot_l;
    r.n_dot_v_min = r.n_dot_v_max = p0.n_dot_v;
    r.roughness_min = r.roughness_max = p0.roughness;
    r.azimuth_min = r.azimuth_max = p0.relative_azimuth;
    for (const auto& p : set.points) {
        r.visibility_min = std::min(r.visibility_min, p.visibility), r.visibility_max = std::max(r.visibility_max, p.visibility);
        r.n_dot_l_min = std::min(r.n_dot_l_min, p.n_dot_l), r.n_dot_l_max = std::max(r.n_dot_l_max, p.n_dot_l);
        r.n_dot_v_min = std::min(r.n_dot_v_min, p.n_dot_v), r.n_dot_v_max = std::max(r.n_dot_v_max, p.n_dot_v);
        r.roughness_min = std::min(r.roughness_min, p.roughness), r.roughness_max = std::max(r.roughness_max, p.roughness);
        r.azimuth_min = std::min(r.azimuth_min, p.relative_azimuth), r.azimuth_max = std::max(r.azimuth_max, p.relative_azimuth);
    }
    return r;
}

namespace {

// A point of the region from unit-box coordinates x[0..4] (clamped to the box).
struct RegionPoint {
    double v, l, nv, r, phi;
};
RegionPoint at_unit(const SearchRegion& g, const std::array<double, 5>& x) {
    auto lerp = [](double lo, double hi, double t) { return lo + (hi - lo) * std::clamp(t, 0.0, 1.0); };
    return {lerp(g.visibility_min, g.visibility_max, x[0]), lerp(g.n_dot_l_min, g.n_dot_l_max, x[1]),
            lerp(g.n_dot_v_min, g.n_dot_v_max, x[2]), lerp(g.roughness_min, g.roughness_max, x[3]),
            lerp(g.azimuth_min, g.azimuth_max, x[4])};
}
std::array<double, 5> to_unit(const SearchRegion& g, const ReferencePoint& p) {
    auto inv = [](double lo, double hi, double v) { return hi > lo ? (v - lo) / (hi - lo) : 0.5; };
    return {inv(g.visibility_min, g.visibility_max, p.visibility), inv(g.n_dot_l_min, g.n_dot_l_max, p.n_dot_l),
            inv(g.n_dot_v_min, g.n_dot_v_max, p.n_dot_v), inv(g.roughness_min, g.roughness_max, p.roughness),
            inv(g.azimuth_min, g.azimuth_max, p.relative_azimuth)};
}

}  // namespace

SearchedMax search_max_error(const fit::ClosedForm& form, const SearchRegion& region, const std::vector<ReferencePoint>& seeds,
                             std::size_t starts, std::uint64_t seed) {
    return search_max_error([&form](double v, double l, double nv, double r, double phi) { return form(v, l, nv, r, phi); },
                            form.weighting, region, seeds, starts, seed);
}

SearchedMax search_max_error(const LookupFunction& form, AoWeighting weighting, const SearchRegion& region,
                             const std::vector<ReferencePoint>& seeds, std::size_t starts, std::uint64_t seed) {
    SearchedMax best;
    auto error_at = [&](const RegionPoint& p, double* term) {
        ++best.evaluations;
        // The term at NdotV or NdotL of exactly 0 is a limit the evaluator refuses; the box's edge is
        // approached instead (1e-6: below any closed form's resolution).
        const double nv = std::max(p.nv, 1e-6), l = p.l;
        const double t = l <= 0 ? 0.0
                                : exact::exact_term_at_azimuth(p.v, p.r * p.r, nv, l, p.phi, weighting, 1e-9).term;
        if (term) *term = t;
        return std::fabs(form(p.v, l, nv, p.r, p.phi) - t);
    };
    // Starts: the seeds where the form errs most (a quarter), then uniform points of the region.
    std::vector<std::array<double, 5>> start_points;
    {
        std::vector<std::pair<double, std::size_t>> by_error;
        for (std::size_t i = 0; i < seeds.size(); ++i) {
            const auto& s = seeds[i];
            by_error.emplace_back(std::fabs(form(s.visibility, s.n_dot_l, std::max(s.n_dot_v, 1e-6), s.roughness, s.relative_azimuth) -
                                            (s.n_dot_l <= 0 ? 0.0
                                                            : exact::exact_term_at_azimuth(s.visibility, s.roughness * s.roughness,
                                                                                           std::max(s.n_dot_v, 1e-6), s.n_dot_l,
                                                                                           s.relative_azimuth, weighting, 1e-7)
                                                                  .term)),
                                  i);
        }
        const std::size_t from_seeds = std::min(by_error.size(), starts / 4);
        std::partial_sort(by_error.begin(), by_error.begin() + std::ptrdiff_t(from_seeds), by_error.end(),
                          [](const auto& a, const auto& b) { return a.first > b.first; });
        for (std::size_t k = 0; k < from_seeds; ++k) start_points.push_back(to_unit(region, seeds[by_error[k].second]));
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<double> u01(0, 1);
        while (start_points.size() < starts) start_points.push_back({u01(rng), u01(rng), u01(rng), u01(rng), u01(rng)});
    }
    // Nelder-Mead maximising the error (minimising its negative) in the unit box, 5 dimensions
    // (fit/nelder_mead.hpp): at most 200 iterations of 1-2 evaluations each (5 more on a shrink), an
    // initial step of 5 % of the box.
    constexpr int kMaxIterations = 200;
    for (const auto& x0 : start_points) {
        auto value = [&](const std::vector<double>& x) { return -error_at(at_unit(region, {x[0], x[1], x[2], x[3], x[4]}), nullptr); };
        double f_best = 0;
        const std::vector<double> x = fit::nelder_mead_unit_box(value, {x0.begin(), x0.end()}, kMaxIterations, 1e-7, 0.05, &f_best);
        if (-f_best > best.max_abs) {
            const RegionPoint p = at_unit(region, {x[0], x[1], x[2], x[3], x[4]});
            double term = 0;
            best.max_abs = error_at(p, &term);
            best.visibility = p.v, best.n_dot_l = p.l, best.n_dot_v = std::max(p.nv, 1e-6), best.roughness = p.r;
            best.relative_azimuth = p.phi, best.term = term;
        }
    }
    best.starts = start_points.size();
    return best;
}

Candidate closed_form_candidate(const fit::ClosedForm& form, const std::string& file) {
    Candidate c;
    c.name = "closed-form-" + std::to_string(form.order);
    c.kind = "closed-form";
    const std::string glsl = fit::generate_closed_form_shader(form, fit::ClosedFormLanguage::glsl, "design");
    c.cost.alu_per_light = count_alu(glsl);
    c.cost.storage = "none (" + std::to_string(form.coefficients.size()) + " constants)";
    auto shared = std::make_shared<const fit::ClosedForm>(form);
    c.value = [shared](const approx::Inputs& in) {
        return (*shared)(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.relative_azimuth);
    };
    c.provenance = {{"name", c.name}, {"kind", "closed-form"}, {"order", form.order}, {"coefficients", form.coefficients}};
    // A fitted form records its training region as its domain; a file without one answers everywhere.
    if (form.provenance.is_object() && form.provenance.contains("domain")) {
        c.domain = LookupDomain::from_json(form.provenance["domain"], file.empty() ? c.name : file);
        c.provenance["domain"] = form.provenance["domain"];
    }
    for (const char* key : {"max_abs", "fit_max_abs"})
        if (form.provenance.is_object() && form.provenance.contains(key)) c.provenance[key + std::string("_of_fit")] = form.provenance[key];
    if (!file.empty()) c.provenance["file"] = json_safe(file);
    c.bake = [shared](OutputSet& outputs, const std::string& prefix) {
        const std::string source = prefix + ".json";
        outputs.stream(outputs.add(prefix + ".json")) << dump_json(fit::to_json(*shared), 2) << "\n";
        outputs.stream(outputs.add(prefix + ".glsl")) << fit::generate_closed_form_shader(*shared, fit::ClosedFormLanguage::glsl, source);
        outputs.stream(outputs.add(prefix + ".hlsl")) << fit::generate_closed_form_shader(*shared, fit::ClosedFormLanguage::hlsl, source);
    };
    return c;
}

}  // namespace ms::design
