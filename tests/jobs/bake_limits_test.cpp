// Bakes that cannot run are refused before any work, with the figure and the
// limit. Before: `bake --size 4096` ended in "std::bad_alloc", `--size 1024` tried to allocate ~35 GiB,
// and seed-2d 4096 with 2^30 samples blamed the device (CL_INVALID_BUFFER_SIZE).
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>

#include "cli_runner.hpp"
#include "jobs/bake.hpp"

namespace ms {
namespace {

TEST(BakeLimits, BakesThatCannotFitAreRefusedUpFrontWithTheFigures) {
    const std::string env = "POCL_CACHE_DIR=" + (std::filesystem::temp_directory_path() / "pocl-cache-limits").string() + " ";
    const std::string out = (std::filesystem::temp_directory_path() / "microshadow_limits_never.exr").string();
    for (const std::string args : {"--size 4096", "--size 1024", "--layout seed-2d --size 4096 --samples 1073741824"}) {
        const auto start = std::chrono::steady_clock::now();
        const auto r = testing::run_shell(env + MICROSHADOW_CLI + " bake -q --out " + out + " " + args + " 2>&1");
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find("of memory"), std::string::npos) << args << "\n" << r.output;
        EXPECT_NE(r.output.find("GiB"), std::string::npos) << r.output;
        EXPECT_EQ(r.output.find("bad_alloc"), std::string::npos) << r.output;
        EXPECT_FALSE(std::filesystem::exists(out));
        EXPECT_LT(seconds, 10.0) << args << ": refused only after work";  // nothing is baked first
    }
}

TEST(BakeLimits, TheEstimateGrowsWithTheLayoutAndCoversTheAtlas) {
    BakeSpec small = default_bake_spec(LutLayout::seed_3d, 16), big = default_bake_spec(LutLayout::seed_3d, 64);
    const std::uint64_t a = bake_host_memory(small, 1), b = bake_host_memory(big, 1);
    EXPECT_GE(a, std::uint64_t(16) * 16 * 16 * 4 * 8);  // values and errors, 4 bytes each
    EXPECT_GE(b, std::uint64_t(64) * 64 * 64 * 4 * 8);
    EXPECT_GT(bake_host_memory(big, 2), b);  // each place holds a slice's tallies
}

// Peak resident memory (KiB) of `command` run through sh, from the kernel's accounting (wait4).
long peak_rss_kib(const std::string& command) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    int status = 0;
    struct rusage usage {};
    if (pid < 0 || ::wait4(pid, &status, 0, &usage) != pid || !WIFEXITED(status) || WEXITSTATUS(status) != 0) return -1;
    return usage.ru_maxrss;
}

// AddressSanitizer keeps freed memory in quarantine (256 MB by default), so RSS measures it, not us.
#if defined(__SANITIZE_ADDRESS__)
#define MICROSHADOW_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MICROSHADOW_UNDER_ASAN 1
#endif
#endif

TEST(BakeLimits, MemoryStaysFlatHoweverManyBatchesAToleranceAsksFor) {
#ifdef MICROSHADOW_UNDER_ASAN
    GTEST_SKIP() << "peak RSS under AddressSanitizer counts its quarantine of freed memory";
#endif
    // Class 11: every batch's point set was kept for the whole bake (a 2 x 2 seed-2d bake with
    // --tolerance 1e-7 --max-batches 4096 reached 4.29 GB, about 1 MB a batch). 16 and 256 batches
    // must now peak within 20 MB of each other (240 batches at ~1 MB each would add ~240 MB).
    const std::string base = "POCL_CACHE_DIR=" + (std::filesystem::temp_directory_path() / "pocl-cache-limits").string() +
                             " exec " + MICROSHADOW_CLI + " bake -q --layout seed-2d --size 2 --tolerance 1e-7 --allow-tolerance-miss --out " +
                             (std::filesystem::temp_directory_path() / "microshadow_limits_tol.exr").string() +
                             " --max-batches ";
    const long few = peak_rss_kib(base + "16"), many = peak_rss_kib(base + "256");
    ASSERT_GT(few, 0);
    ASSERT_GT(many, 0);
    EXPECT_LT(many - few, 20 * 1024) << "peak RSS " << few << " KiB at 16 batches, " << many << " KiB at 256";
    std::filesystem::remove(std::filesystem::temp_directory_path() / "microshadow_limits_tol.exr");
}

}  // namespace
}  // namespace ms
