// What the public facade's files share (host/api/): the translations of its option types into the jobs'
// and the bridge from a public Progress to the jobs' cooperative cancellation.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>

#include "core/cancel.hpp"
#include "core/types.hpp"
#include "jobs/eval.hpp"
#include "microshadow/types.hpp"

namespace microshadow::detail {

ms::TermOptions term_options(AoWeighting weighting, Form form);
ms::AoWeighting to_ms(AoWeighting w);
ms::Sequence to_ms(Sequence s);
// The public Backend, device and threads as the one type every job's options hold: the only place the
// library maps its enum (the fault-injection test hook is then read by the scheduler, as for the CLI).
ms::schedule::BackendSpec backend_spec(Backend backend, const std::string& device, unsigned threads = 0);
std::unique_ptr<ms::TermBackend> make_backend(Backend backend, const std::string& device, bool fast_math);

// Runs `job(report)`, where `report(done, total)` forwards to `progress`; when progress returns false
// the jobs' cancel flag is raised, the job stops at its next check (ms::Cancelled) and this throws
// microshadow::Cancelled. The flag is lowered again before returning, so a later call starts clean.
template <class Job>
auto run_with_progress(const Progress& progress, Job&& job) {
    std::atomic<bool> stop_asked{false};
    auto report = [&](std::uint64_t done, std::uint64_t total) {
        if (progress && !stop_asked.load() && !progress(done, total)) {
            stop_asked = true;
            ms::cancel_requested() = true;
        }
    };
    struct LowerFlag {
        std::atomic<bool>& asked;
        ~LowerFlag() {
            if (asked.load()) ms::cancel_requested() = false;
        }
    } lower{stop_asked};
    try {
        auto result = job(report);
        // Asked to stop on the last report: the caller still gets the stop it asked for.
        if (stop_asked.load()) throw Cancelled();
        return result;
    } catch (const ms::Cancelled& e) {
        throw Cancelled(e.what());
    }
}

}  // namespace microshadow::detail
