// microshadow as a C++ library: the generic VNDF-based micro-shadowing term of a rough GGX
// microsurface, evaluated on queries, baked into LUTs, and looked up from LUT files.
//
// This umbrella header is the whole public API (types.hpp, evaluate.hpp, lut.hpp, analytic.hpp,
// sweep.hpp, ibl.hpp, area.hpp, scene.hpp, design.hpp; docs/library.md
// has a worked example). It uses only the standard library; the engine behind it (the term and
// LUT-slice integrands on the scheduler, OpenCL kernels or the double-precision oracle) is linked in
// through the microshadow::microshadow target:
//
//     find_package(microshadow CONFIG REQUIRED)
//     target_link_libraries(app PRIVATE microshadow::microshadow)
//
// Errors: a bad argument throws std::invalid_argument naming the field and value; a failure while
// running (no OpenCL device, a device failing on every retry, an unreadable file) throws
// std::runtime_error. Nothing here prints or exits.
#pragma once

#include <string>

#include "microshadow/analytic.hpp"
#include "microshadow/area.hpp"
#include "microshadow/design.hpp"
#include "microshadow/evaluate.hpp"
#include "microshadow/ibl.hpp"
#include "microshadow/lut.hpp"
#include "microshadow/scene.hpp"
#include "microshadow/sweep.hpp"
#include "microshadow/types.hpp"

namespace microshadow {

// The library's version ("0.1.0").
std::string version();

}  // namespace microshadow
