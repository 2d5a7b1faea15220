// What `ibl sh | prefilter | irradiance | dfg` do with bad environments, bad destinations, failing
// devices and signals, through the real CLI in child processes:
//   - environments: a texel that is NaN, Inf, negative or beyond kMaxRadiance, channels that are not
//     R G B (or Y), a Radiance EXPOSURE that overflows or is not a number, a header that claims more
//     pixels than the file holds, a FIFO, truncated and hostile files: exit status 2, a one-line message
//     naming the texel, the channel or the header line, nothing written, no large allocation;
//   - destinations: two outputs at one path, an --out that cannot be a folder, options that are not
//     numbers (--lod-bias nan): exit status 2 before any work;
//   - one output set per run: a rerun with fewer mips or another format leaves no file of the earlier
//     run; a SIGTERM at any moment leaves the previous run's files or this run's, never a mix;
//   - failover: with two PoCL devices (POCL_DEVICES="pthread pthread", --device all) and device 0
//     failing on its first item (MICROSHADOW_FAIL_DEVICE=0:0) the values are those of one device,
//     bit for bit; with the only device failing the run exits non-zero and writes nothing.
#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <thread>

#include "cli_runner.hpp"
#include "core/cancel.hpp"
#include "env/image.hpp"
#include "io/atomic_file.hpp"
#include "jobs/ibl_env.hpp"
#include "test_files.hpp"
#include "sanitizers.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using namespace ms;
using Clock = std::chrono::steady_clock;

// The CLI under test: this build's, or another (MICROSHADOW_CLI_UNDER_TEST, e.g. an older build, to
// see which of these checks it fails).
std::string cli_binary() {
    const char* other = std::getenv("MICROSHADOW_CLI_UNDER_TEST");
    return other && *other ? other : MICROSHADOW_CLI;
}

using ms::testing::slurp_file;

// Every regular file under dir (relative path -> bytes), hidden temporaries included.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
    std::map<std::string, std::string> files;
    if (!fs::exists(dir)) return files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = slurp_file(e.path());
    return files;
}

std::string names(const std::map<std::string, std::string>& files) {
    std::string s;
    for (const auto& [name, bytes] : files) s += " " + name;
    return s.empty() ? " (none)" : s;
}

// A smooth, strictly positive 2:1 sky, every texel different.
env::Image sky(std::uint32_t w = 64, std::uint32_t h = 32) {
    env::Image img(w, h, {"R", "G", "B"});
    for (std::uint32_t y = 0; y < h; ++y)
        for (std::uint32_t x = 0; x < w; ++x) {
            img.at(x, y, 0) = 0.5f + 0.01f * float(x);
            img.at(x, y, 1) = 0.5f + 0.02f * float(y);
            img.at(x, y, 2) = 1.0f + 0.001f * float(x * y);
        }
    return img;
}

// A Radiance file with flat scanlines (every pixel's first byte 128, so no scanline reads as RLE).
std::string rgbe_file(std::uint32_t w, std::uint32_t h, const std::string& extra_header = "", unsigned char exponent = 128) {
    std::string s = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n" + extra_header + "\n-Y " + std::to_string(h) + " +X " + std::to_string(w) + "\n";
    for (std::uint32_t i = 0; i < w * h; ++i) s += std::string{char(128), char(100 + i % 50), char(60), char(exponent)};
    return s;
}

class IblReliability : public ms::testing::ScratchDirTest {
protected:
    IblReliability() : ScratchDirTest("ibl_reliability") {}

    ms::testing::RunResult cli(const std::string& args, const std::string& env = "") {
        return ms::testing::run_shell("cd '" + dir_.string() + "' && env " + env + " timeout 120 " + cli_binary() + " " +
                                      args + " 2>&1");
    }
    // The three environment commands on ENV, each into its own destination under `tag`.
    std::vector<std::string> environment_commands(const std::string& env, const std::string& tag) {
        return {"ibl sh " + env + " --out " + tag + "_sh.json --irradiance " + tag + "_irr.exr -q",
                "ibl prefilter " + env + " --out " + tag + "_pf --samples 16 --threads 1 -q",
                "ibl irradiance " + env + " --out " + tag + "_ir --face-size 4 --source-size 4 --backend oracle --threads 1 -q"};
    }
    // Each command refuses ENV with exit status 2, a message holding `expected`, and writes nothing.
    void expect_refused(const std::string& env, const std::string& expected, const std::string& tag) {
        const auto before = snapshot(dir_);
        for (const std::string& args : environment_commands(env, tag)) {
            const auto r = cli(args);
            EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
            EXPECT_NE(r.output.find(expected), std::string::npos) << args << "\nexpected '" << expected << "' in:\n" << r.output;
            EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line:\n" << r.output;
        }
        EXPECT_EQ(names(snapshot(dir_)), names(before)) << env << ": a refused run wrote files";
    }
};

// ---------------------------------------------------------------------------------------------------
// Environments that are not radiance.

TEST_F(IblReliability, TexelsThatAreNotRadianceAreRefusedNamingTheTexel) {
    const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -1000.0f, 1e30f};
    const char* shown[] = {"is NaN", "is +Inf", "is -1000", "is 1e+30"};
    for (int k = 0; k < 4; ++k) {
        env::Image img = sky();
        img.at(17, 5, 1) = bad[k];
        const std::string name = "bad" + std::to_string(k) + ".exr";
        env::write_exr(path(name), img, {});
        expect_refused(name, "texel (17, 5) channel G " + std::string(shown[k]), "t" + std::to_string(k));
    }
    // Negative zero is zero, and kMaxRadiance itself is accepted.
    env::Image edge = sky();
    edge.at(3, 3, 0) = -0.0f;
    edge.at(4, 4, 2) = env::kMaxRadiance;
    env::write_exr(path("edge.exr"), edge, {});
    const auto r = cli("ibl sh edge.exr --out edge.json -q");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    // A negative within kNegativeResidue of the largest value is compression residue (real HDRs hold
    // them): read as 0 and counted; one just beyond it is refused.
    env::Image residue = sky();
    float largest = 0;
    for (float v : residue.data) largest = std::max(largest, v);
    residue.at(6, 2, 0) = -0.5f * env::kNegativeResidue * largest;
    env::write_exr(path("residue.exr"), residue, {});
    const env::Image read = env::read_exr_rgb(path("residue.exr"));
    EXPECT_EQ(read.at(6, 2, 0), 0.0f);
    EXPECT_EQ(read.negative_residue_values, 1u);
    EXPECT_EQ(cli("ibl sh residue.exr --out residue.json -q").exit_code, 0);
    residue.at(6, 2, 0) = -2.0f * env::kNegativeResidue * largest;
    env::write_exr(path("beyond.exr"), residue, {});
    expect_refused("beyond.exr", "texel (6, 2) channel R is -", "beyond");
}

TEST_F(IblReliability, ChannelsThatAreNotRgbAreRefusedNamingWhatIsMissing) {
    struct Case {
        std::vector<std::string> channels;
        std::string expected;
    };
    const std::vector<Case> cases = {
        {{"diffuse.R", "diffuse.G", "diffuse.B"}, "no R, G, B or Y channel (the file has diffuse.B, diffuse.G, diffuse.R)"},
        {{"r", "g", "b"}, "no R, G, B or Y channel (the file has b, g, r)"},
        {{"R", "G"}, "channel B missing (the file has G, R)"},
        {{"Z"}, "no R, G, B or Y channel (the file has Z)"},
        {{"R", "Y"}, "channels G, B missing (the file has R, Y)"},
    };
    for (std::size_t k = 0; k < cases.size(); ++k) {
        env::Image img(64, 32, cases[k].channels);
        for (float& v : img.data) v = 1.0f;
        const std::string name = "chan" + std::to_string(k) + ".exr";
        env::write_exr(path(name), img, {});
        expect_refused(name, cases[k].expected, "c" + std::to_string(k));
    }
    // A single Y channel is a grey environment (R = G = B = Y); extra channels beside R G B are ignored.
    env::Image grey(64, 32, {"Y"});
    for (float& v : grey.data) v = 2.0f;
    env::write_exr(path("grey.exr"), grey, {});
    const env::Image g = env::read_exr_rgb(path("grey.exr"));
    EXPECT_EQ(g.channel_names, (std::vector<std::string>{"R", "G", "B"}));
    for (float v : g.data) ASSERT_EQ(v, 2.0f);
    env::Image rgba(64, 32, {"R", "G", "B", "A"});
    for (float& v : rgba.data) v = 0.25f;
    env::write_exr(path("rgba.exr"), rgba, {});
    EXPECT_EQ(cli("ibl sh rgba.exr --out rgba.json -q").exit_code, 0);
}

TEST_F(IblReliability, RadianceExposureMustBeAFinitePositiveFactorThatKeepsTexelsFinite) {
    // EXPOSURE divides the stored values: 1e-38 turns 1 into 1e38, beyond kMaxRadiance.
    std::ofstream(path("tiny.hdr"), std::ios::binary) << rgbe_file(64, 32, "EXPOSURE=1e-38\n");
    expect_refused("tiny.hdr", "texel (0, 0) channel R is", "e0");
    const std::vector<std::string> bad = {"EXPOSURE=0", "EXPOSURE=-2", "EXPOSURE=nan", "EXPOSURE=abc", "EXPOSURE=1e999"};
    for (std::size_t k = 0; k < bad.size(); ++k) {
        const std::string name = "exp" + std::to_string(k) + ".hdr";
        std::ofstream(path(name), std::ios::binary) << rgbe_file(64, 32, bad[k] + "\n");
        expect_refused(name, "header line '" + bad[k] + "': EXPOSURE must be a finite positive number", "e" + std::to_string(k + 1));
    }
    // A valid exposure divides every value; two lines multiply.
    std::ofstream(path("one.hdr"), std::ios::binary) << rgbe_file(64, 32);
    std::ofstream(path("four.hdr"), std::ios::binary) << rgbe_file(64, 32, "EXPOSURE=2\nEXPOSURE=2\n");
    const env::Image one = env::read_rgbe(path("one.hdr")), four = env::read_rgbe(path("four.hdr"));
    ASSERT_EQ(one.data.size(), four.data.size());
    for (std::size_t i = 0; i < one.data.size(); ++i) ASSERT_EQ(four.data[i], one.data[i] / 4) << i;
    // An exponent byte of 255 is 2^119 times the mantissa: beyond kMaxRadiance.
    std::ofstream(path("huge.hdr"), std::ios::binary) << rgbe_file(64, 32, "", 255);
    expect_refused("huge.hdr", "texel (0, 0) channel R is", "e9");
}

// Peak resident memory of `args` run in dir, in MiB (wait4's ru_maxrss), and its exit status. The
// child starts as a vfork of this process and Linux carries the address space's high-water mark across
// exec, so the figure is at least this process's own peak (VmHWM): compare the difference.
std::pair<int, double> run_measured(const fs::path& dir, const std::string& args) {
    const std::string cmd = "cd '" + dir.string() + "' && exec " + cli_binary() + " " + args + " >log.txt 2>&1";
    const char* argv[] = {"sh", "-c", cmd.c_str(), nullptr};
    pid_t pid = 0;
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return {-1, 0};
    int status = 0;
    struct rusage usage {};
    if (wait4(pid, &status, 0, &usage) != pid) return {-1, 0};
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, double(usage.ru_maxrss) / 1024.0};
}

// This process's peak resident memory (VmHWM of /proc/self/status), in MiB.
double own_peak_mib() {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return 0;
}

TEST_F(IblReliability, RadianceHeaderClaimsAreBoundedBeforeAnyAllocation) {
    // 53 bytes claiming 16384 x 32768 (2^29 pixels, 6.4 GB as floats), and 16384 x 16384 (the pixel limit).
    const std::string too_many = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 32768 +X 16384\n";
    const std::string at_limit = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 16384\n";
    std::ofstream(path("claims.hdr"), std::ios::binary) << too_many << std::string(53 - too_many.size(), '\x02');
    std::ofstream(path("limit.hdr"), std::ios::binary) << at_limit << std::string(53 - at_limit.size(), '\x02');
    ASSERT_EQ(fs::file_size(path("claims.hdr")), 53u);
    expect_refused("claims.hdr", "16384 x 32768 is 536870912 pixels, more than the limit of 268435456", "h0");
    expect_refused("limit.hdr", "needs at least", "h1");
    // The refusal costs no more memory than starting the CLI (the old reader zero-filled the claimed
    // image first: 3 GiB for 16384^2, 6 GiB for the other). A refused run takes about 10 MiB here; 256 MiB
    // leaves room for a sanitizer build.
    for (const char* file : {"claims.hdr", "limit.hdr"}) {
        const double own = own_peak_mib();
        const auto [code, mib] = run_measured(dir_, std::string("ibl sh ") + file + " --out x.json -q");
        EXPECT_EQ(code, 2) << slurp_file(dir_ / "log.txt");
        EXPECT_LT(mib - own, 256.0) << file << ": peak resident memory " << mib << " MiB, this process's " << own << " MiB";
        std::printf("[ibl] refusing %s: peak resident memory %.1f MiB (this process's: %.1f MiB)\n", file, mib, own);
    }
}

TEST_F(IblReliability, TruncatedAndHostileFilesExitTwo) {
    const std::string whole = rgbe_file(64, 32);
    std::ofstream(path("cut.hdr"), std::ios::binary) << whole.substr(0, whole.size() - 100);
    expect_refused("cut.hdr", "cannot read Radiance HDR cut.hdr: truncated pixel data", "x0");
    // RLE scanlines: a run past the scanline's end.
    std::string rle = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 64\n";
    for (int y = 0; y < 2; ++y) rle += std::string{2, 2, 0, 64} + std::string(4 * 64, '\xff');
    std::ofstream(path("runs.hdr"), std::ios::binary) << rle;
    expect_refused("runs.hdr", "scanline 0: bad run", "x1");
    // A truncated EXR (half its bytes), and the hand-made hostile EXRs of the preflight's tests.
    env::write_exr(path("whole.exr"), sky(), {});
    const std::string exr = slurp_file(dir_ / "whole.exr");
    std::ofstream(path("half.exr"), std::ios::binary) << exr.substr(0, exr.size() / 2);
    expect_refused("half.exr", "half.exr", "x2");
    int k = 3;
    for (const auto& e : fs::directory_iterator(fs::path(MICROSHADOW_SOURCE_DIR) / "tests/data/hostile/exr")) {
        fs::copy_file(e.path(), dir_ / e.path().filename());
        expect_refused(e.path().filename().string(), e.path().filename().string(), "x" + std::to_string(k++));
    }
    // Not an environment at all.
    std::ofstream(path("sky.png")) << "not an image";
    expect_refused("sky.png", "expected an .exr or a Radiance .hdr file", "x9");
    expect_refused("missing.exr", "missing.exr: cannot open for reading", "x10");
}

TEST_F(IblReliability, AFifoIsRefusedWithoutBlocking) {
    for (const char* name : {"pipe.exr", "pipe.hdr"}) {
        ASSERT_EQ(::mkfifo(path(name).c_str(), 0600), 0);
        const auto t0 = Clock::now();
        // No writer ever opens the FIFO: a reader that opens it blocking would wait for ever (timeout 120: 124).
        expect_refused(name, std::string(name) + ": is a FIFO (named pipe), not a regular file", std::string("f") + name);
        EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 60.0);
    }
    fs::create_directory(dir_ / "folder.exr");
    expect_refused("folder.exr", "folder.exr: is a directory, not a regular file", "fd");
}

// ---------------------------------------------------------------------------------------------------
// Destinations and options, refused before any work.

TEST_F(IblReliability, TwoOutputsAtOnePathAreRefusedBeforeAnyWork) {
    env::write_exr(path("sky.exr"), sky(), {});
    std::ofstream(path("s.json")) << "previous\n";
    const std::vector<std::string> colliding = {
        "ibl sh sky.exr --out a.json --irradiance s.exr --preview s.exr -q",
        "ibl sh sky.exr --out s.exr --irradiance ./s.exr -q",
        "ibl sh sky.exr --out s.json --preview ./s.json -q",
        "ibl dfg --method sampled --out d.exr --preview d.exr --size 4 --samples 64 -q",
        "ibl dfg --method sampled --out d.dds --preview d.dds.json --size 4 --samples 64 -q",
    };
    for (const std::string& args : colliding) {
        const auto before = snapshot(dir_);
        const auto t0 = Clock::now();
        const auto r = cli(args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find("name the same file"), std::string::npos) << args << "\n" << r.output;
        EXPECT_TRUE(snapshot(dir_) == before) << args << ": files changed:" << names(before) << " ->" << names(snapshot(dir_));
        EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 30.0) << args;
    }
    EXPECT_EQ(slurp_file(dir_ / "s.json"), "previous\n");
}

TEST_F(IblReliability, AnOutFolderThatCannotBeMadeIsRefusedBeforeAnyWork) {
    env::write_exr(path("sky.exr"), sky(), {});
    std::ofstream(path("file.txt")) << "a file\n";
    for (const std::string& args : {std::string("ibl prefilter sky.exr --out file.txt/sub --samples 16 -q"),
                                    std::string("ibl irradiance sky.exr --out file.txt/sub/deeper --face-size 4 -q"),
                                    std::string("ibl prefilter sky.exr --out file.txt --samples 16 -q")}) {
        const auto r = cli(args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_EQ(r.output.find("filesystem error"), std::string::npos) << args << "\n" << r.output;
        EXPECT_NE(r.output.find("file.txt"), std::string::npos) << args << "\n" << r.output;
    }
    // A refused environment leaves no empty --out folder behind.
    std::ofstream(path("bad.hdr")) << "#?RADIANCE\n";
    for (const std::string& args : {std::string("ibl prefilter bad.hdr --out new/pf -q"), std::string("ibl irradiance bad.hdr --out new/ir -q")}) {
        EXPECT_EQ(cli(args).exit_code, 2) << args;
        EXPECT_FALSE(fs::exists(dir_ / "new")) << args;
    }
}

TEST_F(IblReliability, NumericOptionsMustBeFiniteNumbers) {
    env::write_exr(path("sky.exr"), sky(), {});
    for (const std::string& option : {"--lod-bias nan", "--lod-bias inf", "--lod-bias 1e300", "--bright-threshold nan",
                                      "--bright-min-roughness nan", "--exposure nan"}) {
        const auto r = cli("ibl prefilter sky.exr --out pf --samples 16 -q " + option);
        EXPECT_EQ(r.exit_code, 2) << option << "\n" << r.output;
        EXPECT_NE(r.output.find(option.substr(0, option.find(' '))), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(dir_ / "pf")) << option;
    }
    EXPECT_EQ(cli("ibl irradiance sky.exr --out ir --exposure nan -q").exit_code, 2);
    EXPECT_EQ(cli("ibl prefilter sky.exr --out pf --samples 16 --threads 1 --lod-bias -1.5 -q").exit_code, 0);
}

// ---------------------------------------------------------------------------------------------------
// One output set per run.

TEST_F(IblReliability, ARerunWithFewerMipsOrAnotherFormatLeavesNoFileOfTheEarlierRun) {
    env::write_exr(path("sky.exr"), sky(128, 64), {});
    const std::string common = " --samples 16 --threads 1 --irradiance-size 4 -q";
    auto r = cli("ibl prefilter sky.exr --out pf --levels 4 --dfg-size 4 --format exr" + common);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const char* f : {"specular_m3.exr", "dfg.exr", "dfg_preview.png"}) ASSERT_TRUE(fs::exists(dir_ / "pf" / f)) << f;
    std::ofstream(dir_ / "pf" / "notes.txt") << "the user's file\n";
    r = cli("ibl prefilter sky.exr --out pf --levels 2 --format exr" + common);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(names(snapshot(dir_ / "pf")), " ibl.json irradiance.exr irradiance_preview.png notes.txt sh.json specular_m0.exr "
                                            "specular_m1.exr specular_preview.png");
    r = cli("ibl prefilter sky.exr --out pf --levels 3 --format dds" + common);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    // The irradiance follows the format (a DDS cubemap with its sidecar), and the EXR cross of before goes.
    EXPECT_EQ(names(snapshot(dir_ / "pf")), " ibl.json irradiance.dds irradiance.dds.json irradiance_preview.png notes.txt sh.json "
                                            "specular.dds specular.dds.json specular_preview.png");

    const std::string ir = " --face-size 4 --source-size 4 --backend oracle --threads 1 -q";
    ASSERT_EQ(cli("ibl irradiance sky.exr --out ir --format dds" + ir).exit_code, 0);
    ASSERT_EQ(cli("ibl irradiance sky.exr --out ir --format ktx2" + ir).exit_code, 0);
    EXPECT_EQ(names(snapshot(dir_ / "ir")), " irradiance.json irradiance.ktx2 irradiance_preview.png");
}

// The commit itself: a signal that came during the writes (ms::cancel_requested() set) stops the run
// before any file is replaced, and removes the temporaries.
TEST_F(IblReliability, ASignalDuringTheWritesCommitsNothing) {
    std::ofstream(path("a.txt")) << "old a\n";
    std::ofstream(path("b.txt")) << "old b\n";
    const auto before = snapshot(dir_);
    {
        OutputSet outputs;
        const std::size_t a = outputs.add(path("a.txt")), b = outputs.add(path("b.txt"));
        outputs.stream(a) << "new a\n";
        outputs.stream(b) << "new b\n";
        cancel_requested() = true;
        EXPECT_THROW(commit_outputs(outputs, {path("b.txt")}), Cancelled);
        cancel_requested() = false;
    }
    EXPECT_TRUE(snapshot(dir_) == before) << names(snapshot(dir_));
    OutputSet outputs;
    outputs.stream(outputs.add(path("a.txt"))) << "new a\n";
    commit_outputs(outputs, {path("b.txt")});  // b.txt: an earlier run's file this run does not write
    EXPECT_EQ(names(snapshot(dir_)), " a.txt");
    EXPECT_EQ(slurp_file(dir_ / "a.txt"), "new a\n");
}

// Starts `args` in dir (stdout and stderr to dir/log.txt); returns the CLI's own pid.
pid_t spawn_cli(const fs::path& dir, const std::string& args) {
    const std::string cmd = "cd '" + dir.string() + "' && exec " + cli_binary() + " " + args + " >log.txt 2>&1 </dev/null";
    const char* argv[] = {"sh", "-c", cmd.c_str(), nullptr};
    pid_t pid = 0;
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return -1;
    return pid;
}

// Runs `earlier` to completion, then `later` (whose every file differs from the earlier run's), stopped
// by SIGTERM at `fractions` of the time a whole `later` run takes (measured first, so the signals fall
// in the computation and in the writes alike): each time the destination holds exactly the earlier
// run's files, unchanged (exit 143, or killed by the signal before the CLI installed its handlers), or
// exactly a complete later run's (exit 0: the run finished first), and no temporary. A final rerun of
// `later` leaves exactly its own files. `out`: the destination folder under dir (log.txt is ignored).
void interrupt_between_runs(const fs::path& dir, const std::string& earlier, const std::string& later, const std::string& out,
                            const std::vector<double>& fractions) {
    auto outputs = [&] {
        auto all = snapshot(dir / out);
        all.erase("log.txt");
        return all;
    };
    auto run_to_end = [&](const std::string& args) {
        const auto t0 = Clock::now();
        const pid_t pid = spawn_cli(dir, args);
        int status = 0;
        waitpid(pid, &status, 0);
        EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << args << "\n" << slurp_file(dir / "log.txt");
        return std::chrono::duration<double>(Clock::now() - t0).count();
    };
    run_to_end(earlier);
    const auto old_files = outputs();
    ASSERT_FALSE(old_files.empty());
    const double seconds = run_to_end(later);
    const auto later_files = outputs();
    std::string later_names;
    for (const auto& [name, bytes] : later_files) later_names += " " + name;
    for (const auto& [name, bytes] : later_files)
        if (old_files.count(name)) ASSERT_TRUE(bytes != old_files.at(name)) << name << ": choose runs whose every file differs";
    run_to_end(earlier);  // back to the earlier run's files
    int stopped = 0;
    for (double fraction : fractions) {
        const double delay = fraction * seconds;
        const auto before = outputs();
        const pid_t pid = spawn_cli(dir, later);
        std::this_thread::sleep_for(std::chrono::duration<double>(delay));
        kill(pid, SIGTERM);
        int status = 0;
        waitpid(pid, &status, 0);
        const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
        const auto after = outputs();
        std::string after_names;
        for (const auto& [name, bytes] : after) after_names += " " + name;
        if (code == 143 || code == -SIGTERM) {
            ++stopped;
            std::string changed;
            for (const auto& [name, bytes] : after)
                if (!before.count(name) || before.at(name) != bytes) changed += " " + name;
            EXPECT_TRUE(after == before) << later << " (SIGTERM after " << delay << " s, exit " << code << "): files changed:" << changed
                                         << "; before:" << names(before) << ", after:" << names(after) << "\n" << slurp_file(dir / "log.txt");
        } else {
            EXPECT_EQ(code, 0) << slurp_file(dir / "log.txt");
            EXPECT_EQ(after_names, later_names) << "SIGTERM after " << delay << " s, exit " << code;
            for (const auto& [name, bytes] : after)
                if (before.count(name)) EXPECT_TRUE(bytes != before.at(name)) << name << " is the earlier run's (exit " << code << ")";
            run_to_end(earlier);  // the next attempt starts from the earlier run's files again
        }
        std::printf("[ibl] %s: SIGTERM after %.2f of %.2f s: exit %d\n", later.c_str(), delay, seconds, code);
    }
    EXPECT_GT(stopped, 0) << later << ": no attempt was interrupted";
    run_to_end(later);
    std::string final_names;
    for (const auto& [name, bytes] : outputs()) final_names += " " + name;
    EXPECT_EQ(final_names, later_names) << "the rerun after the interruptions";
}

const std::vector<double> kSignalFractions = {0.3, 0.6, 0.8, 0.9, 0.97};

TEST_F(IblReliability, SigtermDuringPrefilterThenRerunLeavesNoMixedOrStaleFiles) {
    env::write_exr(path("sky.exr"), sky(256, 128), {});
    // Every file of the two runs differs: seeds (specular), irradiance sizes (SH cross), exposures (previews).
    const std::string earlier = "ibl prefilter sky.exr --out pf --levels 4 --samples 64 --threads 1 --seed 1 --irradiance-size 8 --exposure 1 -q";
    // The later run has one mip more (stale when the earlier run is repeated) and bakes a DFG LUT, the
    // step after which a signal used to be noticed, with most of the files already replaced.
    const std::string later =
        "ibl prefilter sky.exr --out pf --levels 5 --samples 64 --threads 1 --seed 2 --irradiance-size 4 --exposure 2 --dfg-size 4 -q";
    // Under the sanitizers each run takes three times as long: a signal early, one late and one in the
    // writes (the optimised build takes all five).
    interrupt_between_runs(dir_, earlier, later, "pf", ms::testing::kAsan ? std::vector<double>{0.3, 0.8, 0.97} : kSignalFractions);
}

TEST_F(IblReliability, SigtermDuringIrradianceThenRerunLeavesNoMixedOrStaleFiles) {
    env::write_exr(path("sky.exr"), sky(64, 32), {});
    const std::string common = " --source-size 16 --backend oracle --threads 1 -q";
    const std::string earlier = "ibl irradiance sky.exr --out ir --face-size 4 --format dds --exposure 1" + common;
    const std::string later = "ibl irradiance sky.exr --out ir --face-size 8 --exposure 2" + common;
    interrupt_between_runs(dir_, earlier, later, "ir", kSignalFractions);
}

TEST_F(IblReliability, SigtermDuringDfgThenRerunLeavesNoMixedFiles) {
    const std::string earlier = "ibl dfg --method sampled --out d.exr --preview d.png --size 4 --samples 256 -q";
    const std::string later = "ibl dfg --method sampled --out d.exr --preview d.png --size 8 --samples 256 -q";
    interrupt_between_runs(dir_, earlier, later, ".", kSignalFractions);
}

// ---------------------------------------------------------------------------------------------------
// Failover.

const std::string kTwoDevices = "POCL_DEVICES='pthread pthread'";

nlohmann::json exr_metadata(const std::string& file, env::Image* image) {
    nlohmann::json meta;
    *image = env::read_exr_rgb(file, &meta);
    return meta;
}

TEST_F(IblReliability, DfgFailoverOnTwoDevicesGivesTheSameLut) {
    const std::string args = "ibl dfg --method sampled --size 8 --samples 1024 --replicates 4 -q --out ";
    ASSERT_EQ(cli(args + "one.exr").exit_code, 0);
    auto fault = cli(args + "fault.exr --device all", kTwoDevices + " MICROSHADOW_FAIL_DEVICE=0:0");
    ASSERT_EQ(fault.exit_code, 0) << fault.output;
    env::Image one, failed;
    exr_metadata(path("one.exr"), &one);
    const nlohmann::json meta = exr_metadata(path("fault.exr"), &failed);
    EXPECT_EQ(one.data, failed.data);
    EXPECT_GE(meta.at("rerun_items").get<int>(), 1) << meta.dump(2);
    EXPECT_EQ(meta.at("failed_devices").size(), 1u);
    auto dead = cli(args + "dead.exr --preview dead.png", "MICROSHADOW_FAIL_DEVICE=0:0");
    EXPECT_NE(dead.exit_code, 0);
    EXPECT_NE(dead.output.find("every selected device failed"), std::string::npos) << dead.output;
    EXPECT_FALSE(fs::exists(path("dead.exr")));
    EXPECT_FALSE(fs::exists(path("dead.png")));
    EXPECT_EQ(cli("ibl dfg --size 4 -q --out x.exr", "MICROSHADOW_FAIL_DEVICE=zero").exit_code, 2);
}

TEST_F(IblReliability, PrefilterFailoverOnTwoDevicesGivesTheSameMips) {
    env::write_exr(path("sky.exr"), sky(64, 32), {});
    const std::string args = "ibl prefilter sky.exr --levels 3 --samples 64 --irradiance-size 4 --format exr -q --out ";
    ASSERT_EQ(cli(args + "one --device 0").exit_code, 0);
    auto fault = cli(args + "fault --device all", kTwoDevices + " MICROSHADOW_FAIL_DEVICE=0:0");
    ASSERT_EQ(fault.exit_code, 0) << fault.output;
    for (int m = 0; m < 3; ++m) {
        const std::string file = "/specular_m" + std::to_string(m) + ".exr";
        env::Image a, b;
        exr_metadata(path("one") + file, &a);
        const nlohmann::json meta = exr_metadata(path("fault") + file, &b);
        EXPECT_EQ(a.data, b.data) << file;
        if (m == 0) EXPECT_GE(meta.at("rerun_items").get<int>(), 1) << meta.dump(2);
    }
    auto dead = cli(args + "dead --device 0", "MICROSHADOW_FAIL_DEVICE=0:0");
    EXPECT_NE(dead.exit_code, 0);
    EXPECT_NE(dead.output.find("every selected device failed"), std::string::npos) << dead.output;
    EXPECT_FALSE(fs::exists(path("dead"))) << "an empty --out folder was left";
}

TEST_F(IblReliability, IrradianceFailoverOnTwoDevicesGivesTheSameMap) {
    env::write_exr(path("sky.exr"), sky(64, 32), {});
    const std::string args = "ibl irradiance sky.exr --face-size 8 --source-size 8 -q --out ";
    ASSERT_EQ(cli(args + "one").exit_code, 0);
    auto fault = cli(args + "fault --device all", kTwoDevices + " MICROSHADOW_FAIL_DEVICE=0:0");
    ASSERT_EQ(fault.exit_code, 0) << fault.output;
    env::Image a, b;
    exr_metadata(path("one/irradiance.exr"), &a);
    const nlohmann::json meta = exr_metadata(path("fault/irradiance.exr"), &b);
    EXPECT_EQ(a.data, b.data);
    EXPECT_GE(meta.at("rerun_items").get<int>(), 1) << meta.dump(2);
    auto dead = cli(args + "dead", "MICROSHADOW_FAIL_DEVICE=0:0");
    EXPECT_NE(dead.exit_code, 0);
    EXPECT_NE(dead.output.find("every selected device failed"), std::string::npos) << dead.output;
    EXPECT_FALSE(fs::exists(path("dead")));
}

}  // namespace
