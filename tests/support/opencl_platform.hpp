// Whether the default OpenCL device is PoCL's: tests of PoCL's own behaviour (its POCL_DEVICES list,
// its kernel cache's files, its compiler's messages) skip on other platforms, where the same commands
// are checked by the platform-neutral tests.
#pragma once

#include <string>

#include "device/runtime.hpp"

namespace ms::testing {

inline bool default_device_is_pocl() {
    const std::vector<ocl::DeviceInfo> devices = ocl::select_devices("default");
    return !devices.empty() && devices.front().platform.find("Portable Computing Language") != std::string::npos;
}

#define MS_SKIP_UNLESS_POCL()                                                                           \
    do {                                                                                                \
        if (!::ms::testing::default_device_is_pocl())                                                  \
            GTEST_SKIP() << "tests PoCL's own behaviour; the default OpenCL device is another platform's"; \
    } while (0)

}  // namespace ms::testing
