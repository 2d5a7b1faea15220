// Issue 10, class 12: bakes that cannot run are refused before any work, with the figure and the
// limit. Before: `bake --size 4096` ended in "std::bad_alloc", `--size 1024` tried to allocate ~35 GiB,
// and seed-2d 4096 with 2^30 samples blamed the device (CL_INVALID_BUFFER_SIZE).
#include <gtest/gtest.h>

#include <chrono>

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

}  // namespace
}  // namespace ms
