// The shading languages the generators write (LUT, representation and area-light shaders alike).
#pragma once

#include <string>

namespace ms::lutshader {

// WGSL is translated from the GLSL (lut/shader/wgsl.hpp).
enum class ShaderLanguage { glsl, hlsl, wgsl };
ShaderLanguage parse_shader_language(const std::string&);  // "glsl" | "hlsl" | "wgsl"; std::invalid_argument
std::string to_string(ShaderLanguage);

}  // namespace ms::lutshader
