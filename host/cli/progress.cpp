#include "cli/progress.hpp"

#include <atomic>
#include <string>
#include <cstdio>

#include "core/cancel.hpp"
#include "platform/files.hpp"
#include "platform/process.hpp"
#include "platform/signals.hpp"

namespace ms::cli {

Progress::Progress(std::string label, bool quiet)
    : label_(std::move(label)), quiet_(quiet), tty_(platform::is_terminal(platform::kStandardError)),
      start_(std::chrono::steady_clock::now()), last_draw_(start_) {}

std::string format_duration(double seconds) {
    char buf[48];
    if (!(seconds >= 0)) seconds = 0;
    if (seconds < 10) std::snprintf(buf, sizeof buf, "%.1f s", seconds);
    else if (seconds < 60) std::snprintf(buf, sizeof buf, "%.0f s", seconds);
    else if (seconds < 3600) std::snprintf(buf, sizeof buf, "%d min %02d s", int(seconds) / 60, int(seconds) % 60);
    else std::snprintf(buf, sizeof buf, "%d h %02d min", int(seconds) / 3600, int(seconds) / 60 % 60);
    return buf;
}

std::string progress_text(const std::string& label, std::size_t done, std::size_t total, double elapsed, bool bar) {
    const double fraction = total ? double(done) / double(total) : 1.0;
    std::string eta;
    if (done > 0 && done < total) eta = ", about " + format_duration(elapsed * double(total - done) / double(done)) + " left";
    char head[160];
    if (bar) {
        const int width = 30, filled = int(fraction * width);
        std::string cells(filled, '#');
        cells.resize(width, '.');
        std::snprintf(head, sizeof head, " [%s] %5.1f%% %zu/%zu, ", cells.c_str(), 100 * fraction, done, total);
    } else {
        std::snprintf(head, sizeof head, ": %3d%% (%zu/%zu) ", int(fraction * 10) * 10, done, total);
    }
    return label + head + format_duration(elapsed) + eta;
}

void Progress::update(std::size_t done, std::size_t total) {
    if (quiet_ || total == 0) return;
    const double fraction = double(done) / double(total);
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (tty_) {
        if (done != total && now - last_draw_ < std::chrono::milliseconds(100)) return;
        last_draw_ = now;
        // Cleared to the end of the line: the estimate's text can shrink between draws.
        std::fprintf(stderr, "\r%s\033[K", progress_text(label_, done, total, elapsed, true).c_str());
        std::fflush(stderr);
        drawn_ = true;
    } else {
        const int decile = int(fraction * 10);
        if (decile == last_decile_) return;
        last_decile_ = decile;
        std::fprintf(stderr, "%s\n", progress_text(label_, done, total, elapsed, false).c_str());
    }
}

void Progress::finish() {
    if (drawn_) std::fprintf(stderr, "\n");
    drawn_ = false;
}

// SIGINT/SIGTERM (Ctrl-C, Ctrl-Break and closing the console on Windows) are taken by one thread of
// platform::watch_interrupts, which on POSIX blocks them in every thread (PoCL's linker, a child
// process, must not die of a terminal's Ctrl-C mid-link: PoCL would abort the process, exit 134,
// instead of the clean stop, 130). Called before any other thread exists, so PoCL's own threads
// inherit the mask as well.
std::atomic<int>& last_signal() {
    static std::atomic<int> sig{0};
    return sig;
}

int interrupted_exit_status() {
    const int sig = last_signal().load();
    return 128 + (sig ? sig : platform::kInterruptSignal);  // the shell's convention: 130 for SIGINT, 143 for SIGTERM
}

void install_interrupt_handlers() {
    // When it cannot, the default stays: die on the signal.
    platform::watch_interrupts([](int sig) {
        static std::atomic<int> received{0};  // Windows may run two console events' handlers at once
        {
            last_signal().store(sig);
            cancel_requested().store(true);
            // The first signals ask the running batch to finish and stop cleanly; a third one means the
            // user will not wait for that (a long device batch): leave now, like an unhandled signal.
            if (received.fetch_add(1) + 1 >= 3) {
                // Outputs are renamed into place only when complete, so nothing half-written appears; a
                // temporary file may be left, and the next run that writes the same output removes it.
                static const char msg[] =
                    "\nmicroshadow: interrupted three times: exiting at once; files appear only when complete, and "
                    "a leftover temporary file is removed by the next run that writes the same output\n";
                (void)!platform::write_some(platform::kStandardError, msg, sizeof msg - 1);
                platform::exit_now(128 + sig);
            }
        }
    });
}

}  // namespace ms::cli
