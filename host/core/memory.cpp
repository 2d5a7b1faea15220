#include "core/memory.hpp"

#include <unistd.h>

#include <cstdio>

namespace ms {

std::uint64_t physical_memory() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? std::uint64_t(pages) * std::uint64_t(page) : 0;
}

std::string gib(std::uint64_t bytes) {
    char buf[32];
    const double g = double(bytes) / double(1ull << 30);
    std::snprintf(buf, sizeof buf, g >= 100 ? "%.0f GiB" : "%.3g GiB", g);
    return buf;
}

}  // namespace ms
