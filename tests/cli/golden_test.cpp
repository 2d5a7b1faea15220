// The golden set and the refactor contract, through the real CLI in child processes:
//   - the golden set: tests/golden/make_golden.sh with the freshly built binaries reproduces
//     tests/golden/expected.txt line for line, and its eval lines are the pre-refactor record's
//     (tests/golden/before-refactor.txt; tests/golden/README.md says why the bakes changed);
//   - failover for eval and sweep: with two PoCL devices and device 0 failing on its first work item
//     (MICROSHADOW_FAIL_DEVICE=0:0) the outputs are byte-identical to a clean one-device run; with the
//     only device failing the run exits non-zero naming the failure and writes nothing;
//   - signals: SIGINT / SIGTERM stop eval, bake (with --verify) and sweep within 1.5 s, with the exit
//     status of an interruption, the previous output file intact and no new output.
// Two PoCL devices come from POCL_DEVICES="pthread pthread", set in the child's environment only.
#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "cli_runner.hpp"
#include "test_files.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using ms::testing::ScratchDirTest;

using ms::testing::slurp_file;

// "name hash" lines of make_golden.sh's output (or of a record), by name.
std::map<std::string, std::string> golden_lines(const std::string& text) {
    static const std::regex line("^([a-z_/0-9]+\\.(exr|csv|term)) ([0-9a-f]{16})$");
    std::map<std::string, std::string> out;
    std::istringstream in(text);
    std::string s;
    std::smatch m;
    while (std::getline(in, s))
        if (std::regex_match(s, m, line)) out[m[1]] = m[3];
    return out;
}

// Starts `env... microshadow args` in `dir`, stdout and stderr to dir/log.txt; returns the CLI's own
// pid (sh execs env, which execs the CLI, so a signal reaches the CLI itself).
pid_t spawn_cli(const fs::path& dir, const std::string& args, const std::string& env = "") {
    const std::string cmd = "cd '" + dir.string() + "' && exec env " + env + " " + std::string(MICROSHADOW_CLI) + " " +
                            args + " >>log.txt 2>&1 </dev/null";
    const char* argv[] = {"sh", "-c", cmd.c_str(), nullptr};
    pid_t pid = 0;
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return -1;
    return pid;
}

// Exit status, or -signal when the process was killed by one.
int wait_exit(pid_t pid) {
    int status = 0;
    if (waitpid(pid, &status, 0) != pid) return -1000;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

struct CliRun {
    int exit_code;
    double seconds;
    std::string log;
};

// Runs to completion; `timeout` turns a hang into exit code 124 instead of a stuck suite (every run
// here takes well under a second; the bound allows for a loaded machine).
CliRun run_cli(const fs::path& dir, const std::string& args, const std::string& env = "", int timeout_seconds = 60) {
    fs::remove(dir / "log.txt");
    const auto t0 = Clock::now();
    const int code = wait_exit(spawn_cli(dir, args, env + " timeout " + std::to_string(timeout_seconds)));
    return {code, std::chrono::duration<double>(Clock::now() - t0).count(), slurp_file(dir / "log.txt")};
}

// Every regular file under dir (relative path -> bytes), except the runs' log.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file() && e.path().filename() != "log.txt")
            files[fs::relative(e.path(), dir).string()] = slurp_file(e.path());
    return files;
}

std::string names(const std::map<std::string, std::string>& files) {
    std::string s;
    for (const auto& [name, bytes] : files) s += " " + name + " (" + std::to_string(bytes.size()) + " bytes)";
    return s.empty() ? " (none)" : s;
}

void write_queries(const fs::path& path, int count, unsigned seed) {
    std::ofstream out(path);
    out << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n";
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.05, 0.95);
    for (int i = 0; i < count; ++i) {
        // One draw per statement: the order of draws inside one expression is the compiler's choice.
        const double v = 0.5 + 0.45 * u(rng), ax = u(rng), ay = u(rng), wix = u(rng), wiz = u(rng), wox = u(rng),
                     woz = u(rng);
        out << v << "," << ax << "," << ay << "," << wix << ",0.1," << wiz << "," << wox << ",0.2," << woz << "\n";
    }
}

const std::string kTwoDevices = "POCL_DEVICES='pthread pthread'";

// ---------------------------------------------------------------------------------------------------
// Golden set.

class GoldenSet : public ScratchDirTest {
protected:
    GoldenSet() : ScratchDirTest("golden") {}
};

TEST_F(GoldenSet, ScriptReproducesExpectedAndEvalKeepsThePreRefactorBits) {
    const std::string golden = MICROSHADOW_GOLDEN_DIR;
    const auto expected = golden_lines(slurp_file(golden + "/expected.txt"));
    const auto before = golden_lines(slurp_file(golden + "/before-refactor.txt"));
    ASSERT_EQ(expected.size(), 10u) << "tests/golden/expected.txt should name the 10 lines of make_golden.sh";
    ASSERT_EQ(before.size(), 10u);

    const auto t0 = Clock::now();
    const std::string cmd = "bash '" + golden + "/make_golden.sh' '" + MICROSHADOW_CLI + "' '" + MICROSHADOW_EXR_PIXEL_HASH +
                            "' '" + path("work") + "' 2>&1";
    const ms::testing::RunResult run = ms::testing::run_shell(cmd);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    ASSERT_EQ(run.exit_code, 0) << cmd << "\n" << run.output;
    const auto got = golden_lines(run.output);

    std::string report;
    for (const auto& [name, hash] : expected) {
        const auto it = got.find(name);
        if (it == got.end()) report += "  " + name + ": missing from the script's output\n";
        else if (it->second != hash) report += "  " + name + ": " + it->second + ", expected " + hash + "\n";
    }
    for (const auto& [name, hash] : got)
        if (!expected.count(name)) report += "  " + name + ": not in expected.txt\n";
    EXPECT_TRUE(report.empty()) << "golden set differs (if on purpose: update tests/golden/expected.txt and say why in "
                                   "tests/golden/README.md):\n"
                                << report << "script output:\n"
                                << run.output;

    // The refactor kept eval's estimates bit for bit: the term columns are the pre-refactor record's. (The
    // whole files changed once, on purpose, when the error bars were fixed: rows no sample passed got honest error bars.)
    for (const std::string name : {"eval_opencl.term", "eval_oracle.term"}) {
        ASSERT_TRUE(expected.count(name) && before.count(name)) << name;
        EXPECT_EQ(expected.at(name), before.at(name)) << name << ": eval bits differ from before-refactor.txt";
        if (got.count(name)) {
            EXPECT_EQ(got.at(name), before.at(name)) << name << " (this build)";
        }
    }
    std::printf("[golden] %zu outputs in %.1f s\n", got.size(), seconds);
}

// ---------------------------------------------------------------------------------------------------
// Failover of eval and sweep.

class Failover : public ScratchDirTest {
protected:
    Failover() : ScratchDirTest("failover") {}
};

const char* kSmallSweep =
    "[sweep]\nchunk_size = 32\n"
    "[parameters]\n"
    "visibility = { start = 0.1, stop = 0.9, count = 8 }\n"
    "n_dot_l = { start = 0.1, stop = 1.0, count = 8 }\n"
    "roughness = [0.3, 0.6]\n"
    "n_dot_v = [0.5, 1.0]\n"
    "[comparators]\nanalytic = [\"reference-step\"]\n";

// cmd_eval and cmd_sweep print nothing about failed devices or reruns (cmd_bake does, see
// resilience_test.cpp), so these runs can only show that the outputs are unchanged; the scheduler's
// failover itself is tested in-process (integrand_scheduler_test.cpp, SchedulerTest.*Failover*).
TEST_F(Failover, EvalWithAFailingDeviceGivesTheSameBytes) {
    // The golden set's queries are one work item (2^28 samples per device item); 5000 queries at the
    // default 65536 samples are two, so the other device is busy when device 0 fails.
    write_queries(dir_ / "many.csv", 5000, 3);
    const std::string golden_in = "'" + std::string(MICROSHADOW_GOLDEN_DIR) + "/bench_queries.csv'";
    int trial = 0;
    for (const std::string& in : {golden_in, golden_in, std::string("many.csv")}) {
        const std::string clean_out = "clean" + std::to_string(trial) + ".csv", out = "faulty" + std::to_string(trial) + ".csv";
        const CliRun clean = run_cli(dir_, "eval --method sampled --in " + in + " --out " + clean_out + " -q");
        ASSERT_EQ(clean.exit_code, 0) << clean.log;
        const std::string expected = slurp_file(dir_ / clean_out);
        ASSERT_FALSE(expected.empty());
        const CliRun faulty =
            run_cli(dir_, "eval --method sampled --in " + in + " --out " + out + " --device all", kTwoDevices + " MICROSHADOW_FAIL_DEVICE=0:0");
        ASSERT_EQ(faulty.exit_code, 0) << "eval --method sampled --in " << in << " (124: hung, see SchedulerFailover.FailoverWhenTheOtherPlacesHaveFinished)\n"
                                       << faulty.log;
        EXPECT_EQ(slurp_file(dir_ / out), expected) << in;
        // The metadata names both devices: the run really had two places.
        EXPECT_NE(slurp_file(dir_ / (out + ".json")).find("; "), std::string::npos) << slurp_file(dir_ / (out + ".json"));
        ++trial;
    }
}

TEST_F(Failover, EvalWithItsOnlyDeviceFailingWritesNothing) {
    const std::string in = std::string(MICROSHADOW_GOLDEN_DIR) + "/bench_queries.csv";
    const CliRun dead = run_cli(dir_, "eval --method sampled --in '" + in + "' --out dead.csv -q", "MICROSHADOW_FAIL_DEVICE=0:0");
    EXPECT_EQ(dead.exit_code, 1) << dead.log;
    EXPECT_NE(dead.log.find("error"), std::string::npos) << dead.log;
    EXPECT_NE(dead.log.find("injected failure"), std::string::npos) << dead.log;
    EXPECT_NE(dead.log.find("nothing was written"), std::string::npos) << dead.log;
    EXPECT_EQ(dead.log.find("terminate called"), std::string::npos) << dead.log;
    EXPECT_FALSE(fs::exists(dir_ / "dead.csv"));
    EXPECT_FALSE(fs::exists(dir_ / "dead.csv.json"));
    EXPECT_EQ(snapshot(dir_).size(), 0u) << names(snapshot(dir_));
}

TEST_F(Failover, SweepWithAFailingDeviceGivesTheSameBytes) {
    std::ofstream(dir_ / "s.toml") << kSmallSweep;  // 256 points: 8 chunks of 32
    const std::string args = " --method sampled --samples 4096 --seed 4 -q";
    const CliRun clean = run_cli(dir_, "sweep s.toml --out clean" + args);
    ASSERT_EQ(clean.exit_code, 0) << clean.log;
    const CliRun faulty =
        run_cli(dir_, "sweep s.toml --out faulty --device all" + args, kTwoDevices + " MICROSHADOW_FAIL_DEVICE=0:0");
    ASSERT_EQ(faulty.exit_code, 0) << faulty.log;
    for (const char* f : {"sweep.csv", "summary.csv", "summary.md"}) {
        ASSERT_TRUE(fs::exists(dir_ / "clean" / f)) << f;
        EXPECT_EQ(slurp_file(dir_ / "faulty" / f), slurp_file(dir_ / "clean" / f)) << f;
    }
}

TEST_F(Failover, SweepWithItsOnlyDeviceFailingWritesNoResult) {
    std::ofstream(dir_ / "s.toml") << kSmallSweep;
    const CliRun dead = run_cli(dir_, "sweep s.toml --out dead --method sampled --samples 4096 -q", "MICROSHADOW_FAIL_DEVICE=0:0");
    EXPECT_EQ(dead.exit_code, 1) << dead.log;
    EXPECT_NE(dead.log.find("injected failure"), std::string::npos) << dead.log;
    EXPECT_EQ(dead.log.find("terminate called"), std::string::npos) << dead.log;
    EXPECT_FALSE(fs::exists(dir_ / "dead" / "sweep.csv"));
    EXPECT_FALSE(fs::exists(dir_ / "dead" / "summary.csv"));
    // No chunk was computed, so no chunk file may exist either.
    std::size_t chunk_files = 0;
    if (fs::exists(dir_ / "dead"))
        for (const auto& e : fs::recursive_directory_iterator(dir_ / "dead"))
            chunk_files += e.is_regular_file() && e.path().filename().string().find("chunk") != std::string::npos;
    EXPECT_EQ(chunk_files, 0u) << names(snapshot(dir_));
}

// ---------------------------------------------------------------------------------------------------
// Signals. Both stop the run cooperatively (ms::cancel_requested(), ms::Cancelled); the exit status is
// the shell's convention, 128 + the signal (host/cli/program.cpp: 130 for SIGINT, 143 for SIGTERM).

int interrupted_status(int sig) { return 128 + sig; }
constexpr double kSignalAfter = 1.0;   // seconds after the start
constexpr double kExitWithin = 1.5;    // seconds after the signal

class Signals : public ScratchDirTest {
protected:
    Signals() : ScratchDirTest("signals") {}

    // Starts the command, signals it after kSignalAfter s, and checks status, latency, the previous
    // output file (`previous`, pre-filled) and that no other file appeared. Returns the log.
    std::string interrupt(const std::string& args, int sig, const std::string& previous,
                          const std::set<std::string>& may_appear = {}) {
        const std::string old_bytes = "previous output, must survive\n";
        std::ofstream(dir_ / previous, std::ios::binary) << old_bytes;
        const auto before = snapshot(dir_);
        fs::remove(dir_ / "log.txt");
        const pid_t pid = spawn_cli(dir_, args);
        EXPECT_GT(pid, 0);
        std::this_thread::sleep_for(std::chrono::duration<double>(kSignalAfter));
        // Still running? (If the job finished within kSignalAfter, the test proves nothing.)
        int status = 0;
        EXPECT_EQ(waitpid(pid, &status, WNOHANG), 0) << args << ": finished before the signal; make it longer";
        const auto signalled = Clock::now();
        kill(pid, sig);
        // Poll so a process that ignores the signal is killed after a bound instead of hanging the suite.
        int code = -1000;
        double latency = 0;
        for (;;) {
            const pid_t r = waitpid(pid, &status, WNOHANG);
            latency = std::chrono::duration<double>(Clock::now() - signalled).count();
            if (r == pid) {
                code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
                break;
            }
            if (latency > 30) {
                kill(pid, SIGKILL);
                waitpid(pid, &status, 0);
                break;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        const std::string log = slurp_file(dir_ / "log.txt");
        const std::string what = "microshadow " + args + " (signal " + std::to_string(sig) + " after " +
                                 std::to_string(kSignalAfter) + " s)";
        EXPECT_EQ(code, interrupted_status(sig)) << what << "\nexit " << code << " after " << latency << " s\n" << log;
        EXPECT_LE(latency, kExitWithin) << what << ": exited " << latency << " s after the signal\n" << log;
        EXPECT_EQ(slurp_file(dir_ / previous), old_bytes) << what << ": the previous output changed";
        EXPECT_NE(log.find("interrupted"), std::string::npos) << what << "\n" << log;
        auto after = snapshot(dir_);
        for (const auto& name : may_appear)
            for (auto it = after.begin(); it != after.end();) it = it->first.rfind(name, 0) == 0 ? after.erase(it) : std::next(it);
        EXPECT_EQ(names(after), names(before)) << what << ": files appeared or changed";
        std::printf("[signals] %s: exit %d, %.2f s after the signal\n", what.c_str(), code, latency);
        return log;
    }
};

TEST_F(Signals, EvalOnTheOracleStopsOnSigintAndSigterm) {
    write_queries(dir_ / "q.csv", 300, 8);
    for (const int sig : {SIGINT, SIGTERM})
        interrupt("eval --method sampled --in q.csv --out r.csv --backend oracle --samples 1048576 -q", sig, "r.csv");
}

TEST_F(Signals, BakeWithVerifyStopsOnSigintAndSigterm) {
    // Warm PoCL's kernel cache first: a cold build of the bake kernels takes seconds (2.7 s measured on
    // 2 loaded cores) and a build is not interruptible, so the latency measured would be the compiler's.
    const CliRun warm = run_cli(dir_, "bake --size 2 --samples 1024 --out warm.exr -q");
    ASSERT_EQ(warm.exit_code, 0) << warm.log;
    fs::remove(dir_ / "warm.exr");
    for (const int sig : {SIGINT, SIGTERM}) interrupt("bake --size 32 --verify 100000 --out lut.exr -q", sig, "lut.exr");
}

TEST_F(Signals, SweepOnTheOracleStopsOnSigint) {
    std::ofstream(dir_ / "s.toml") << kSmallSweep;
    // A sweep keeps its finished chunks on purpose (rerun to resume): files under out/ may appear, but
    // never sweep.csv, and the previous file beside it stays.
    const std::string log = interrupt("sweep s.toml --out out --backend oracle --method sampled --samples 1048576 -q", SIGINT, "previous.csv",
                                      {"out/items/", "out/manifest", "out/sweep-spec.json"});
    EXPECT_FALSE(fs::exists(dir_ / "out" / "sweep.csv"));
    EXPECT_NE(log.find("rerun the same command to resume"), std::string::npos) << log;
}

}  // namespace
