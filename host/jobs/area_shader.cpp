#include "jobs/area_shader.hpp"

namespace ms::area {

namespace {

// Written once in GLSL spelling; HLSL differs only in the vector type names and atan2 / rsqrt-free
// spellings below, substituted textually.
const char* kTaps = R"(// microshadow: the 7-tap micro-shadowing of a sphere light (docs/area-lights.md).
// T_taps = sum_k w_k W(wo_k) T(wo_k) / sum_k w_k W(wo_k): Radon's degree-5 disc rule on a tap cone
// (equal-area map), W = f cos of the lobe (Lambert 1/pi; GGX D G2 / (4 NdotV NdotL), height-correlated
// Smith, F = 1), T = ms_point_term(wi, wo), which the engine defines before this code.
float ms_area_angle(vec3 a, vec3 b) { return atan(length(cross(a, b)), dot(a, b)); }

float ms_area_lambda(vec3 w, float ax, float ay) {
    float a = (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z);
    return a / (2.0 * (1.0 + sqrt(1.0 + a)));
}

float ms_area_lobe_weight(vec3 wi, vec3 wo, float ax, float ay, int lobe) {
    if (wo.z <= 0.0) return 0.0;
    if (lobe == 0) return wo.z * 0.31830988618;
    vec3 h = normalize(wi + wo);
    float ex = h.x / ax, ey = h.y / ay;
    float s = ex * ex + ey * ey + h.z * h.z;
    float d = 1.0 / (3.14159265359 * ax * ay * s * s);
    return d / (4.0 * wi.z * (1.0 + ms_area_lambda(wi, ax, ay) + ms_area_lambda(wo, ax, ay)));
}

float ms_area_light_taps(vec3 wi, vec3 centre, float half_angle, float alpha_x, float alpha_y, int lobe) {
    vec3 c = normalize(centre);
    // The tap cone: the light itself, or for a GGX lobe narrower than the light (radius 2 atan(2 alpha),
    // or the angle from the mirror direction to the light when it misses) a cone of the lobe's radius
    // around Karis's point, pulled towards the centre until it lies inside the light.
    vec3 cone_c = c;
    float cone_r = half_angle;
    if (lobe == 1) {
        vec3 mirror = vec3(-wi.x, -wi.y, wi.z);
        float lobe_r = max(2.0 * atan(2.0 * sqrt(alpha_x * alpha_y), 1.0), max(0.0, ms_area_angle(c, mirror) - half_angle));
        if (lobe_r < half_angle) {
            vec3 to_ray = mirror * dot(c, mirror) - c;
            float l = length(to_ray);
            float t = l > 0.0 ? min(1.0, sin(half_angle) / l) : 0.0;
            vec3 rep = normalize(c + to_ray * t);
            float off = ms_area_angle(c, rep), limit = half_angle - lobe_r;
            if (off > limit) rep = normalize(sin(off - limit) * c + sin(limit) * rep);  // slerp by angle
            cone_c = rep;
            cone_r = lobe_r;
        }
    }
    vec3 helper = abs(cone_c.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
    vec3 t1 = normalize(cross(helper, cone_c));
    vec3 t2 = cross(cone_c, t1);
    float sh = sin(0.5 * cone_r);
    float omc_cone = 2.0 * sh * sh;  // 1 - cos(cone_r)
    float cos_gamma = cos(half_angle);
    float num = 0.0, den = 0.0;
    for (int k = 0; k < 7; ++k) {
        float rho2 = k == 0 ? 0.0 : 0.66666666667;
        float rule = k == 0 ? 0.25 : 0.125;
        float phi = float(k - 1) * 1.0471975512;
        float omc = rho2 * omc_cone;
        float sin_t = sqrt(max(0.0, omc * (2.0 - omc)));
        vec3 wo = normalize(sin_t * (cos(phi) * t1 + sin(phi) * t2) + (1.0 - omc) * cone_c);
        float w = dot(wo, c) >= cos_gamma - 1e-6 ? rule * ms_area_lobe_weight(wi, wo, alpha_x, alpha_y, lobe) : 0.0;
        if (w > 0.0) {
            num += w * ms_point_term(wi, wo);
            den += w;
        }
    }
    return den > 0.0 ? num / den : 0.0;
}
)";

void replace_all(std::string& s, const std::string& from, const std::string& to) {
    for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
}

}  // namespace

std::string taps_shader(ShaderLanguage language) {
    std::string s = kTaps;
    if (language == ShaderLanguage::hlsl) {
        replace_all(s, "vec3", "float3");
        replace_all(s, "atan(", "atan2(");
    }
    return s;
}

}  // namespace ms::area
