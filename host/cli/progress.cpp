#include "cli/progress.hpp"

#include <atomic>

#include <pthread.h>
#include <unistd.h>

#include <csignal>
#include <string>
#include <cstdio>
#include <thread>

#include "core/cancel.hpp"

namespace ms::cli {

Progress::Progress(std::string label, bool quiet)
    : label_(std::move(label)), quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1),
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

// SIGINT/SIGTERM are blocked in every thread and taken by one thread with sigwait, instead of an
// asynchronous handler, because a blocked mask is inherited by child processes: PoCL runs its linker
// as a child while it compiles a kernel, and a terminal's Ctrl-C (sent to the whole process group)
// killed it mid-link, which made PoCL abort the process (exit 134) instead of the clean stop (130).
// Called before any other thread exists, so PoCL's own threads inherit the mask as well.
std::atomic<int>& last_signal() {
    static std::atomic<int> sig{0};
    return sig;
}

int interrupted_exit_status() {
    const int sig = last_signal().load();
    return 128 + (sig ? sig : SIGINT);  // the shell's convention: 130 for SIGINT, 143 for SIGTERM
}

void install_interrupt_handlers() {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    if (pthread_sigmask(SIG_BLOCK, &set, nullptr) != 0) return;  // keeps the default: die on the signal
    std::thread([set] {
        for (int received = 0;;) {
            int sig = 0;
            if (sigwait(&set, &sig) != 0) continue;
            last_signal().store(sig);
            cancel_requested().store(true);
            // The first signals ask the running batch to finish and stop cleanly; a third one means the
            // user will not wait for that (a long device batch): leave now, like an unhandled signal.
            if (++received >= 3) {
                // Outputs are renamed into place only when complete, so nothing half-written appears; a
                // temporary file may be left, and the next run that writes the same output removes it.
                static const char msg[] =
                    "\nmicroshadow: interrupted three times: exiting at once; files appear only when complete, and "
                    "a leftover temporary file is removed by the next run that writes the same output\n";
                (void)!::write(STDERR_FILENO, msg, sizeof msg - 1);
                ::_exit(128 + sig);
            }
        }
    }).detach();
}

}  // namespace ms::cli
