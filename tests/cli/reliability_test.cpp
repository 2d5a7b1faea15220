// Reliability, round 2: each class of failure found by hand, tested through the real CLI
// (and the io helpers directly where the CLI cannot reach the case):
//   outputs  - symlinks, devices, FIFOs, '-', write errors, stale temporaries, both-or-neither sidecars;
//   plot     - no shell between a file name and the plotter, the script found beside the executable;
//   sizes    - device and oversized inputs, point sets that cannot fit in memory;
//   text     - non-UTF-8 bytes in arguments, BOM / UTF-16 / CR-only / control bytes in inputs;
//   OpenCL   - PoCL variables that crash it, an unwritable kernel cache, damaged cache entries;
//   options  - decimal-only integers, seeds >= 2^64, huge device indices, sweep size overflow,
//              spec domains, interruption messages.
// MICROSHADOW_CLI_UNDER_TEST=/path/to/microshadow runs the CLI tests against another build (e.g. the
// one before these fixes, to see them fail).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "cli_runner.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "test_files.hpp"
#include "sanitizers.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using namespace std::string_literals;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

using ms::testing::kAsan;

std::string cli() {
    const char* other = std::getenv("MICROSHADOW_CLI_UNDER_TEST");
    return other && *other ? other : MICROSHADOW_CLI;
}

using ms::testing::slurp_file;

// Single-quoted for sh (the tests' own file names hold quotes on purpose).
std::string sq(const std::string& s) {
    std::string out = "'";
    for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

const std::string kQueries = std::string(MICROSHADOW_SOURCE_DIR) + "/examples/queries.csv";

class Reliability : public ScratchDirTest {
protected:
    Reliability() : ScratchDirTest("reliability") {}

    // `prefix` runs first in the same shell (env settings, ulimit, trap); stderr joins stdout. A 2 GiB
    // address-space limit turns an unbounded allocation into a failure instead of thrashing the machine
    // (not under ASan, which reserves terabytes of address space).
    RunResult run(const std::string& args, const std::string& prefix = "") const {
        const std::string cmd = "cd " + sq(dir_.string()) + " && " + (kAsan ? "" : "ulimit -v 2097152 && ") + prefix +
                                " timeout 120 " + sq(cli()) + " " + args + " 2>&1 </dev/null";
        return run_shell(cmd);
    }
    std::string write(const std::string& name, const std::string& text) const {
        std::ofstream(dir_ / name, std::ios::binary) << text;
        return (dir_ / name).string();
    }
    std::vector<std::string> entries() const {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    }
};

bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }

#define EXPECT_CONTAINS(out, text) EXPECT_TRUE(contains(out, text)) << "expected '" << (text) << "' in:\n" << (out)

const std::string kEval = "eval --method sampled --backend oracle --samples 64 -q --in " + kQueries;

// --- 1. outputs are what the user named ------------------------------------------------------------

TEST_F(Reliability, SymlinkedOutputReplacesTheTargetAndKeepsTheLink) {
    write("real.csv", "old\n");
    fs::create_symlink("real.csv", dir_ / "link.csv");
    const auto r = run(kEval + " --out link.csv");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::is_symlink(dir_ / "link.csv")) << "the link was replaced by a regular file";
    EXPECT_CONTAINS(slurp_file(dir_ / "real.csv"), "term,std_error");
    // A dangling link names the file to create, as the shell's '>' does.
    fs::create_symlink("new.csv", dir_ / "dangling.csv");
    ASSERT_EQ(run(kEval + " --out dangling.csv").exit_code, 0);
    EXPECT_TRUE(fs::is_symlink(dir_ / "dangling.csv"));
    EXPECT_CONTAINS(slurp_file(dir_ / "new.csv"), "term,std_error");
}

TEST_F(Reliability, NonRegularOutputsAreRefusedBeforeComputing) {
    ASSERT_EQ(::mkfifo((dir_ / "fifo").c_str(), 0600), 0);
    auto r = run(kEval + " --out fifo");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "cannot write fifo: it is a FIFO");
    struct stat st {};
    ASSERT_EQ(::lstat((dir_ / "fifo").c_str(), &st), 0);
    EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the FIFO was replaced";
    // A character device: a private copy of /dev/null where we may create one (root), so that a
    // regression replaces the copy, never the machine's /dev/null.
    if (::geteuid() == 0 && ::mknod((dir_ / "null").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {
        r = run(kEval + " --out null");
        EXPECT_EQ(r.exit_code, 2) << r.output;
        EXPECT_CONTAINS(r.output, "it is a character device");
        ASSERT_EQ(::lstat((dir_ / "null").c_str(), &st), 0);
        EXPECT_TRUE(S_ISCHR(st.st_mode)) << "the device was replaced by a regular file";
        // A symlink to a device is refused the same way.
        fs::create_symlink("null", dir_ / "to-null");
        r = run(kEval + " --out to-null");
        EXPECT_EQ(r.exit_code, 2) << r.output;
        EXPECT_CONTAINS(r.output, "symlink to a character device");
    }
    std::vector<std::string> expected = {"fifo"};
    if (fs::exists(dir_ / "null")) expected = {"fifo", "null", "to-null"};
    EXPECT_EQ(entries(), expected) << "something was written";
}

TEST_F(Reliability, DashWritesTheCsvToStandardOutputWithoutASidecar) {
    for (const std::string target : {"-", "/dev/stdout"}) {
        const auto r = run_shell("cd " + sq(dir_.string()) + " && " + sq(cli()) + " " + kEval + " --out " + target +
                                 " 2>/dev/null");
        ASSERT_EQ(r.exit_code, 0) << target;
        EXPECT_EQ(r.output.rfind("visibility,alpha_x", 0), 0u) << target << ":\n" << r.output;
        EXPECT_CONTAINS(r.output, "term,std_error");
        EXPECT_TRUE(entries().empty()) << target << ": wrote a file";
    }
    // Standard output that cannot take the data is an error, not a silent success.
    const auto r = run_shell("cd " + sq(dir_.string()) + " && " + sq(cli()) + " " + kEval + " --out - 2>&1 >/dev/full");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_CONTAINS(r.output, "cannot write to standard output: No space left on device");
}

TEST_F(Reliability, WriteErrorsAreReportedAndLeaveNothing) {
    // A file size limit of 0 makes every write fail with EFBIG (the signal it raises is ignored), as
    // ENOSPC would on a full disk: the error is reported with its cause, nothing is left behind.
    write("r.csv", "previous\n");
    const auto r = run(kEval + " --out r.csv", "trap '' XFSZ; ulimit -f 0;");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_CONTAINS(r.output, "cannot write r.csv");
    EXPECT_CONTAINS(r.output, "File too large");
    EXPECT_EQ(slurp_file(dir_ / "r.csv"), "previous\n");
    EXPECT_EQ(entries(), std::vector<std::string>{"r.csv"});
}

TEST_F(Reliability, StaleTemporariesOfAKilledRunAreRemoved) {
    // A pid that is certainly gone: a child that has exited and been reaped.
    const pid_t child = fork();
    if (child == 0) _exit(0);
    ASSERT_GT(child, 0);
    waitpid(child, nullptr, 0);
    const std::string dead = std::to_string(child), alive = std::to_string(::getpid());
    write(".r.csv.tmp." + dead, "half");
    write(".r.csv.json.tmp." + dead, "half");
    write(".r.csv.tmp." + alive, "in use by a live process");
    write(".other.csv.tmp." + dead, "another output's: not ours to remove");
    const auto r = run(kEval + " --out r.csv");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_FALSE(fs::exists(dir_ / (".r.csv.tmp." + dead)));
    EXPECT_FALSE(fs::exists(dir_ / (".r.csv.json.tmp." + dead)));
    EXPECT_TRUE(fs::exists(dir_ / (".r.csv.tmp." + alive)));
    EXPECT_TRUE(fs::exists(dir_ / (".other.csv.tmp." + dead)));
}

// --- 3. both outputs or neither --------------------------------------------------------------------

TEST_F(Reliability, ABadSidecarPathFailsBeforeComputingAndKeepsTheCsv) {
    write("r.csv", "previous\n");
    fs::create_directory(dir_ / "r.csv.json");
    const auto r = run(kEval + " --out r.csv");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "cannot write r.csv.json: it is a directory");
    EXPECT_EQ(slurp_file(dir_ / "r.csv"), "previous\n");
    EXPECT_EQ(entries(), (std::vector<std::string>{"r.csv", "r.csv.json"}));
}

TEST_F(Reliability, AnOutputNameTooLongForItsTemporariesFailsUpFront) {
    const std::string name(242, 'x');
    const auto r = run(kEval + " --out " + name);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "NAME_MAX");
    EXPECT_TRUE(entries().empty());
}

TEST_F(Reliability, OutputSetPutsThePreviousFilesBackWhenARenameFails) {
    write("a.csv", "old a\n");
    write("b.json", "old b\n");
    {
        ms::OutputSet set;
        const auto a = set.add((dir_ / "a.csv").string());
        const auto b = set.add((dir_ / "b.json").string());
        set.stream(a) << "new a\n";
        set.stream(b) << "new b\n";
        // The second target becomes a non-empty directory after the check: its rename fails.
        fs::remove(dir_ / "b.json");
        fs::create_directories(dir_ / "b.json" / "x");
        EXPECT_THROW(set.commit(), std::runtime_error);
    }
    EXPECT_EQ(slurp_file(dir_ / "a.csv"), "old a\n") << "the first output was not put back";
    EXPECT_EQ(entries(), (std::vector<std::string>{"a.csv", "b.json"})) << "temporaries or backups left";
    // Two names for one file are refused (they would share a temporary).
    fs::create_symlink("a.csv", dir_ / "alias.csv");
    ms::OutputSet set;
    set.add((dir_ / "a.csv").string());
    EXPECT_THROW(set.add((dir_ / "alias.csv").string()), ms::OutputError);
}

// --- 6. the plotter runs without a shell -----------------------------------------------------------

const char* kTinySpec =
    "[parameters]\nvisibility = [0.5, 0.9]\nn_dot_l = [0.5]\nroughness = [0.5]\n"
    "[comparators]\nanalytic = [\"naughty-dog\"]\n";

TEST_F(Reliability, PlotFileNamesAreNeverParsedByAShell) {
    // A copy of the CLI with a stand-in plotter beside it (../share/microshadow/plot_sweep.py), which
    // records its arguments and exits 3: no matplotlib needed, and the exit status must come back.
    fs::create_directories(dir_ / "bin");
    fs::create_directories(dir_ / "share" / "microshadow");
    fs::copy_file(cli(), dir_ / "bin" / "microshadow");
    write("share/microshadow/plot_sweep.py",
          "import sys\nopen(sys.argv[0] + '.args', 'w').write('\\n'.join(sys.argv[1:]))\nsys.exit(3)\n");
    const std::string spec = "x';touch PWNED;'.toml";
    write(spec, kTinySpec);
    const std::string out = "inj'; touch PWNED2; echo '";
    const auto r = run_shell("cd " + sq(dir_.string()) + " && ./bin/microshadow sweep " + sq(spec) + " --out " + sq(out) +
                             " --plot --backend oracle --method sampled --samples 64 -q 2>&1");
    EXPECT_FALSE(fs::exists(dir_ / "PWNED")) << r.output;
    EXPECT_FALSE(fs::exists(dir_ / "PWNED2")) << r.output;
    EXPECT_EQ(r.exit_code, 3) << "the plotter's exit status\n" << r.output;
    EXPECT_CONTAINS(r.output, "plotting failed (exit status 3)");
    const std::string args = slurp_file(dir_ / "share" / "microshadow" / "plot_sweep.py.args");
    EXPECT_EQ(args, "heatmaps\n" + (dir_ / out / "sweep.csv").string() + "\n--out\n" + (dir_ / out / "figures").string());
    EXPECT_TRUE(fs::exists(dir_ / out / "sweep.csv"));
}

TEST_F(Reliability, PlotScriptIsFoundFromTheExecutableNotACompiledInPath) {
    // A copy of the CLI away from any build or install tree has no plotter: it says where it looked.
    fs::create_directories(dir_ / "bin");
    fs::copy_file(cli(), dir_ / "bin" / "microshadow");
    write("s.toml", kTinySpec);
    const auto r = run_shell("cd " + sq(dir_.string()) + " && ./bin/microshadow sweep s.toml --out o --plot --backend oracle "
                             "--samples 64 -q 2>&1");
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_CONTAINS(r.output, "plot_sweep.py not found; looked in:");
    EXPECT_CONTAINS(r.output, (dir_ / "share" / "microshadow" / "plot_sweep.py").string());
}

// --- 12. sizes that cannot run ---------------------------------------------------------------------

TEST_F(Reliability, DeviceAndOversizedInputsAreRefusedBeforeReading) {
    auto r = run("eval --method sampled --in /dev/zero --out r.csv --backend oracle");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "/dev/zero: is a device, not a regular file");
    r = run("sweep /dev/zero --out o --backend oracle");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "/dev/zero: is a device");
    // Sparse files one byte over each limit: refused by size, not read.
    ASSERT_EQ(::truncate(write("big.csv", "").c_str(), (off_t(1) << 30) + 1), 0);
    r = run("eval --method sampled --in big.csv --out r.csv --backend oracle");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "more than the limit of 1 GiB");
    ASSERT_EQ(::truncate(write("big.toml", "").c_str(), (off_t(16) << 20) + 1), 0);
    r = run("sweep big.toml --out o --backend oracle");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "more than the limit of 16 MiB");
    EXPECT_EQ(entries(), (std::vector<std::string>{"big.csv", "big.toml"}));
}

TEST_F(Reliability, PointSetsThatCannotFitAreRefusedWithTheFigure) {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
    const double memory = double(pages) * double(page);
    // 2^34 samples x 8 bytes = 128 GiB: refused by memory on any machine with less than 256 GiB.
    if (memory < 256.0 * (1ull << 30)) {
        for (const std::string cmd : {"eval --method sampled --backend oracle -q --in " + kQueries + " --out r.csv", std::string("bake --out l.exr --size 2 -q"),
                                      std::string("sweep s.toml --out o --backend oracle --method sampled -q")}) {
            write("s.toml", kTinySpec);
            const auto r = run(cmd + " --samples 17179869184 --replicates 64");
            EXPECT_EQ(r.exit_code, 2) << cmd << "\n" << r.output;
            EXPECT_CONTAINS(r.output, "--samples 17179869184 needs 128 GiB for the point set");
            EXPECT_CONTAINS(r.output, "half the");
        }
    }
    // More points per replicate than the generator takes (2^28): refused with the way out.
    const auto r = run("eval --method sampled --backend oracle -q --in " + kQueries + " --out r.csv --samples 4294967296");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "at most 2^28");
    EXPECT_FALSE(fs::exists(dir_ / "r.csv"));
    // --help states the range that is accepted.
    EXPECT_CONTAINS(run("eval --method sampled --help").output, "16 to replicates x 2^28");
}

// --- 13. non-UTF-8 bytes in arguments --------------------------------------------------------------

TEST_F(Reliability, NonUtf8FileNamesWorkAndAreEscapedInTheProvenance) {
    const std::string name = "r\xE9.csv";  // Latin-1 e-acute: a legal Linux file name, not UTF-8
    auto r = run(kEval + " --out " + sq(name));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto meta = nlohmann::json::parse(slurp_file(dir_ / (name + ".json")));
    const std::string recorded = meta.at("command_line").get<std::string>();
    EXPECT_CONTAINS(recorded, "$'r\\xE9.csv'");
    // The sweep records its spec's name in the manifest.
    write("s\xE9.toml", kTinySpec);
    r = run("sweep " + sq("s\xE9.toml") + " --out o --backend oracle --method sampled --samples 64 -q");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_CONTAINS(nlohmann::json::parse(slurp_file(dir_ / "o" / "manifest.json")).at("spec").get<std::string>(), "s\\xE9.toml");
    // A bake records the command line in the EXR header.
    r = run("bake --layout seed-2d --size 2 --samples 64 -q --out " + sq("l\xE9.exr"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::exists(dir_ / "l\xE9.exr"));
}

TEST(ReliabilityText, JsonSafeAndShellQuote) {
    EXPECT_EQ(ms::json_safe("plain"), "plain");
    EXPECT_EQ(ms::json_safe("caf\xC3\xA9"), "caf\xC3\xA9");  // valid UTF-8 kept
    EXPECT_EQ(ms::json_safe("lut\xE9.exr"), "lut\\xE9.exr");
    EXPECT_EQ(ms::json_safe("\xED\xA0\x80"), "\\xED\\xA0\\x80");  // a UTF-16 surrogate is not UTF-8
    EXPECT_TRUE(ms::is_valid_utf8(ms::json_safe("\xFF\xFE\xC0\xAF")));
    EXPECT_EQ(ms::dump_json(nlohmann::json("a\xE9")), "\"a\xEF\xBF\xBD\"");  // U+FFFD, no exception
    EXPECT_EQ(ms::shell_quote("a.csv"), "a.csv");
    EXPECT_EQ(ms::shell_quote("it's"), "'it'\\''s'");
    EXPECT_EQ(ms::shell_quote("x\xE9'"), "$'x\\xE9\\''");
    EXPECT_EQ(ms::shell_quote(""), "''");
}

// --- 15. OpenCL set-up -----------------------------------------------------------------------------

TEST_F(Reliability, PoclVariablesThatCrashPoclAreRefused) {
    for (const std::string setting : {"POCL_MAX_PTHREAD_COUNT=-1", "POCL_MAX_PTHREAD_COUNT=abc",
                                      "POCL_MAX_WORK_GROUP_SIZE=0", "POCL_MAX_WORK_GROUP_SIZE=-1"}) {
        const auto r = run("devices", "env " + setting);
        EXPECT_EQ(r.exit_code, 2) << setting << "\n" << r.output;
        EXPECT_CONTAINS(r.output, setting.substr(0, setting.find('=')) + "='");
        EXPECT_CONTAINS(r.output, "PoCL crashes on such values");
    }
}

TEST_F(Reliability, AnUnwritableHomeStillFindsTheDevice) {
    // /proc/.cache cannot be created, by root either; PoCL then reported no device at all.
    const auto r = run("devices", "env -u POCL_CACHE_DIR -u XDG_CACHE_HOME HOME=/proc TMPDIR=" + sq(dir_.string()));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const std::string cache = (dir_ / ("microshadow-pocl-cache-" + std::to_string(::getuid()))).string();
    EXPECT_CONTAINS(r.output, "PoCL kernel cache: " + cache);
    EXPECT_CONTAINS(r.output, "cannot be created or written; using POCL_CACHE_DIR=" + cache);
}

TEST_F(Reliability, DamagedKernelCacheEntriesAreNamedInsteadOfAborting) {
    const std::string env = "env POCL_CACHE_DIR=" + sq((dir_ / "cache").string());
    const std::string eval = "eval --method sampled --in " + kQueries + " --out r.csv --samples 256 -q";
    ASSERT_EQ(run(eval, env).exit_code, 0);  // fills the cache
    int damaged = 0;
    for (const auto& e : fs::recursive_directory_iterator(dir_ / "cache")) {
        if (e.path().filename() == "program.bc" || e.path().extension() == ".so") {
            std::ofstream(e.path(), std::ios::binary | std::ios::trunc) << "garbage";
            // Settled, as a damaged entry from an earlier run is (files written in the last minute may
            // be a concurrent run's work in progress and are not judged).
            fs::last_write_time(e.path(), fs::file_time_type::clock::now() - std::chrono::minutes(5));
            ++damaged;
        }
    }
    ASSERT_GT(damaged, 0) << "PoCL cached nothing";
    const auto r = run(eval, env);
    EXPECT_EQ(r.exit_code, 1) << r.output;  // PoCL itself aborts with 134
    EXPECT_CONTAINS(r.output, "has damaged entries");
    EXPECT_CONTAINS(r.output, "rm -rf '" + (dir_ / "cache").string());
    EXPECT_CONTAINS(run("devices", env).output, "PoCL kernel cache: " + (dir_ / "cache").string());
}

// --- 16. options, messages, specs ------------------------------------------------------------------

TEST_F(Reliability, IntegerOptionsAreDecimal) {
    ASSERT_EQ(run(kEval + " --out a.csv --seed 010").exit_code, 0);
    ASSERT_EQ(run(kEval + " --out b.csv --seed 10").exit_code, 0);
    EXPECT_EQ(slurp_file(dir_ / "a.csv"), slurp_file(dir_ / "b.csv")) << "--seed 010 was not read as ten";
    auto r = run(kEval + " --out c.csv --seed 0x10");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "'0x10' is not a decimal integer");
    r = run(kEval + " --out c.csv --seed 18446744073709551616");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "Value 18446744073709551616 not in range 0 to 18446744073709551615");
    r = run(kEval + " --out c.csv --seed 18446744073709551615");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    r = run("bake --out l.exr --size 010 --size-n-dot-v 0x4 -q");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "--size-n-dot-v: '0x4' is not a decimal integer");
}

TEST_F(Reliability, MessagesForHugeNumbersAreClear) {
    auto r = run("eval --method sampled --in " + kQueries + " --out r.csv --device 99999999999999999999999");
    EXPECT_EQ(r.exit_code, 2) << r.output;  // a --device naming no device is bad input
    EXPECT_CONTAINS(r.output, "no OpenCL device 99999999999999999999999; the devices are");
    EXPECT_FALSE(contains(r.output, "stoul"));
    r = run("bake --out l.exr --tolerance 2");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "Value 2 not in range 1e-07 to 1");
    EXPECT_FALSE(contains(r.output, "1.000000"));
    write("big.toml",
          "[parameters]\n"
          "visibility = { start = 0.0, stop = 1.0, count = 10000000 }\n"
          "n_dot_l = { start = 0.0, stop = 1.0, count = 10000000 }\n"
          "n_dot_v = { start = 0.1, stop = 1.0, count = 10000000 }\n"
          "roughness = { start = 0.1, stop = 1.0, count = 10000000 }\n"
          "phi_i = { start = 0, stop = 90, count = 10000000 }\n");
    r = run("sweep big.toml --out o --backend oracle");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_CONTAINS(r.output, "the sweep has more than 2^64 points");
    EXPECT_FALSE(contains(r.output, "-9223372036854775808"));
}

TEST_F(Reliability, QueryFileEncodingsAreReportedAtTheFirstBadByte) {
    const std::string header = "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z";
    const std::string row = "0.5,0.16,0.16,0,0,1,0,0,1";
    write("bom.csv", "\xEF\xBB\xBF" + header + "\n" + row + "\n");
    auto r = run("eval --method sampled --in bom.csv --out r.csv --backend oracle --samples 64 -q");
    EXPECT_EQ(r.exit_code, 0) << "a UTF-8 byte-order mark is accepted\n" << r.output;
    write("crlf.csv", header + "\r\n" + row + "\r\n");
    EXPECT_EQ(run("eval --method sampled --in crlf.csv --out r.csv --backend oracle --samples 64 -q").exit_code, 0);
    const std::vector<std::pair<std::string, std::string>> bad = {
        {header + "\r" + row + "\r", "cr.csv:1: a carriage return without a line feed at column 57: CR-only"},
        {"\xFF\xFEv\0i\0"s, "utf16.csv:1: binary data, not CSV text (a UTF-16 byte-order mark)"},
        {header + "\n0.5,0.16,0.16,0,0,1\x01,0,0,1\n", "ctl.csv:2: binary data, not CSV text (control character 0x01 at column 20)"},
        {header + "\n0.5,0.16\xE9,0.16,0,0,1,0,0,1\n", "latin1.csv:2: binary data, not CSV text (byte 0xE9 at column 9 is not UTF-8)"},
        {header + "\n0.5,0.16,0.16,0,0,1,0,0,1\n0.5,0.16,0.16,0,0\0,1,0,0,1\n"s, "nul.csv:3: binary data, not CSV text (a NUL byte at column 18)"},
    };
    const char* names[] = {"cr.csv", "utf16.csv", "ctl.csv", "latin1.csv", "nul.csv"};
    for (std::size_t i = 0; i < bad.size(); ++i) {
        write(names[i], bad[i].first);
        r = run(std::string("eval --method sampled --in ") + names[i] + " --out r.csv --backend oracle");
        EXPECT_EQ(r.exit_code, 2) << names[i] << "\n" << r.output;
        EXPECT_CONTAINS(r.output, bad[i].second);
    }
}

TEST_F(Reliability, FuzzSeedsAreAcceptedOrRefusedCleanly) {
    // The shapes added to the fuzz corpora (fuzz/csv-seeds, fuzz/spec-seeds) through the real CLI: each
    // one works (exit 0) or is bad input (exit 2) with a message naming the file; never a crash.
    const fs::path fuzz = fs::path(MICROSHADOW_SOURCE_DIR) / "fuzz";
    std::size_t seen = 0;
    for (const auto& [sub, command] : {std::pair<std::string, std::string>{"csv-seeds", "eval --method sampled --out r.csv --in "},
                                       std::pair<std::string, std::string>{"spec-seeds", "sweep --out o "}}) {
        for (const auto& e : fs::directory_iterator(fuzz / sub)) {
            ++seen;
            const std::string file = e.path().string();
            const auto r = run(command + sq(file) + " --backend oracle --samples 64 -q");
            EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 2) << file << ": exit " << r.exit_code << "\n" << r.output;
            if (r.exit_code == 2) EXPECT_CONTAINS(r.output, e.path().filename().string());
            fs::remove_all(dir_ / "o");
            fs::remove(dir_ / "r.csv");
            fs::remove(dir_ / "r.csv.json");
        }
    }
    EXPECT_GE(seen, 20u);
    EXPECT_TRUE(entries().empty());
}

TEST_F(Reliability, SpecDomainsAreCheckedBeforeTheRun) {
    const std::string base = "[parameters]\nvisibility = [0.5]\nn_dot_l = [0.5]\n";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {base + "roughness = [-3]\n", "parameters.roughness: value -3 outside (0, 1]"},
        {base + "roughness = [3]\n", "parameters.roughness: value 3 outside (0, 1]"},
        {base + "roughness = [1e-200]\n", "alpha = roughness^2 underflows to 0"},
        {base + "alpha_x = [1e-200]\nalpha_y = [1e-200]\n[comparators]\nanalytic = [\"activision-adjusted\"]\n",
         "comparators.analytic: activision-adjusted needs an isotropic alpha in (0, sqrt(2))"},
        {base + "roughness = [0.5]\n[[comparators.lut]]\nname = \"a\\u0001b\"\nfile = \"x.exr\"\n",
         "comparators.lut[0].name: must not contain control characters (found 0x01)"},
        {base + "roughness = [0.5]\n[[comparators.lut]]\nname = \"a\\tb\"\nfile = \"x.exr\"\n",
         "must not contain control characters (found 0x09)"},
    };
    for (const auto& [text, message] : cases) {
        write("s.toml", text);
        const auto r = run("sweep s.toml --out o --backend oracle --method sampled --samples 64 -q");
        EXPECT_EQ(r.exit_code, 2) << text << "\n" << r.output;
        EXPECT_CONTAINS(r.output, message);
        EXPECT_FALSE(fs::exists(dir_ / "o")) << text << ": the run started";
    }
}

TEST_F(Reliability, AnInterruptedSweepSaysWhatItKeptAndNothingElse) {
    // Enough chunks that the interrupt lands in the middle: 4096 points in chunks of 16.
    write("s.toml",
          "[sweep]\nchunk_size = 16\n[parameters]\nvisibility = { start = 0.0, stop = 1.0, count = 64 }\n"
          "n_dot_l = { start = 0.05, stop = 1.0, count = 64 }\nroughness = [0.5]\n");
    const std::string cmd = "cd " + sq(dir_.string()) + " && exec " + sq(cli()) +
                            " sweep s.toml --out o --backend oracle --method sampled --samples 4096 >log.txt 2>&1 </dev/null";
    const char* argv[] = {"sh", "-c", cmd.c_str(), nullptr};
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
    // Wait for the first finished chunk, then interrupt.
    const auto start = std::chrono::steady_clock::now();
    while (!fs::exists(dir_ / "o" / "manifest.json") && std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    kill(pid, SIGINT);
    int status = 0;
    waitpid(pid, &status, 0);
    const std::string log = slurp_file(dir_ / "log.txt");
    ASSERT_TRUE(WIFEXITED(status)) << log;
    if (WEXITSTATUS(status) == 0) GTEST_SKIP() << "the sweep finished before the interrupt";
    EXPECT_EQ(WEXITSTATUS(status), 130) << log;
    EXPECT_CONTAINS(log, "interrupted; the finished chunks are kept in o - rerun the same command to resume");
    EXPECT_FALSE(contains(log, "nothing was written")) << log;
}

}  // namespace
