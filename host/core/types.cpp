#include "core/types.hpp"

#include <stdexcept>

namespace ms {

std::string to_string(AoWeighting w) { return w == AoWeighting::cosine ? "cosine" : "uniform"; }
std::string to_string(Form f) { return f == Form::height_correlated ? "height-correlated" : "uncorrelated"; }
std::string to_string(Sequence s) { return s == Sequence::sobol ? "sobol" : "random"; }
std::string to_string(Method m) { return m == Method::sampled ? "sampled" : "exact"; }

AoWeighting parse_ao_weighting(const std::string& s) {
    if (s == "cosine") return AoWeighting::cosine;
    if (s == "uniform") return AoWeighting::uniform;
    throw std::invalid_argument("unknown AO weighting '" + s + "' (expected cosine or uniform)");
}

Form parse_form(const std::string& s) {
    if (s == "height-correlated") return Form::height_correlated;
    if (s == "uncorrelated") return Form::uncorrelated;
    throw std::invalid_argument("unknown form '" + s + "' (expected height-correlated or uncorrelated)");
}

Sequence parse_sequence(const std::string& s) {
    if (s == "sobol") return Sequence::sobol;
    if (s == "random") return Sequence::random;
    throw std::invalid_argument("unknown sequence '" + s + "' (expected sobol or random)");
}

Method parse_method(const std::string& s) {
    if (s == "sampled") return Method::sampled;
    if (s == "exact") return Method::exact;
    throw std::invalid_argument("unknown method '" + s + "' (expected exact or sampled)");
}

}  // namespace ms
