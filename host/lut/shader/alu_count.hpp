// An ALU estimate of generated shader code, for the cost models of comparators (approx::Cost),
// counted one way for every candidate: each binary + - * / and comparison is 1, each ?: select 1, each
// call of a built-in function 1 except pow (3: log2, mul, exp2 as GPUs compile it); texture fetches are
// not ALU (they are fetches). Comments, preprocessor lines, declarations and literals (an exponent's sign
// included) cost nothing; vector width is ignored; both arms of a branch count. An estimate, but the
// same estimate for every candidate.
#pragma once

#include <string>

namespace ms::lutshader {

unsigned count_alu(const std::string& shader_source);

}  // namespace ms::lutshader
