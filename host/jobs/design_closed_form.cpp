#include "jobs/design_closed_form.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "fit/least_squares.hpp"
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
        w[i] = p.weight * std::max(p.n_dot_l, 0.0);
        // S^-1(s) = q / sqrt(1 - q^2) with q = 2 s - 1: the start solves the linearised problem.
        const double q = 2 * std::clamp(y[i], 0.005, 0.995) - 1;
        start_target[i] = q / std::sqrt(1 - q * q);
    }
    const std::vector<double> start = fit::weighted_least_squares(a, start_target, w);
    fit::GaussNewtonReport report;
    form.coefficients = fit::gauss_newton(a, y, w, {fit::closed_form_link, fit::closed_form_link_derivative}, start, 50, &report);
    double max_abs = 0, sum_w = 0, sum_we2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
        double z = 0;
        for (std::size_t k = 0; k < terms; ++k) z += a.rows[i * terms + k] * form.coefficients[k];
        const double e = fit::closed_form_link(z) - y[i];
        if (w[i] > 0) max_abs = std::max(max_abs, std::fabs(e));
        sum_w += w[i];
        sum_we2 += w[i] * e * e;
    }
    form.provenance = {{"fitted_to", {{"name", training.definition.name},
                                      {"hash", training.definition.hash()},
                                      {"points", n},
                                      {"definition", training.definition.canonical_text()}}},
                       {"weighting", "weight x NdotL"},
                       {"fit_weighted_rms", sum_w > 0 ? std::sqrt(sum_we2 / sum_w) : 0.0},
                       {"fit_max_abs", max_abs},
                       {"gauss_newton_steps", report.iterations},
                       {"program", "microshadow " MICROSHADOW_VERSION}};
    return form;
}

Candidate closed_form_candidate(const fit::ClosedForm& form, const std::string& file) {
    Candidate c;
    c.name = "closed-form-" + std::to_string(form.order);
    c.kind = "closed-form";
    const std::string glsl = fit::generate_closed_form_shader(form, fit::ClosedFormLanguage::glsl, "design");
    c.cost.alu_per_light = count_alu(glsl);
    c.cost.storage = "none (" + std::to_string(form.coefficients.size()) + " constants)";
    auto shared = std::make_shared<const fit::ClosedForm>(form);
    c.value = [shared](const compare::ComparatorInputs& in) {
        return (*shared)(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.relative_azimuth);
    };
    c.provenance = {{"name", c.name}, {"kind", "closed-form"}, {"order", form.order}, {"coefficients", form.coefficients}};
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
