#include "core/lookup_domain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace ms {

namespace {

std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

std::string range(double lo, double hi) { return "[" + number(lo) + ", " + number(hi) + "]"; }

bool within(double x, double lo, double hi) { return x >= lo && x <= hi; }  // false for NaN

// What an anisotropic domain checks of a surface: each axis's roughness sqrt(alpha) and the ratio.
struct AxisRoughness {
    double x, y, ratio;
};
AxisRoughness axis_roughness(double roughness, double alpha_x, double alpha_y) {
    if (!(alpha_x > 0 && alpha_y > 0)) return {roughness, roughness, 1.0};
    return {std::sqrt(alpha_x), std::sqrt(alpha_y), std::max(alpha_x, alpha_y) / std::min(alpha_x, alpha_y)};
}

}  // namespace

bool LookupDomain::contains(double visibility, double n_dot_l, double n_dot_v, double roughness, double alpha_x,
                            double alpha_y) const {
    return first_outside(visibility, n_dot_l, n_dot_v, roughness, alpha_x, alpha_y).empty();
}

std::string LookupDomain::describe() const {
    std::string s = "roughness " + range(roughness_min, roughness_max) + ", visibility " + range(visibility_min, visibility_max) +
                    ", NdotV " + range(n_dot_v_min, n_dot_v_max);
    if (n_dot_l_min > -1 || n_dot_l_max < 1) s += ", NdotL " + range(n_dot_l_min, n_dot_l_max);
    if (max_alpha_ratio > 0) s += ", alpha ratio [1, " + number(max_alpha_ratio) + "] (roughness per axis)";
    return s;
}

std::string LookupDomain::first_outside(double visibility, double n_dot_l, double n_dot_v, double roughness, double alpha_x,
                                       double alpha_y) const {
    if (max_alpha_ratio > 0) {
        const AxisRoughness a = axis_roughness(roughness, alpha_x, alpha_y);
        if (!within(a.ratio, 1, max_alpha_ratio)) return "alpha ratio " + number(a.ratio) + " outside " + range(1, max_alpha_ratio);
        if (!within(a.x, roughness_min, roughness_max)) return "sqrt(alpha_x) " + number(a.x) + " outside " + range(roughness_min, roughness_max);
        if (!within(a.y, roughness_min, roughness_max)) return "sqrt(alpha_y) " + number(a.y) + " outside " + range(roughness_min, roughness_max);
    }
    const double x[4] = {roughness, visibility, n_dot_v, n_dot_l};
    const double lo[4] = {roughness_min, visibility_min, n_dot_v_min, n_dot_l_min};
    const double hi[4] = {roughness_max, visibility_max, n_dot_v_max, n_dot_l_max};
    const char* names[4] = {"roughness", "visibility", "NdotV", "NdotL"};
    // An anisotropic domain has checked the roughness per axis (the isotropic equivalent, their
    // geometric mean, lies between them).
    for (int k = max_alpha_ratio > 0 ? 1 : 0; k < 4; ++k)
        if (!within(x[k], lo[k], hi[k])) return std::string(names[k]) + " " + number(x[k]) + " outside " + range(lo[k], hi[k]);
    return "";
}

nlohmann::json LookupDomain::to_json(const std::string& what) const {
    nlohmann::json j = {{"visibility", {visibility_min, visibility_max}},
                        {"n_dot_l", {n_dot_l_min, n_dot_l_max}},
                        {"n_dot_v", {n_dot_v_min, n_dot_v_max}},
                        {"roughness", {roughness_min, roughness_max}},
                        {"outside", refuse_outside ? "refused" : "counted"}};
    if (max_alpha_ratio > 0) j["alpha_ratio"] = {1.0, max_alpha_ratio};
    if (!what.empty()) j["what"] = what;
    return j;
}

LookupDomain LookupDomain::from_json(const nlohmann::json& d, const std::string& source) {
    LookupDomain out;
    if (!d.is_object()) throw std::runtime_error(source + ": metadata domain must be an object");
    double* fields[4][2] = {{&out.visibility_min, &out.visibility_max},
                            {&out.n_dot_l_min, &out.n_dot_l_max},
                            {&out.n_dot_v_min, &out.n_dot_v_max},
                            {&out.roughness_min, &out.roughness_max}};
    const char* axes[4] = {"visibility", "n_dot_l", "n_dot_v", "roughness"};
    for (int k = 0; k < 4; ++k) {
        const char* axis = axes[k];
        if (!d.contains(axis) || !d.at(axis).is_array() || d.at(axis).size() != 2 || !d.at(axis)[0].is_number() ||
            !d.at(axis)[1].is_number() || !(d.at(axis)[0].get<double>() <= d.at(axis)[1].get<double>()) ||
            !std::isfinite(d.at(axis)[0].get<double>()) || !std::isfinite(d.at(axis)[1].get<double>()))
            throw std::runtime_error(source + ": metadata domain." + axis + " must be [min, max]");
        *fields[k][0] = d.at(axis)[0].get<double>();
        *fields[k][1] = d.at(axis)[1].get<double>();
    }
    if (d.contains("alpha_ratio")) {
        const auto& r = d.at("alpha_ratio");
        if (!r.is_array() || r.size() != 2 || !r[0].is_number() || !r[1].is_number() || r[0].get<double>() != 1 ||
            !(r[1].get<double>() >= 1 && r[1].get<double>() <= 1e6))
            throw std::runtime_error(source + ": metadata domain.alpha_ratio must be [1, max] with max in [1, 1e6]");
        out.max_alpha_ratio = r[1].get<double>();
    }
    // Files written before "outside" existed are the scene-fitted LUTs, whose lookups refuse.
    if (!d.contains("outside")) {
        out.refuse_outside = true;
    } else if (d.at("outside") == "refused") {
        out.refuse_outside = true;
    } else if (d.at("outside") != "counted") {
        throw std::runtime_error(source + ": metadata domain.outside must be \"counted\" or \"refused\"");
    }
    return out;
}

}  // namespace ms
