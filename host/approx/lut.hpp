// Part 2's baked LUTs as approximations: the renderer-style lookup (lut/lookup.hpp) at (visibility,
// NdotL, NdotV, roughness); the LUT knows no AO weighting (it was baked with one) and no azimuth.
#pragma once

#include <memory>
#include <string>

#include "approx/approximation.hpp"
#include "lut/lookup.hpp"

namespace ms::approx {

double lut_value(const LutLookup& lut, const Inputs& in);

// The LUT as an engine ships it: R16F, RG16F, or RGBA16F for three or four channels (no RGB16F on most
// GPUs), one filtered fetch, and the ALU of the shader `microshadow shader` generates for it (named
// after `source_name`, the file).
Cost lut_cost(const LutFile& f, const std::string& source_name);

// A LUT read from `path` in any format the tool writes (LutLookup::open). Throws std::runtime_error
// naming the file.
std::shared_ptr<const Approximation> open_lut(const std::string& path);
// The same over a lookup already read (`path` names it in the cost's shader and the provenance).
std::shared_ptr<const Approximation> lut_approximation(std::shared_ptr<const LutLookup> lut, const std::string& path);

}  // namespace ms::approx
