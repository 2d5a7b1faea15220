// Interrupts (SIGINT/SIGTERM; Ctrl-C, Ctrl-Break and closing the console on Windows) and the abort
// note. POSIX and Win32 implementations (posix.cpp, win32.cpp).
#pragma once

#include <functional>
#include <string>

namespace ms::platform {

// The numbers the CLI reports interrupts by (exit status 128 + N, as a shell does) on every platform.
constexpr int kInterruptSignal = 2;   // SIGINT, Ctrl-C
constexpr int kTerminateSignal = 15;  // SIGTERM, Ctrl-Break, console close

// Calls `on_interrupt(signal)` on a thread of its own for every interrupt from then on. On POSIX the
// signals are blocked in the calling thread (and so in every thread and child it starts later) and
// taken with sigwait: call it before starting other threads. Returns false when it could not.
bool watch_interrupts(std::function<void(int)> on_interrupt);

// Writes `note` to standard error when the process aborts (SIGABRT), then aborts as it would have.
// The first call installs the handler; later calls change the text.
void set_abort_note(const std::string& note);

}  // namespace ms::platform
