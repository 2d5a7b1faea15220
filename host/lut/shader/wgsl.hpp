// WGSL from the generators' GLSL: every generator writes its code once, in a small GLSL subset, and
// this translation gives the WGSL (web engines, Bevy), statement for statement, the same arithmetic:
// - functions `T name(T a, ...) { ... }` become `fn name(a: T, ...) -> T { ... }` (float f32, int i32,
//   vecN vecN<f32>, bool); a `sampler2D`/`sampler3D X` parameter becomes `X: texture_2d<f32>` /
//   `texture_3d<f32>` and `X_sampler: sampler`, and textureLod(X, c, l) textureSampleLevel(X, X_sampler, c, l);
// - declarations `T a = e, b = f;` become `let` (or `var` when assigned later) one per name;
//   `if` bodies get braces; `for (int k = 0; k < n; ++k)` becomes `for (var k: i32 = 0; k < n; k++)`;
// - `c ? a : b` becomes select(b, a, c) (both sides are evaluated: the subset has no side effects);
//   atan(y, x) atan2, float()/int() f32()/i32(), vecN() vecN<f32>(), inversesqrt inverseSqrt;
// - comments stay where they were.
// Anything outside the subset throws std::logic_error (a generator bug, caught by the tests).
#pragma once

#include <string>

namespace ms::lutshader {

std::string glsl_to_wgsl(const std::string& glsl);

}  // namespace ms::lutshader
