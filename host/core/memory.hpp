// The machine's memory, for the checks jobs make before they allocate (a bake's atlas, a point set).
#pragma once

#include <cstdint>
#include <string>

namespace ms {

// Physical memory in bytes (sysconf), 0 when unknown.
std::uint64_t physical_memory();
// "1.5 GiB", for memory figures in messages.
std::string gib(std::uint64_t bytes);

}  // namespace ms
