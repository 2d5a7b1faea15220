// The 7-tap area-light approximation (jobs/area.hpp, sphere_taps) as GLSL or HLSL source for engines:
//     float ms_area_light_taps(vec3 wi, vec3 centre, float half_angle, float alpha_x, float alpha_y, int lobe)
// (HLSL: float3), directions in the tangent frame (normal +z), half_angle in radians, lobe 0 = Lambert,
// 1 = GGX. It calls the engine's point lookup, which must be defined before the code:
//     float ms_point_term(vec3 wi, vec3 wo)
// (the LUT or representation lookup the engine uses for the sun, returning 0 for wo below the horizon).
// And the 9-tap approximation of rectangle lights (rect_taps):
//     float ms_rect_light_taps(vec3 wi, vec3 p0, vec3 e1, vec3 e2, float alpha_x, float alpha_y, int lobe)
// corners p0, p0 + e1, p0 + e1 + e2, p0 + e2, positions relative to the shaded point in the tangent frame.
#pragma once

#include <string>

#include "lut/shader/language.hpp"

namespace ms::area {

using ShaderLanguage = lutshader::ShaderLanguage;
std::string taps_shader(ShaderLanguage language);

}  // namespace ms::area
