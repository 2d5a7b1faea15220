// Loading a shared library at run time (dlopen; LoadLibrary on Windows).
#pragma once

#include <string>

namespace ms::platform {

// The library's handle, or nullptr with the system's reason in `error`.
void* open_library(const std::string& name, std::string& error);
// The address of `symbol` in `library`, or nullptr.
void* library_symbol(void* library, const char* symbol);

}  // namespace ms::platform
