#include "cli/plot_runner.hpp"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "cli/common.hpp"
#include "io/text.hpp"

extern char** environ;

namespace ms::cli {

namespace fs = std::filesystem;

std::string find_plot_script(const std::string& name) {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw std::runtime_error("--plot: cannot find the executable's path (/proc/self/exe: " + ec.message() + ")");
    const fs::path bin = exe.parent_path();
    std::vector<fs::path> candidates = {bin / ".." / "share" / "microshadow" / name, bin / ".." / "scripts" / name};
    std::ifstream cache(bin / "CMakeCache.txt");
    for (std::string line; std::getline(cache, line);)
        if (line.rfind("CMAKE_HOME_DIRECTORY:INTERNAL=", 0) == 0)
            candidates.push_back(fs::path(line.substr(line.find('=') + 1)) / "scripts" / name);
    std::string looked;
    for (const auto& c : candidates) {
        if (fs::is_regular_file(c, ec)) return c.lexically_normal().string();
        looked += "\n  " + c.lexically_normal().string();
    }
    throw std::runtime_error("--plot: " + name + " not found; looked in:" + looked);
}

void run_plotter(const std::vector<std::string>& args, const std::string& what_is_done) {
    std::string shown;
    for (const auto& a : args) shown += (shown.empty() ? "" : " ") + shell_quote(a);
    // Not echoed: the plotter prints the figures it wrote; a failure names the command line.
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    // The CLI blocks SIGINT/SIGTERM in every thread (progress.cpp) and a spawned child inherits that
    // mask: give the plotter the default mask and dispositions so Ctrl-C stops it too.
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t none, defaults;
    sigemptyset(&none);
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGINT);
    sigaddset(&defaults, SIGTERM);
    sigaddset(&defaults, SIGPIPE);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    std::cout.flush();
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0], nullptr, &attr, argv.data(), environ);
    posix_spawnattr_destroy(&attr);
    if (rc != 0) throw std::runtime_error("--plot: cannot run " + args[0] + ": " + std::strerror(rc));
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) throw std::runtime_error(std::string("--plot: waitpid: ") + std::strerror(errno));
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
    // The plotter's own status becomes the command's (128 + N for a signal, as a shell reports it).
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    throw ExitError(code, "plotting failed (" +
                              (WIFEXITED(status) ? "exit status " + std::to_string(code)
                                                 : "killed by signal " + std::to_string(WTERMSIG(status))) +
                              "): " + shown + "; " + what_is_done);
}

}  // namespace ms::cli
