// Processes: identity, liveness, the terminal, the running executable, and running another program
// without a shell. POSIX and Win32 implementations (posix.cpp, win32.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <system_error>
#include <vector>

namespace ms::platform {

long process_id();
// Whether a process with this id may still exist (a process we may not signal counts as existing).
bool process_exists(long pid);
// The machine's name, as the system gives it (empty when it cannot).
std::string host_name();
// A name of the running user fit for a file name (the uid on POSIX, the user name on Windows).
std::string user_tag();
bool is_terminal(int fd);
// The running executable's path (/proc/self/exe; GetModuleFileName on Windows).
std::string executable_path(std::error_code& ec);
// Every program `name` on PATH, in PATH's order (with PATHEXT's extensions on Windows); a name with a
// directory part is only checked.
std::vector<std::string> find_on_path(const std::string& name);

struct ProcessEnd {
    bool exited = false;  // ended by exit (else by a signal)
    int code = 0;         // the exit status, or the signal's number
};
// Runs argv[0] (a path, or a name looked up on PATH) with `argv` as its arguments, no shell involved,
// with the default handling of interrupts (the CLI blocks them in its own threads), and waits for it.
// `stop` (when given) is asked every 50 ms while the child runs: when it answers true the child is ended
// (SIGTERM; TerminateProcess) and waited for, so a signal sent to this process alone (a batch system's
// SIGTERM) does not leave it waiting on the child. Throws std::system_error when it cannot be started.
ProcessEnd run_program(const std::vector<std::string>& argv, const std::function<bool()>& stop = {});

// Sets an environment variable for this process and the children it starts (setenv; _putenv_s).
int set_environment(const std::string& name, const std::string& value);

// Runs `command` through the system's shell (sh -c; cmd.exe /c on Windows) and collects its standard
// output. Returns its exit status, or -1 when it did not exit normally or could not be started.
int run_shell_command(const std::string& command, std::string& output);

// Ends the process at once with `status`, running no destructors or atexit handlers (_exit).
[[noreturn]] void exit_now(int status);

}  // namespace ms::platform
