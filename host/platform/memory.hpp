// Memory queries (POSIX and Win32 implementations in posix.cpp, win32.cpp).
#pragma once

#include <cstdint>

namespace ms::platform {

// The machine's physical memory in bytes; 0 when the system does not say.
std::uint64_t physical_memory();

}  // namespace ms::platform
