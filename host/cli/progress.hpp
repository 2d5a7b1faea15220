// Progress reporting on stderr: a redrawn bar on a terminal, a plain line every 10% otherwise.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace ms::cli {

// "12 s", "4 min 05 s", "2 h 07 min": a duration as a person reads it.
std::string format_duration(double seconds);
// The text of one progress report: "LABEL [####......]  40.0% 52/128, 8.3 s, about 12 s left" on a
// terminal (`bar`), "LABEL:  40% (52/128) 8.3 s, about 12 s left" otherwise. The estimate of the time
// left assumes the rest goes at the pace so far; none is given before any work is done or at the end.
std::string progress_text(const std::string& label, std::size_t done, std::size_t total, double elapsed_seconds, bool bar);

class Progress {
public:
    Progress(std::string label, bool quiet = false);
    void update(std::size_t done, std::size_t total);
    void finish();

private:
    std::string label_;
    bool quiet_, tty_;
    int last_decile_ = -1;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point start_, last_draw_;
};

// SIGINT/SIGTERM set ms::cancel_requested() (taken by a dedicated thread; call before starting any
// other thread). A third signal exits at once with status 130.
void install_interrupt_handlers();
// 128 + the signal that interrupted the run (130 SIGINT, 143 SIGTERM; 130 when cancelled otherwise).
int interrupted_exit_status();

}  // namespace ms::cli
