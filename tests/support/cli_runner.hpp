// Helpers shared by the tests that run the `microshadow` binary: a shell command's exit code and
// output, and a fixture with a scratch directory named after the running test.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "platform/process.hpp"

namespace ms::testing {

struct RunResult {
    int exit_code;  // -1 when killed by a signal
    std::string output;  // stdout and whatever the command redirects into it
};

// Runs `command` through the shell (sh; cmd.exe on Windows) and collects its stdout. A Windows program
// writes its console text with \r\n line ends; they are read as \n, so one expected text fits both.
inline RunResult run_shell(const std::string& command) {
    std::string out;
    const int code = platform::run_shell_command(command, out);
#ifdef _WIN32
    std::string lf;
    for (std::size_t i = 0; i < out.size(); ++i)
        if (!(out[i] == '\r' && i + 1 < out.size() && out[i + 1] == '\n')) lf += out[i];
    out.swap(lf);
#endif
    return {code, out};
}

// A path as one word of the shell's command line: sh's single quotes, cmd.exe's double quotes.
inline std::string shell_quote(const std::string& path) {
#ifdef _WIN32
    return "\"" + path + "\"";
#else
    return "'" + path + "'";
#endif
}

// The shell's words for "in this folder, with these variables set, run": sh's cd and VAR='value'
// prefixes, or cmd.exe's cd /d (which also changes the drive) and set "VAR=value" &&.
using ShellVariables = std::vector<std::pair<std::string, std::string>>;
inline std::string shell_prefix(const std::filesystem::path& dir, const ShellVariables& variables = {}) {
#ifdef _WIN32
    std::string s = "cd /d \"" + dir.string() + "\" && ";
    for (const auto& [name, value] : variables) s += "set \"" + name + "=" + value + "\" && ";
#else
    std::string s = "cd '" + dir.string() + "' && ";
    for (const auto& [name, value] : variables) s += name + "='" + value + "' ";
#endif
    return s;
}

// Runs this build's `microshadow ARGS` with stderr joined to stdout.
inline RunResult cli(const std::string& args) { return run_shell(std::string(MICROSHADOW_CLI) + " " + args + " 2>&1"); }

// A fresh, empty directory per test (prefix + pid + test name), removed afterwards.
class ScratchDirTest : public ::testing::Test {
protected:
    explicit ScratchDirTest(std::string prefix) : prefix_(std::move(prefix)) {}
    void SetUp() override {
        dir_ = std::filesystem::temp_directory_path() /
               ("microshadow_" + prefix_ + "_" + std::to_string(platform::process_id()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    std::filesystem::path dir_;

private:
    std::string prefix_;
};

}  // namespace ms::testing
