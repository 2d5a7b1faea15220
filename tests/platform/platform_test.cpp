// The platform layer (host/platform): the same behaviour from its POSIX and Win32 halves (this file
// runs in the Linux suite and, cross-built, under Wine), and the program without an OpenCL runtime.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "cli_runner.hpp"
#include "platform/files.hpp"
#include "platform/memory.hpp"
#include "platform/process.hpp"
#include "test_files.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::ScratchDirTest;

class PlatformTest : public ScratchDirTest {
protected:
    PlatformTest() : ScratchDirTest("platform") {}
    std::string write_text(const std::string& name, const std::string& text) {
        std::ofstream(path(name), std::ios::binary) << text;
        return path(name);
    }
};

TEST_F(PlatformTest, ExclusiveLockIsRefusedToASecondDescriptorUntilReleased) {
    const std::string lock = path("cache.lock");
    const int first = ms::platform::open_file(lock, ms::platform::read_write | ms::platform::create, 0644);
    const int second = ms::platform::open_file(lock, ms::platform::read_write | ms::platform::create, 0644);
    ASSERT_GE(first, 0);
    ASSERT_GE(second, 0);
    EXPECT_EQ(ms::platform::try_lock_exclusive(first), 0);
    EXPECT_EQ(ms::platform::try_lock_exclusive(second), 1) << "a second holder while the first keeps it";
    ms::platform::close_file(first);
    EXPECT_EQ(ms::platform::try_lock_exclusive(second), 0) << "free once the first descriptor is closed";
    ms::platform::close_file(second);
}

TEST_F(PlatformTest, ReplaceFileReplacesAnExistingTargetInOneStep) {
    // std::rename refuses an existing target on Windows; outputs are replaced this way.
    const std::string target = write_text("out.csv", "old");
    const std::string temp = write_text(".out.csv.tmp.1", "new");
    ASSERT_EQ(ms::platform::replace_file(temp, target), 0) << std::strerror(errno);
    EXPECT_EQ(ms::testing::slurp_file(target), "new");
    EXPECT_FALSE(fs::exists(temp));
}

TEST_F(PlatformTest, StatusTellsRegularFilesDirectoriesAndMissingPaths) {
    ms::platform::FileStatus s;
    ASSERT_EQ(ms::platform::link_status(write_text("a.txt", "12345"), s), 0);
    EXPECT_EQ(s.kind, ms::platform::FileKind::regular);
    EXPECT_EQ(s.size, 5u);
    ASSERT_EQ(ms::platform::path_status(dir_.string(), s), 0);
    EXPECT_EQ(s.kind, ms::platform::FileKind::directory);
    EXPECT_TRUE(ms::platform::can_create_in(dir_.string()));
    EXPECT_EQ(ms::platform::link_status(path("missing"), s), -1);
    EXPECT_EQ(errno, ENOENT);
}

TEST_F(PlatformTest, DescriptorsWriteReadAndSync) {
    const std::string file = path("data.bin");
    const int fd = ms::platform::open_file(file, ms::platform::write_only | ms::platform::create | ms::platform::truncate);
    ASSERT_GE(fd, 0);
    const std::string bytes("a\nb\r\n\0z", 7);  // binary: no newline translation on Windows
    EXPECT_EQ(ms::platform::write_some(fd, bytes.data(), bytes.size()), 7);
    EXPECT_EQ(ms::platform::sync_file(fd), 0);
    EXPECT_EQ(ms::platform::close_file(fd), 0);
    EXPECT_EQ(ms::platform::sync_path(file), 0);
    EXPECT_EQ(ms::testing::slurp_file(file), bytes);
    std::string made = path("probe-XXXXXX");
    const int unique = ms::platform::make_unique_file(made);
    ASSERT_GE(unique, 0);
    ms::platform::close_file(unique);
    EXPECT_NE(made, path("probe-XXXXXX"));
    EXPECT_TRUE(fs::is_regular_file(made));
}

TEST(Platform, ProcessesMemoryAndTheExecutable) {
    EXPECT_GT(ms::platform::physical_memory(), std::uint64_t(64) << 20);
    EXPECT_TRUE(ms::platform::process_exists(ms::platform::process_id()));
    std::error_code ec;
    const std::string exe = ms::platform::executable_path(ec);
    EXPECT_FALSE(ec) << ec.message();
    EXPECT_TRUE(fs::is_regular_file(fs::u8path(exe))) << exe;
}

TEST(Platform, RunProgramGivesBackTheExitStatusWithoutAShell) {
#ifdef _WIN32
    const std::vector<std::string> exits_3 = {"cmd", "/c", "exit 3"};
#else
    const std::vector<std::string> exits_3 = {"sh", "-c", "exit 3"};
#endif
    const ms::platform::ProcessEnd end = ms::platform::run_program(exits_3);
    EXPECT_TRUE(end.exited);
    EXPECT_EQ(end.code, 3);
    EXPECT_THROW(ms::platform::run_program({"microshadow-no-such-program"}), std::system_error);
}

// Without an OpenCL runtime (MICROSHADOW_OPENCL_LIBRARY names a file that is not there; the child
// inherits it) a job on the default device runs on the C++ backend and says so once; a named device
// is refused with the reason.
class NoOpenClRuntime : public ScratchDirTest {
protected:
    NoOpenClRuntime() : ScratchDirTest("no_opencl") {}
    void SetUp() override {
        ScratchDirTest::SetUp();
        ms::platform::set_environment("MICROSHADOW_OPENCL_LIBRARY", path("no-such-opencl-runtime"));
    }
    void TearDown() override {
        ms::platform::set_environment("MICROSHADOW_OPENCL_LIBRARY", "");
        ScratchDirTest::TearDown();
    }
};

TEST_F(NoOpenClRuntime, TheDefaultDeviceFallsBackToTheCppBackendAndSaysSoOnce) {
    std::ofstream(path("q.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n"
                                    "0.5,0.3,0.3,0.3,0,0.9539392014169456,-0.2,0.1,0.9746794344808963\n"
                                    "0.25,0.6,0.6,0,0.5,0.8660254037844386,0,0,1\n";
    auto r = ms::testing::cli("eval --method exact --in " + path("q.csv") + " --out " + path("r.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string note = "no OpenCL runtime is installed";
    const auto first = r.output.find(note);
    ASSERT_NE(first, std::string::npos) << r.output;
    EXPECT_EQ(r.output.find(note, first + 1), std::string::npos) << "said once\n" << r.output;
    EXPECT_NE(r.output.find("running on the CPU with the C++ backend"), std::string::npos) << r.output;
    EXPECT_TRUE(fs::is_regular_file(path("r.csv")));

    r = ms::testing::cli("eval --method exact --device 0 --in " + path("q.csv") + " --out " + path("d.csv"));
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(note), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(path("d.csv")));
}

}  // namespace
