// Running the `microshadow` binary as a child process that a test can signal: start it (env and args
// through sh, which execs it, so a signal reaches the CLI and not a shell), wait for its exit status,
// or run it to completion with a timeout. Output goes to DIR/log.txt.
#pragma once

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "test_files.hpp"

extern char** environ;

namespace ms::testing {

// The binary under test: MICROSHADOW_CLI_UNDER_TEST when set (another build), else this build's.
inline std::string microshadow_under_test() {
    const char* other = std::getenv("MICROSHADOW_CLI_UNDER_TEST");
    return other && *other ? other : MICROSHADOW_CLI;
}

// Starts `env... microshadow args` in `dir`, appending its output to dir/log.txt; returns the CLI's pid.
inline pid_t spawn_microshadow(const std::filesystem::path& dir, const std::string& args, const std::string& env = "") {
    const std::string cmd = "cd " + dir.string() + " && exec env " + env + " " + microshadow_under_test() + " " + args +
                            " >>log.txt 2>&1 </dev/null";
    const char* argv[] = {"sh", "-c", cmd.c_str(), nullptr};
    pid_t pid = 0;
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return -1;
    return pid;
}

// The exit status, or minus the signal that ended the process.
inline int wait_for_exit(pid_t pid) {
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

struct ChildRun {
    int exit_code;
    double seconds;
    std::string log;
};

// Runs to completion; a hang becomes exit code 124 (timeout 120 s) instead of a stuck suite.
inline ChildRun run_microshadow(const std::filesystem::path& dir, const std::string& args, const std::string& env = "") {
    std::filesystem::remove(dir / "log.txt");
    const auto t0 = std::chrono::steady_clock::now();
    const int code = wait_for_exit(spawn_microshadow(dir, args, env + " timeout 120"));
    return {code, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), slurp_file(dir / "log.txt")};
}

}  // namespace ms::testing
