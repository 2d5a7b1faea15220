// An ALU estimate of generated shader code, for the cost models of comparators (compare::ComparatorCost):
// arithmetic operators, comparisons and intrinsic calls outside comments, each counted once whatever its
// vector width; texture fetches are not counted; every line counts once (both arms of a branch).
#pragma once

#include <string>

namespace ms::lutshader {

unsigned count_alu(const std::string& shader_source);

}  // namespace ms::lutshader
