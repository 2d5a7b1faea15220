// What a caller hands a job's run(): where its progress goes, and how it asks the run to stop.
//
// Jobs stop cooperatively: the scheduler and the integrands poll ms::cancel_requested() between work
// items (core/cancel.hpp; the CLI raises it on SIGINT). A library caller that wants to stop one run
// gives `cancel` instead: the run asks it at every progress report and between its phases, and when it
// answers true the run raises the flag for itself, stops at the next check with ms::Cancelled, writes
// nothing, and lowers the flag again before returning, so a later run starts clean.
#pragma once

#include <cstdint>
#include <functional>

#include "core/cancel.hpp"

namespace ms {

struct JobCallbacks {
    // (work items done, work items) of the run's long phase; called on the calling thread.
    std::function<void(std::uint64_t done, std::uint64_t total)> progress;
    // Asked at each progress report and between phases; true stops the run (ms::Cancelled).
    std::function<bool()> cancel;
};

// The bridge of one run from JobCallbacks to the cancel flag (the facade's run_with_progress does the
// same for the public Progress). Lives for the run; its destructor lowers the flag if it raised it.
class JobControl {
public:
    explicit JobControl(const JobCallbacks& callbacks) : callbacks_(callbacks) {}
    JobControl(const JobControl&) = delete;
    JobControl& operator=(const JobControl&) = delete;
    ~JobControl() {
        if (raised_) cancel_requested() = false;
    }
    // The progress callback to hand the job's long phase.
    std::function<void(std::uint64_t, std::uint64_t)> progress() {
        return [this](std::uint64_t done, std::uint64_t total) {
            if (callbacks_.progress) callbacks_.progress(done, total);
            ask();
        };
    }
    // Between phases: throws ms::Cancelled when the caller asked to stop (or the flag is up).
    void checkpoint() {
        ask();
        throw_if_cancelled();
    }

private:
    void ask() {
        if (!raised_ && callbacks_.cancel && callbacks_.cancel()) {
            raised_ = true;
            cancel_requested() = true;
        }
    }
    const JobCallbacks& callbacks_;
    bool raised_ = false;
};

}  // namespace ms
