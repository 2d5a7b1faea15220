// Cooperative cancellation: long jobs poll this flag between chunks and stop cleanly (the CLI sets
// it from SIGINT/SIGTERM). Nothing half-written is left behind because outputs are atomic files.
#pragma once

#include <atomic>
#include <stdexcept>
#include <string>

namespace ms {

inline std::atomic<bool>& cancel_requested() {
    static std::atomic<bool> flag{false};
    return flag;
}

class Cancelled : public std::runtime_error {
public:
    Cancelled() : std::runtime_error("interrupted; nothing was written") {}
    // For jobs that keep part of their work (a sweep keeps its finished chunks): say what is kept.
    explicit Cancelled(const std::string& message) : std::runtime_error(message) {}
};

inline void throw_if_cancelled() {
    if (cancel_requested().load()) throw Cancelled();
}

}  // namespace ms
