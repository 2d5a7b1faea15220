#include "analytic/part1_terms.hpp"

#include <cmath>
#include <stdexcept>

namespace ms::analytic {

namespace {

// HLSL saturate: NaN -> 0 (the comparisons are false for NaN).
double saturate(double x) { return x > 0.0 ? (x < 1.0 ? x : 1.0) : 0.0; }
// HLSL step(a, x).
double step(double a, double x) { return x >= a ? 1.0 : 0.0; }
// HLSL lerp(x, y, s).
double lerp(double x, double y, double s) { return x + s * (y - x); }
// HLSL frac(x).
double frac(double x) { return x - std::floor(x); }

double pow5(double x) {
    const double xx = x * x;
    return xx * xx * x;
}

}  // namespace

double cone_cos_theta(double visibility, AoWeighting weighting) {
    return weighting == AoWeighting::cosine ? std::sqrt(1.0 - visibility) : 1.0 - visibility;
}

double reference_step(double visibility, double n_dot_l, AoWeighting weighting) {
    return step(analytic::cone_cos_theta(visibility, weighting), n_dot_l);
}

double naughty_dog(double visibility, double n_dot_l) {
    const double aperture = 2.0 * visibility * visibility;
    return saturate(n_dot_l + aperture - 1.0);
}

double naughty_dog_ao_fresnel_visibility(double visibility, double n_dot_v) {
    return lerp(1.0, visibility, saturate(n_dot_v));
}

double naughty_dog_with_ao_fresnel(double visibility, double n_dot_l, double n_dot_v) {
    return naughty_dog(naughty_dog_ao_fresnel_visibility(visibility, n_dot_v), n_dot_l);
}

double activision(double visibility, double n_dot_l, AoWeighting weighting) {
    if (visibility == 1.0) return 1.0;  // the paper's guard against division by 0
    const double result = saturate(n_dot_l / analytic::cone_cos_theta(visibility, weighting));
    return result * result;
}

double activision_adjust_cos_cone(double cos_cone, double gloss, double n_dot_v, bool scale_gloss) {
    if (scale_gloss) gloss = saturate(gloss * 1.5);
    const double gloss2 = gloss * gloss;
    const double gloss4 = gloss2 * gloss2;
    const double gloss8 = gloss4 * gloss4;
    const double one_minus_n_dot_v2 = (1.0 - n_dot_v) * (1.0 - n_dot_v);
    const double one_minus_n_dot_v4 = one_minus_n_dot_v2 * one_minus_n_dot_v2;
    return lerp(0.0, cos_cone, (1.0 - gloss8) * (1.0 - one_minus_n_dot_v4));
}

double activision_with_cone_adjustment(double visibility, double roughness, double n_dot_l, double n_dot_v,
                                       AoWeighting weighting) {
    const double gloss = 1.0 - roughness;  // part 1: "line not included in the paper"
    const double cos_cone = analytic::cone_cos_theta(visibility, weighting);
    double adjusted = activision_adjust_cos_cone(cos_cone, gloss, n_dot_v);
    adjusted = std::fmax(adjusted, 0.001);
    const double vis = saturate(n_dot_l / adjusted);
    return vis * vis;
}

double activision_alpha_from_roughness(double roughness) {
    return std::sqrt(2.0 / (1.0 + std::exp2(18.0 * (1.0 - roughness))));
}

double activision_roughness_from_alpha(double alpha) {
    // alpha^2 = 2 / (1 + 2^(18 (1 - r)))  <=>  2^(18 (1 - r)) = 2 / alpha^2 - 1.
    if (!(alpha > 0.0 && alpha < std::sqrt(2.0)))
        throw std::domain_error("activision_roughness_from_alpha: alpha must lie in (0, sqrt(2))");
    return 1.0 - std::log2(2.0 / (alpha * alpha) - 1.0) / 18.0;
}

double pz_analytic(double visibility, double n_dot_l) {
    if (frac(visibility) == 0.0) return visibility;  // the paper's guard against divisions by 0
    const double cos_theta_prime = std::sqrt(1.0 - pow5(visibility));
    return std::pow(saturate(n_dot_l / cos_theta_prime), 0.75 / visibility);
}

double f_schlick(double f0, double f90, double v_dot_h) {
    return f0 + (f90 - f0) * std::pow(1.0 - v_dot_h, 5.0);
}

double f_schlick_f0_micro_occlusion(double f0, double v_dot_h) {
    return f_schlick(f0, saturate(50.0 * f0), v_dot_h);
}

std::string to_string(AnalyticTerm t) {
    switch (t) {
        case AnalyticTerm::reference_step: return "reference-step";
        case AnalyticTerm::naughty_dog: return "naughty-dog";
        case AnalyticTerm::naughty_dog_ao_fresnel: return "naughty-dog-ao-fresnel";
        case AnalyticTerm::activision: return "activision";
        case AnalyticTerm::activision_adjusted: return "activision-adjusted";
        case AnalyticTerm::pz_analytic: return "pz-analytic";
    }
    throw std::invalid_argument("to_string: invalid AnalyticTerm value");
}

std::vector<std::string> analytic_term_names() {
    std::vector<std::string> names;
    for (AnalyticTerm t : kAllAnalyticTerms) names.push_back(to_string(t));
    return names;
}

AnalyticTerm parse_analytic_term(const std::string& s) {
    for (AnalyticTerm t : kAllAnalyticTerms)
        if (to_string(t) == s) return t;
    std::string names;
    for (const std::string& name : analytic_term_names()) names += (names.empty() ? "" : ", ") + name;
    throw std::invalid_argument("unknown analytic term '" + s + "' (expected one of " + names + ")");
}

double evaluate(AnalyticTerm t, const AnalyticInputs& in) {
    switch (t) {
        case AnalyticTerm::reference_step: return reference_step(in.visibility, in.n_dot_l, in.ao_weighting);
        case AnalyticTerm::naughty_dog: return naughty_dog(in.visibility, in.n_dot_l);
        case AnalyticTerm::naughty_dog_ao_fresnel:
            return naughty_dog_with_ao_fresnel(in.visibility, in.n_dot_l, in.n_dot_v);
        case AnalyticTerm::activision: return activision(in.visibility, in.n_dot_l, in.ao_weighting);
        case AnalyticTerm::activision_adjusted:
            return activision_with_cone_adjustment(in.visibility, in.roughness, in.n_dot_l, in.n_dot_v,
                                                   in.ao_weighting);
        case AnalyticTerm::pz_analytic: return pz_analytic(in.visibility, in.n_dot_l);
    }
    throw std::invalid_argument("evaluate: invalid AnalyticTerm value");
}

}  // namespace ms::analytic
