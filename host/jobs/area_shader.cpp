#include "jobs/area_shader.hpp"

#include "lut/shader/compose.hpp"
#include "lut/shader/wgsl.hpp"

namespace ms::area {

namespace {

// Written once in GLSL spelling; HLSL differs only in the vector type names and atan2 / rsqrt-free
// spellings below, substituted textually.
// The taps; the helpers they call (ms_area_angle, ms_area_lobe_weight, ms_rect_gauss_node/weight) are
// the shared ones (lut/shader/compose.hpp), put in front by taps_shader.
const char* kTaps = R"(// microshadow: the tap micro-shadowing of sphere lights (7 taps) and rectangle lights (9), docs/area-lights.md.
// T_taps = sum_k w_k W(wo_k) T(wo_k) / sum_k w_k W(wo_k): Radon's degree-5 disc rule on a tap cone
// (equal-area map), W = f cos of the lobe (Lambert 1/pi; GGX D G2 / (4 NdotV NdotL), height-correlated
// Smith, F = 1), T = ms_point_term(wi, wo), which the engine defines before this code.
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
// The 9-tap micro-shadowing of a rectangle light with corners p0, p0 + e1, p0 + e1 + e2, p0 + e2 (positions
// relative to the shaded point, tangent frame, any unit): the 3 x 3 Gauss-Legendre rule on a tap rectangle,
// each node weighted by the rule, the solid angle per unit area |n.wo| / d^2 and W = f cos.
float ms_rect_light_taps(vec3 wi, vec3 p0, vec3 e1, vec3 e2, float alpha_x, float alpha_y, int lobe) {
    vec3 n = normalize(cross(e1, e2));
    float d = dot(n, p0);
    if (d < 0.0) {
        n = -n;
        d = -d;
    }
    float ee1 = dot(e1, e1), ee2 = dot(e2, e2);
    float u0 = 0.0, u1 = 1.0, v0 = 0.0, v1 = 1.0;
    if (lobe == 1) {
        // Karis's point: the mirror ray's hit on the plane clamped to the rectangle (a ray parallel to or away
        // from the plane: the rectangle's point furthest along its in-plane direction).
        vec3 mirror = vec3(-wi.x, -wi.y, wi.z);
        float facing = dot(n, mirror);
        vec3 hit = facing > 1e-12 ? mirror * (d / facing) - p0
                                  : 0.5 * (e1 + e2) + (mirror - n * facing) * (1e6 * (sqrt(ee1) + sqrt(ee2)));
        float ur = clamp(dot(hit, e1) / ee1, 0.0, 1.0), vr = clamp(dot(hit, e2) / ee2, 0.0, 1.0);
        vec3 rep = normalize(p0 + ur * e1 + vr * e2);
        vec3 c = normalize(p0 + 0.5 * (e1 + e2));
        // The lobe's angle (or the angle from the mirror direction to the light, when it misses) against the
        // light's: a narrower lobe gets a tap rectangle of half-extent t tan(lobe) around Karis's point.
        float lobe_r = max(2.0 * atan(2.0 * sqrt(alpha_x * alpha_y), 1.0), ms_area_angle(rep, mirror));
        float radius = max(max(ms_area_angle(c, normalize(p0)), ms_area_angle(c, normalize(p0 + e1))),
                           max(ms_area_angle(c, normalize(p0 + e1 + e2)), ms_area_angle(c, normalize(p0 + e2))));
        if (lobe_r < radius) {
            float reach = d / dot(n, rep) * tan(lobe_r);
            float hu = min(0.5, reach / sqrt(ee1)), hv = min(0.5, reach / sqrt(ee2));
            float uc = clamp(ur, hu, 1.0 - hu), vc = clamp(vr, hv, 1.0 - hv);
            u0 = uc - hu;
            u1 = uc + hu;
            v0 = vc - hv;
            v1 = vc + hv;
        }
    }
    float num = 0.0, den = 0.0;
    for (int k = 0; k < 9; ++k) {
        int a = k / 3, b = k - 3 * (k / 3);
        vec3 p = p0 + (u0 + (u1 - u0) * ms_rect_gauss_node(a)) * e1 + (v0 + (v1 - v0) * ms_rect_gauss_node(b)) * e2;
        vec3 wo = normalize(p);
        float w = ms_rect_gauss_weight(a) * ms_rect_gauss_weight(b) * abs(dot(n, wo)) / dot(p, p) *
                  ms_area_lobe_weight(wi, wo, alpha_x, alpha_y, lobe);
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
    if (language == ShaderLanguage::wgsl) return lutshader::glsl_to_wgsl(taps_shader(ShaderLanguage::glsl));
    std::string s = kTaps;
    const std::size_t body = s.find("\nfloat ms_area_light_taps") + 1;
    std::string helpers;
    for (const char* name : {"ms_area_angle", "ms_area_lambda", "ms_area_lobe_weight", "ms_rect_gauss_node", "ms_rect_gauss_weight"})
        helpers += lutshader::shared_helper(name, lutshader::ShaderLanguage::glsl) + "\n";
    s.insert(body, helpers);
    if (language == ShaderLanguage::hlsl) {
        replace_all(s, "vec3", "float3");
        replace_all(s, "atan(", "atan2(");
    }
    return s;
}

}  // namespace ms::area
