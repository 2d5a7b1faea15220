#include "approx/analytic.hpp"

#include <algorithm>
#include <stdexcept>

#include "io/text.hpp"
#include "lut/shader/alu_count.hpp"

namespace ms::approx {

double analytic_value(analytic::AnalyticTerm t, const Inputs& c) {
    analytic::AnalyticInputs in;
    in.visibility = c.visibility;
    in.n_dot_l = c.n_dot_l;
    in.n_dot_v = c.n_dot_v;
    in.ao_weighting = c.weighting;
    // Activision's own non-standard roughness of the GGX alpha; the other terms ignore roughness.
    in.roughness = t == analytic::AnalyticTerm::activision_adjusted
                       ? analytic::activision_roughness_from_alpha(c.roughness * c.roughness)
                       : 0.5;
    return analytic::evaluate(t, in);
}

std::string analytic_glsl(analytic::AnalyticTerm term) {
    using analytic::AnalyticTerm;
    // Part 1's formulas (host/analytic/part1_terms.cpp) as a shader writes them, cosine AO
    // (cos_t = sqrt(1 - v)); `roughness` of activision-adjusted is its own (gloss = 1 - roughness).
    const std::string head = "float ms_part1(float v, float n_dot_l, float n_dot_v, float roughness) {\n";
    switch (term) {
        case AnalyticTerm::reference_step:
            return head + "    return n_dot_l >= sqrt(1.0 - v) ? 1.0 : 0.0;\n}\n";
        case AnalyticTerm::naughty_dog:
            return head + "    return clamp(n_dot_l + 2.0 * v * v - 1.0, 0.0, 1.0);\n}\n";
        case AnalyticTerm::naughty_dog_ao_fresnel:
            return head + "    float w = mix(1.0, v, clamp(n_dot_v, 0.0, 1.0));\n"
                          "    return clamp(n_dot_l + 2.0 * w * w - 1.0, 0.0, 1.0);\n}\n";
        case AnalyticTerm::activision:
            return head + "    if (v == 1.0) return 1.0;\n"
                          "    float s = clamp(n_dot_l / sqrt(1.0 - v), 0.0, 1.0);\n    return s * s;\n}\n";
        case AnalyticTerm::activision_adjusted:
            return head + "    float g = clamp((1.0 - roughness) * 1.5, 0.0, 1.0);\n"
                          "    float g2 = g * g, g4 = g2 * g2, g8 = g4 * g4;\n"
                          "    float o = (1.0 - n_dot_v) * (1.0 - n_dot_v);\n"
                          "    float c = max(mix(0.0, sqrt(1.0 - v), (1.0 - g8) * (1.0 - o * o)), 0.001);\n"
                          "    float s = clamp(n_dot_l / c, 0.0, 1.0);\n    return s * s;\n}\n";
        case AnalyticTerm::pz_analytic:
            return head + "    if (fract(v) == 0.0) return v;\n"
                          "    float v2 = v * v;\n"
                          "    float c = sqrt(1.0 - v2 * v2 * v);\n"
                          "    return pow(clamp(n_dot_l / c, 0.0, 1.0), 0.75 / v);\n}\n";
    }
    throw std::invalid_argument("analytic_glsl: invalid term");
}

namespace {

class AnalyticApproximation final : public Approximation {
public:
    explicit AnalyticApproximation(analytic::AnalyticTerm t) : term_(t) {}
    std::string kind() const override { return "analytic"; }
    std::string name() const override { return analytic::to_string(term_); }
    Cost cost() const override {
        Cost c;
        c.alu_per_light = lutshader::count_alu(analytic_glsl(term_));
        c.storage = "none (part 1's formula)";
        return c;
    }
    double operator()(const Inputs& in) const override { return analytic_value(term_, in); }
    nlohmann::json provenance() const override {
        const Cost c = cost();
        return {{"kind", "analytic"},
                {"term", analytic::to_string(term_)},
                {"cost", {{"bytes", c.bytes}, {"fetches_per_light", c.fetches_per_light}, {"alu_per_light", c.alu_per_light}, {"storage", c.storage}}}};
    }

private:
    analytic::AnalyticTerm term_;
};

}  // namespace

std::shared_ptr<const Approximation> analytic_approximation(analytic::AnalyticTerm t) {
    return std::make_shared<const AnalyticApproximation>(t);
}

std::optional<analytic::AnalyticTerm> analytic_term_named(const std::string& name) {
    for (auto t : analytic::kAllAnalyticTerms)
        if (analytic::to_string(t) == name) return t;
    return std::nullopt;
}

std::string analytic_term_names() {
    std::string s;
    for (auto t : analytic::kAllAnalyticTerms) s += (s.empty() ? "" : ", ") + analytic::to_string(t);
    return s;
}

std::string closest_analytic_term(const std::string& word) {
    std::string best;
    // As the CLI's option suggestions: a few edits, and fewer than half the word's letters.
    std::size_t best_distance = std::min<std::size_t>(4, word.size() / 2 + 1);
    for (auto t : analytic::kAllAnalyticTerms) {
        const std::string name = analytic::to_string(t);
        const std::size_t d = edit_distance(word, name);
        if (d < best_distance) best = name, best_distance = d;
    }
    return best;
}

}  // namespace ms::approx
