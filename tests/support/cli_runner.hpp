// Helpers shared by the tests that run the `microshadow` binary: a shell command's exit code and
// output, and a fixture with a scratch directory named after the running test.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "platform/process.hpp"

namespace ms::testing {

struct RunResult {
    int exit_code;  // -1 when killed by a signal
    std::string output;  // stdout and whatever the command redirects into it
};

// Runs `command` through the shell (sh; cmd.exe on Windows) and collects its stdout.
inline RunResult run_shell(const std::string& command) {
    std::string out;
    const int code = platform::run_shell_command(command, out);
    return {code, out};
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
