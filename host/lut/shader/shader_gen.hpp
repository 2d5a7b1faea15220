// GLSL and HLSL for sampling a baked LUT in a renderer, generated from the file's own axes, texel
// convention, channels and AO weighting so the shader cannot disagree with the file.
//
// The generated function ms_micro_shadowing(lut, visibility, NdotL, NdotV, roughness) does what
// host/lut/lookup.cpp (the sweeps' `lut3d` comparator) does, on the GPU:
// - per axis, the texel coordinate t = (p - min) / (max - min) * n - 0.5 (texel centres) or
//   (p - min) / (max - min) * (n - 1) (endpoints), clamped to [0, n - 1]; the texture coordinate is
//   uv = (t + 0.5) / n, which a linear, clamp-to-edge sampler turns back into exactly t;
// - one filtered fetch (3D texture, or 2D for a single NdotV slice), then the roughness blend: r is
//   clamped to the channel range and the two channels that bracket it are mixed linearly;
// - an early-out to exactly 0 where the term is 0 for every roughness and view: NdotL <= 0, or inside
//   the zero region (cosine AO: 2 v + NdotL <= 1; uniform AO: NdotL <= 2 (1 - v)^2 - 1).
// Anisotropic surfaces: use roughness = (alpha_x alpha_y)^(1/4), the isotropic roughness with the same
// geometric-mean alpha (as the sweeps do, host/jobs/sweep/points.hpp).
#pragma once

#include <string>

#include "lut/exr_lut.hpp"
#include "lut/shader/language.hpp"

namespace ms::lutshader {

// The shader source (a function library to paste or #include; no entry point). `source_name` is
// recorded in the comment (the LUT file the code was made for).
std::string generate_shader(const LutFile& lut, ShaderLanguage language, const std::string& source_name);

// Writes generate_shader's output, composable (lut/shader/compose.hpp: names prefixed with `prefix`, or
// with default_prefix(path) when it is empty; include guard), atomically.
void write_shader(const std::string& path, const LutFile& lut, ShaderLanguage language, const std::string& source_name,
                  const std::string& prefix = "");

}  // namespace ms::lutshader
