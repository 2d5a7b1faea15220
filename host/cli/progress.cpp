#include "cli/progress.hpp"

#include <unistd.h>

#include <csignal>
#include <cstdio>

#include "core/cancel.hpp"

namespace ms::cli {

Progress::Progress(std::string label, bool quiet)
    : label_(std::move(label)), quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()), last_draw_(start_) {}

void Progress::update(std::size_t done, std::size_t total) {
    if (quiet_ || total == 0) return;
    const double fraction = double(done) / double(total);
    const auto now = std::chrono::steady_clock::now();
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (tty_) {
        if (done != total && now - last_draw_ < std::chrono::milliseconds(100)) return;
        last_draw_ = now;
        const int width = 30, filled = int(fraction * width);
        std::string bar(filled, '#');
        bar.resize(width, '.');
        std::fprintf(stderr, "\r%s [%s] %5.1f%% %zu/%zu %.1fs", label_.c_str(), bar.c_str(), 100 * fraction, done, total, elapsed);
        std::fflush(stderr);
        drawn_ = true;
    } else {
        const int decile = int(fraction * 10);
        if (decile == last_decile_) return;
        last_decile_ = decile;
        std::fprintf(stderr, "%s: %3d%% (%zu/%zu) %.1fs\n", label_.c_str(), decile * 10, done, total, elapsed);
    }
}

void Progress::finish() {
    if (drawn_) std::fprintf(stderr, "\n");
    drawn_ = false;
}

namespace {
extern "C" void on_interrupt(int) { cancel_requested().store(true); }
}  // namespace

void install_interrupt_handlers() {
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
}

}  // namespace ms::cli
