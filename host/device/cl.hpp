// The one place that includes Khronos' C++ bindings, with the project's configuration (CMake sets
// CL_HPP_TARGET_OPENCL_VERSION=120, CL_HPP_MINIMUM_OPENCL_VERSION=120 and CL_HPP_ENABLE_EXCEPTIONS).
#pragma once

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wignored-attributes"
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
#include <CL/opencl.hpp>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif
