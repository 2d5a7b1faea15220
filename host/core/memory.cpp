#include "core/memory.hpp"

#include <cstdio>

#include "platform/memory.hpp"

namespace ms {

std::uint64_t physical_memory() { return platform::physical_memory(); }

std::string gib(std::uint64_t bytes) {
    char buf[32];
    const double g = double(bytes) / double(1ull << 30);
    std::snprintf(buf, sizeof buf, g >= 100 ? "%.0f GiB" : "%.3g GiB", g);
    return buf;
}

}  // namespace ms
