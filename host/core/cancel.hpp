// Cooperative cancellation: long jobs poll this flag between chunks and stop cleanly (the CLI sets
// it from SIGINT/SIGTERM). Nothing half-written is left behind because outputs are atomic files.
#pragma once

#include <atomic>
#include <stdexcept>

namespace ms {

inline std::atomic<bool>& cancel_requested() {
    static std::atomic<bool> flag{false};
    return flag;
}

class Cancelled : public std::runtime_error {
public:
    Cancelled() : std::runtime_error("interrupted; nothing was written") {}
};

inline void throw_if_cancelled() {
    if (cancel_requested().load()) throw Cancelled();
}

}  // namespace ms
