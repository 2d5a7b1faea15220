// Generated shaders that compose: any set of files the generators write (LUTs of any layout,
// representations, the area-light taps) can be included or pasted into one shader.
// - Each file's own names carry a prefix the caller chooses (`--shader-prefix`; by default the output
//   file's name, so lut_a.glsl defines lut_a_micro_shadowing, lut_a_lut_coord, ...): the generators write
//   `ms_` names and compose() renames them.
// - Each file's own code sits inside an include guard, MICROSHADOW_<prefix>_INCLUDED, so including one
//   file twice is harmless.
// - The helpers that do not depend on the file (asinh, the area-light lobe weights, the rectangle rule)
//   keep their `ms_` names and live in one common block, the same in every file that uses them and
//   guarded by one macro: the first file included defines them, the others skip them.
#pragma once

#include <string>
#include <vector>

#include "lut/shader/language.hpp"

namespace ms::lutshader {

// A file-independent helper in GLSL spelling, with the comment that precedes it; generators emit
// shared_helper(name, language) so that compose() finds the same text.
std::string shared_helper(const std::string& name, ShaderLanguage language);

// The common block: every shared helper in `language`, inside the one guard.
std::string common_block(ShaderLanguage language);

// The prefix an output file gets when the caller names none: its stem with every character outside
// [A-Za-z0-9_] turned into '_' (runs collapsed), "ms_" put in front of a leading digit; "ms" for
// standard output ("" or "-").
std::string default_prefix(const std::string& output_path);

// Throws std::invalid_argument unless `prefix` can start every name in every language: a letter, then
// letters, digits or single underscores, not ending in '_' and not starting with "gl_" (reserved).
void check_prefix(const std::string& prefix);

// The composable file: a generator's text (written with `ms_` names) with its own names renamed to
// `prefix_`, its shared helpers moved into the common block and the rest inside its include guard.
std::string compose(const std::string& generated, ShaderLanguage language, const std::string& prefix);

}  // namespace ms::lutshader
