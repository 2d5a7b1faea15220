#include "fit/closed_form.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <stdexcept>

#include "io/input_file.hpp"

namespace ms::fit {

namespace {

// 2: u is measured in units of alpha = roughness^2 (format 1, never released, used roughness).
constexpr const char* kFormat = "microshadow closed form 2";
constexpr const char* kVariableNames[5] = {"u", "t", "n_dot_v", "roughness", "c"};

// Variables per order and the monomials' highest degree (see the header).
int variable_count(unsigned order) { return order == 1 ? 1 : 5; }
int degree(unsigned order) { return order <= 2 ? 1 : int(order) - 1; }

void check_order(unsigned order) {
    if (order < 1 || order > kMaxClosedFormOrder)
        throw std::invalid_argument("closed form: order " + std::to_string(order) + " outside 1.." +
                                    std::to_string(kMaxClosedFormOrder));
}

// A float literal GLSL and HLSL read as the same binary32 value.
std::string lit(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", double(float(v)));
    std::string s = buf;
    if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
    return s;
}

// The name of monomial k in the shader: m<k>, or the variable itself for degree-1 monomials.
std::string monomial_name(const std::vector<std::vector<int>>& monomials, std::size_t k) {
    if (monomials[k].size() == 1) return kVariableNames[monomials[k][0]];
    return "m" + std::to_string(k);
}

}  // namespace

ClosedFormVariables closed_form_variables(double visibility, double n_dot_l, double n_dot_v, double roughness,
                                          double relative_azimuth, AoWeighting weighting) {
    ClosedFormVariables x;
    x.c = weighting == AoWeighting::cosine ? std::sqrt(std::max(0.0, 1.0 - visibility)) : 1.0 - visibility;
    x.u = (n_dot_l - x.c) / (roughness * roughness);
    const double sin_v = std::sqrt(std::max(0.0, 1.0 - n_dot_v * n_dot_v));
    const double sin_l = std::sqrt(std::max(0.0, 1.0 - n_dot_l * n_dot_l));
    x.t = sin_v * sin_l * std::cos(relative_azimuth);
    x.n_dot_v = n_dot_v;
    x.roughness = roughness;
    return x;
}

std::vector<std::vector<int>> closed_form_monomials(unsigned order) {
    check_order(order);
    const int n = variable_count(order), d = degree(order);
    std::vector<std::vector<int>> out = {{}};
    // Degree by degree, each monomial extending one of the previous degree by a variable index no
    // smaller than its last: every multiset of variables exactly once, in a fixed order.
    std::size_t begin = 0;
    for (int k = 1; k <= d; ++k) {
        const std::size_t end = out.size();
        for (std::size_t i = begin; i < end; ++i)
            for (int v = out[i].empty() ? 0 : out[i].back(); v < n; ++v) {
                std::vector<int> m = out[i];
                m.push_back(v);
                out.push_back(m);
            }
        begin = end;
    }
    return out;
}

std::vector<double> closed_form_basis(unsigned order, const ClosedFormVariables& x) {
    const auto monomials = closed_form_monomials(order);
    const double vars[5] = {x.u, x.t, x.n_dot_v, x.roughness, x.c};
    std::vector<double> out(monomials.size(), 1.0);
    for (std::size_t k = 0; k < monomials.size(); ++k)
        for (int v : monomials[k]) out[k] *= vars[v];
    return out;
}

bool closed_form_zero_region(double visibility, double n_dot_l, AoWeighting weighting) {
    // The same arithmetic as the shader's test (a float there).
    const double edge = weighting == AoWeighting::cosine ? 1.0 - 2.0 * visibility
                                                         : 2.0 * (1.0 - visibility) * (1.0 - visibility) - 1.0;
    return n_dot_l <= std::max(0.0, edge);
}

double closed_form_link(double z) { return 0.5 + 0.5 * z / std::sqrt(1.0 + z * z); }
double closed_form_link_derivative(double z) { return 0.5 / std::pow(1.0 + z * z, 1.5); }

double ClosedForm::at(const ClosedFormVariables& x) const {
    const std::vector<double> basis = closed_form_basis(order, x);
    double z = 0;
    for (std::size_t k = 0; k < basis.size(); ++k) z += coefficients.at(k) * basis[k];
    return closed_form_link(z);
}

double ClosedForm::operator()(double visibility, double n_dot_l, double n_dot_v, double roughness,
                              double relative_azimuth) const {
    if (closed_form_zero_region(visibility, n_dot_l, weighting)) return 0.0;
    return at(closed_form_variables(visibility, n_dot_l, n_dot_v, roughness, relative_azimuth, weighting));
}

std::string generate_closed_form_shader(const ClosedForm& form, ClosedFormLanguage language, const std::string& source_name) {
    const bool glsl = language == ClosedFormLanguage::glsl;
    const auto monomials = closed_form_monomials(form.order);
    if (form.coefficients.size() != monomials.size()) throw std::invalid_argument("closed form: wrong coefficient count");
    const std::string fma = glsl ? "fma" : "mad";
    const std::string rsqrt = glsl ? "inversesqrt" : "rsqrt";
    std::set<int> used;
    for (const auto& m : monomials) used.insert(m.begin(), m.end());
    std::ostringstream o;
    o << "// microshadow closed-form micro-shadowing term, order " << form.order << " (" << monomials.size()
      << " coefficients), " << to_string(form.weighting) << " AO; from " << source_name << ".\n"
      << "// term ~ S(z), S(z) = 0.5 + 0.5 z / sqrt(1 + z^2), z = a polynomial in u = (NdotL - c) / roughness^2,\n"
      << "// t = VdotL - NdotV NdotL, NdotV, roughness and c = cos of the visibility cone (docs/study.md).\n"
      << "// roughness is the perceptual roughness (alpha = roughness^2), > 0; anisotropic: (alpha_x alpha_y)^(1/4).\n"
      << "float ms_micro_shadowing_fit(float visibility, float n_dot_l, float n_dot_v, float roughness, float v_dot_l) {\n";
    o << "    float c = " << (form.weighting == AoWeighting::cosine ? "sqrt(1.0 - visibility)" : "1.0 - visibility") << ";\n";
    // The provable zero region (light beyond twice the cone's half-angle, or below the horizon): exactly 0.
    o << "    if (n_dot_l <= max(0.0, " << (form.weighting == AoWeighting::cosine ? "1.0 - 2.0 * visibility" : "2.0 * c * c - 1.0")
      << ")) return 0.0;\n";
    o << "    float u = (n_dot_l - c) / (roughness * roughness);\n";
    if (used.count(1)) o << "    float t = " << fma << "(-n_dot_v, n_dot_l, v_dot_l);\n";
    // Degree >= 2 monomials reuse the one of degree - 1 they extend: one multiply each.
    for (std::size_t k = 0; k < monomials.size(); ++k) {
        if (monomials[k].size() < 2) continue;
        std::vector<int> parent(monomials[k].begin(), monomials[k].end() - 1);
        std::size_t p = 0;
        while (monomials[p] != parent) ++p;
        o << "    float m" << k << " = " << monomial_name(monomials, p) << " * " << kVariableNames[monomials[k].back()] << ";\n";
    }
    o << "    float z = " << lit(form.coefficients[0]) << ";\n";
    for (std::size_t k = 1; k < monomials.size(); ++k) {
        o << "    z = " << fma << "(" << lit(form.coefficients[k]) << ", " << monomial_name(monomials, k) << ", z);\n";
    }
    o << "    return " << fma << "(z * " << rsqrt << "(" << fma << "(z, z, 1.0)), 0.5, 0.5);\n}\n";
    return o.str();
}

nlohmann::json to_json(const ClosedForm& form) {
    const auto monomials = closed_form_monomials(form.order);
    nlohmann::json names = nlohmann::json::array();
    for (const auto& m : monomials) {
        std::string s;
        for (int v : m) s += (s.empty() ? "" : "*") + std::string(kVariableNames[v]);
        names.push_back(s.empty() ? "1" : s);
    }
    return {{"format", kFormat},
            {"model", "term ~ 0.5 + 0.5 z / sqrt(1 + z^2), z = sum_k coefficients[k] * monomials[k]; u = (NdotL - c) / "
                      "roughness^2, t = VdotL - NdotV NdotL, c = sqrt(1 - visibility) (cosine AO) or 1 - visibility (uniform)"},
            {"order", form.order},
            {"ao_weighting", to_string(form.weighting)},
            {"monomials", names},
            {"coefficients", form.coefficients},
            {"provenance", form.provenance}};
}

ClosedForm closed_form_from_json(const nlohmann::json& j, const std::string& source) {
    auto fail = [&](const std::string& field, const std::string& what) {
        throw std::invalid_argument(source + ": " + field + ": " + what);
    };
    if (!j.is_object()) fail("(top)", "not a JSON object");
    if (!j.contains("format") || j["format"] != kFormat) fail("format", std::string("expected \"") + kFormat + "\"");
    ClosedForm f;
    if (!j.contains("order") || !j["order"].is_number_unsigned()) fail("order", "missing or not a positive integer");
    f.order = j["order"].get<unsigned>();
    if (f.order < 1 || f.order > kMaxClosedFormOrder) fail("order", "outside 1.." + std::to_string(kMaxClosedFormOrder));
    if (!j.contains("ao_weighting") || !j["ao_weighting"].is_string()) fail("ao_weighting", "missing");
    try {
        f.weighting = parse_ao_weighting(j["ao_weighting"].get<std::string>());
    } catch (const std::invalid_argument& e) {
        fail("ao_weighting", e.what());
    }
    if (!j.contains("coefficients") || !j["coefficients"].is_array()) fail("coefficients", "missing");
    for (const auto& c : j["coefficients"]) {
        if (!c.is_number() || !std::isfinite(c.get<double>())) fail("coefficients", "a value is not a finite number");
        f.coefficients.push_back(c.get<double>());
    }
    const std::size_t expected = closed_form_monomials(f.order).size();
    if (f.coefficients.size() != expected)
        fail("coefficients", std::to_string(f.coefficients.size()) + " values, order " + std::to_string(f.order) +
                                 " has " + std::to_string(expected));
    if (j.contains("provenance")) f.provenance = j["provenance"];
    return f;
}

ClosedForm read_closed_form(const std::string& path) {
    const std::string text = read_input_file(path, kMaxSpecBytes, "closed-form JSON");
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
        throw std::invalid_argument(path + ": not JSON (" + e.what() + ")");
    }
    return closed_form_from_json(j, path);
}

}  // namespace ms::fit
