// microshadow::analytic_term: part 1's terms by name, through the comparators of `eval --compare`.
#include "microshadow/analytic.hpp"

#include "approx/analytic.hpp"

#include <stdexcept>

#include "api/facade.hpp"
#include "jobs/compare.hpp"

namespace microshadow {

std::vector<std::string> analytic_term_names() {
    std::vector<std::string> names;
    for (const ms::analytic::AnalyticTerm t : ms::analytic::kAllAnalyticTerms) names.push_back(ms::analytic::to_string(t));
    return names;
}

std::vector<double> analytic_term(const std::string& name, const std::vector<AnalyticInputs>& inputs, AoWeighting ao_weighting) {
    const ms::analytic::AnalyticTerm term = ms::analytic::parse_analytic_term(name);
    std::vector<double> out;
    out.reserve(inputs.size());
    for (std::size_t i = 0; i < inputs.size(); ++i) {
        ms::approx::Inputs in;
        in.visibility = inputs[i].visibility;
        in.n_dot_l = inputs[i].n_dot_l;
        in.n_dot_v = inputs[i].n_dot_v;
        in.roughness = inputs[i].roughness;
        in.weighting = detail::to_ms(ao_weighting);
        try {
            out.push_back(ms::approx::analytic_value(term, in));
        } catch (const std::domain_error& e) {
            throw std::domain_error("microshadow::analytic_term: " + name + ": input " + std::to_string(i) + ": " + e.what());
        }
    }
    return out;
}

}  // namespace microshadow
