// `microshadow help [COMMAND]`, and the closest spelling for a
// mistyped option or command (before: "not expected: 16 --szie" and nothing else; `help` was refused).
// Then what a new user meets in the first hour (FirstHour*): one-line errors with the closest spelling,
// exit statuses, summaries that say what they count and what their times measure, `repr info` and
// `lut info` alike, progress with an estimate of the time left, no compiler chatter from kernel builds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "opencl_platform.hpp"

namespace ms {
namespace {

using ms::testing::cli;

TEST(CliHelp, HelpListsTheCommandsAndDescribesOne) {
    const auto all = cli("help");
    EXPECT_EQ(all.exit_code, 0) << all.output;
    for (const char* command : {"devices", "eval", "bake", "sweep", "merge", "shader", "scene"})
        EXPECT_NE(all.output.find(command), std::string::npos) << command << "\n" << all.output;
    const auto bake = cli("help bake");
    EXPECT_EQ(bake.exit_code, 0);
    EXPECT_NE(bake.output.find("--azimuth"), std::string::npos) << bake.output;
    const auto unknown = cli("help bkae");
    EXPECT_EQ(unknown.exit_code, 2);
    EXPECT_NE(unknown.output.find("did you mean bake?"), std::string::npos) << unknown.output;
}

TEST(CliHelp, MistypedOptionsAndCommandsGetTheClosestSpelling) {
    const auto option = cli("bake --szie 16 --out never.exr");
    EXPECT_EQ(option.exit_code, 2);
    EXPECT_NE(option.output.find("did you mean --size?"), std::string::npos) << option.output;
    const auto command = cli("bkae --out never.exr");
    EXPECT_EQ(command.exit_code, 2);
    EXPECT_NE(command.output.find("did you mean bake?"), std::string::npos) << command.output;
    // Nothing close: no guess.
    const auto far = cli("bake --zzzzzzzzzz 1 --out never.exr");
    EXPECT_EQ(far.exit_code, 2);
    EXPECT_EQ(far.output.find("did you mean"), std::string::npos) << far.output;
}

TEST(CliHelp, BakeSamplesAreDescribedAsTheSummaryCountsThem) {
    const auto help = cli("bake --help");
    EXPECT_NE(help.output.find("samples per slice and batch"), std::string::npos) << help.output;
}

TEST(CliHelp, HelpDescribesNestedCommands) {
    // Before: "'bake' is not a command; did you mean bake?" (help took one word).
    const auto repr_bake = cli("help repr bake");
    EXPECT_EQ(repr_bake.exit_code, 0) << repr_bake.output;
    EXPECT_NE(repr_bake.output.find("--azimuth-nodes"), std::string::npos) << repr_bake.output;
    EXPECT_NE(repr_bake.output.find("Usage: microshadow repr bake [OPTIONS]"), std::string::npos) << repr_bake.output;
    const auto prefilter = cli("help ibl prefilter");
    EXPECT_EQ(prefilter.exit_code, 0) << prefilter.output;
    EXPECT_NE(prefilter.output.find("--faces"), std::string::npos) << prefilter.output;
    const auto lut_export = cli("help lut export");
    EXPECT_EQ(lut_export.exit_code, 0) << lut_export.output;
    EXPECT_NE(lut_export.output.find("--encoding"), std::string::npos) << lut_export.output;
    // A subcommand that does not exist names the ones that do.
    const auto wrong = cli("help repr bkae");
    EXPECT_EQ(wrong.exit_code, 2) << wrong.output;
    EXPECT_NE(wrong.output.find("'repr' has no subcommand 'bkae'"), std::string::npos) << wrong.output;
    EXPECT_NE(wrong.output.find("bake"), std::string::npos) << wrong.output;
}

TEST(CliHelp, HelpPointsAtFilesThatExistAndNamesEveryBakeFormat) {
    // sweep --help pointed to a header that does not exist; every docs/ or host/ path any help text
    // names must exist in the source tree.
    std::string all = cli("help").output;
    for (const char* command : {"eval", "bake", "sweep", "merge", "shader", "scene", "ibl", "design", "repr", "lut",
                                "repr bake", "ibl prefilter", "ibl dfg", "lut info", "lut export"})
        all += cli(std::string("help ") + command).output;
    for (const char* prefix : {"docs/", "host/"}) {
        for (std::size_t at = all.find(prefix); at != std::string::npos; at = all.find(prefix, at + 1)) {
            std::size_t end = at;
            while (end < all.size() && (std::isalnum(static_cast<unsigned char>(all[end])) || std::string("/._-*").find(all[end]) != std::string::npos)) ++end;
            std::string path = all.substr(at, end - at);
            while (!path.empty() && (path.back() == '.' || path.back() == ')')) path.pop_back();
            if (path.find('*') != std::string::npos) path = path.substr(0, path.rfind('/'));  // a glob: its folder
            EXPECT_TRUE(std::filesystem::exists(std::string(MICROSHADOW_SOURCE_DIR) + "/" + path)) << path << " named in the help";
        }
    }
    // The summary said bake writes "to OpenEXR" only.
    const auto top = cli("help");
    const std::size_t at = top.output.find("\n  bake ");
    ASSERT_NE(at, std::string::npos) << top.output;
    const std::string line = top.output.substr(at + 1, top.output.find('\n', at + 1) - at - 1);
    for (const char* format : {"OpenEXR", "KTX2", "DDS", "C header", "PNG"}) EXPECT_NE(line.find(format), std::string::npos) << line;
}

// --- the first hour ---------------------------------------------------------------------------------

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::run_shell;

const std::string kFirstHourSource = MICROSHADOW_SOURCE_DIR;

std::size_t first_hour_lines(const std::string& text) { return std::count(text.begin(), text.end(), '\n'); }

class FirstHour : public ms::testing::ScratchDirTest {
protected:
    FirstHour() : ScratchDirTest("first_hour") {}
    // The program run inside the scratch folder (its outputs land there), stderr joined to stdout.
    RunResult here(const std::string& args, const ms::testing::ShellVariables& env = {}) {
        return run_shell(ms::testing::shell_prefix(dir_, env) + MICROSHADOW_CLI + " " + args + " 2>&1");
    }
};

TEST(FirstHourCli, AMistypedWordIsOneLineWithTheClosestSpelling) {
    // Before: CLI11's message, "Run with --help for more information." and then the suggestion; a
    // missing --out was reported instead of the misspelt option beside it.
    for (const auto& [args, expected] : std::vector<std::pair<std::string, std::string>>{
             {"bake --szie 16 --out never.exr", "did you mean --size?"},
             {"bake --sizee 3", "did you mean --size?"},
             {"bkae --out never.exr", "did you mean bake?"},
             {"version", "did you mean --version?"},
             {"lut infp never.exr", "did you mean info?"},
             {"repr bake --presett full-range --out never.exr", "did you mean --preset?"}}) {
        const RunResult r = cli(args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_EQ(first_hour_lines(r.output), 1u) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(expected), std::string::npos) << args << "\n" << r.output;
        EXPECT_EQ(r.output.find("Run with --help"), std::string::npos) << r.output;
        EXPECT_EQ(r.output.find("A subcommand is required"), std::string::npos) << r.output;
    }
    // An option of another command is not "suggested" as itself.
    const RunResult elsewhere = cli("devices --device 3");
    EXPECT_EQ(elsewhere.exit_code, 2) << elsewhere.output;
    EXPECT_EQ(elsewhere.output.find("did you mean --device"), std::string::npos) << elsewhere.output;
    const RunResult version = cli("--version");
    EXPECT_EQ(version.exit_code, 0);
    EXPECT_EQ(version.output, "microshadow " MICROSHADOW_VERSION "\n");
}

TEST(FirstHourCli, ADeviceIndexThisMachineDoesNotHaveIsBadInput) {
    // Before: exit status 1, as for a failure while running.
    const RunResult r = cli("eval --method sampled --in " + kFirstHourSource + "/examples/queries.csv --out - --device 999");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("no OpenCL device 999; the devices are"), std::string::npos) << r.output;
}

TEST_F(FirstHour, SummariesCountWhatTheMethodDidAndProgressEstimatesTheTimeLeft) {
    // Before: "10 queries (7 sampled, ...)" under the exact method, which samples nothing.
    const RunResult exact = here("eval --in " + kFirstHourSource + "/examples/queries.csv --out t.csv");
    ASSERT_EQ(exact.exit_code, 0) << exact.output;
    EXPECT_NE(exact.output.find("(7 integrated, 2 exact 0"), std::string::npos) << exact.output;
    EXPECT_EQ(exact.output.find("sampled"), std::string::npos) << exact.output;
    EXPECT_NE(exact.output.find("computed in "), std::string::npos) << exact.output;
    // Six sphere lights, one work item each: the reports between 0 % and 100 % estimate the time left.
    const RunResult area = here("area eval --in " + kFirstHourSource + "/examples/lights.csv --out a.csv --method exact");
    ASSERT_EQ(area.exit_code, 0) << area.output;
    EXPECT_NE(area.output.find("(6 integrated,"), std::string::npos) << area.output;
    EXPECT_NE(area.output.find(" left\n"), std::string::npos) << area.output;
}

TEST_F(FirstHour, ASampledEvalToAToleranceSaysWhatTheQueriesSampledAgainGot) {
    // Before: "1024 samples each" although the queries above the tolerance were sampled again with 4^k x.
    const RunResult r = here("eval --method sampled --samples 1024 --tolerance 1e-3 --in " + kFirstHourSource +
                             "/examples/queries.csv --out t.csv");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("1024 samples each, up to "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(" sampled again to the tolerance, max std error "), std::string::npos) << r.output;
    // Without a tolerance nothing is sampled again and the summary says only the one count.
    const RunResult once = here("eval --method sampled --samples 1024 --in " + kFirstHourSource + "/examples/queries.csv --out t.csv");
    ASSERT_EQ(once.exit_code, 0) << once.output;
    EXPECT_EQ(once.output.find("up to"), std::string::npos) << once.output;
}

TEST_F(FirstHour, AMergeSaysItReadEarlierWorkRatherThanReportComputeTime) {
    for (const char* shard : {"0/2", "1/2"}) ASSERT_EQ(here(std::string("bake --size 4 -q --samples 1024 --out m.exr --shard ") + shard).exit_code, 0);
    const RunResult merge = here("bake --size 4 --samples 1024 --out m.exr --merge");
    ASSERT_EQ(merge.exit_code, 0) << merge.output;
    // Before: "...; 0.00158 s on <device>", as if the merge had computed the LUT that fast.
    EXPECT_NE(merge.output.find("merged 16 slices computed by earlier runs (read in "), std::string::npos) << merge.output;
    EXPECT_EQ(merge.output.find(" s on "), std::string::npos) << merge.output;
}

TEST_F(FirstHour, LutInfoOfAFloatCopyOfAPngNamesThePngsSteps) {
    ASSERT_EQ(here("bake --size 4 -q --samples 1024 --out l.png").exit_code, 0);
    ASSERT_EQ(here("lut export l.png --out l.exr").exit_code, 0);
    const RunResult info = here("lut info l.exr");
    ASSERT_EQ(info.exit_code, 0) << info.output;
    // Before: "exr float32 (the baked floats exactly)".
    EXPECT_EQ(info.output.find("exactly"), std::string::npos) << info.output;
    // Half an 8-bit step (0.5/255 = 0.00196078) plus the float32 rounding of the stored value (<= 2^-25).
    EXPECT_NE(info.output.find("exported from an earlier unorm8 png file: each texel within 0.0019608"), std::string::npos) << info.output;
}

TEST_F(FirstHour, ReprInfoSummarisesLikeLutInfoAndJsonGivesTheRecord) {
    ASSERT_EQ(here("repr bake -q --kind azimuth-axis --visibility-count 4 --n-dot-l-count 4 --n-dot-v-count 2 "
                   "--azimuth-nodes 3 --roughness 0.3,0.7 --out r.exr")
                  .exit_code,
              0);
    const RunResult info = here("repr info r.exr");
    ASSERT_EQ(info.exit_code, 0) << info.output;
    // Before: the name, the cost and then the raw JSON record.
    EXPECT_EQ(info.output.find('{'), std::string::npos) << info.output;
    for (const char* line : {"r.exr: representation azimuth-axis\n", "\ncost: ", "\ndomain: roughness [", "\nmade by: microshadow "})
        EXPECT_NE(info.output.find(line), std::string::npos) << line << "\n" << info.output;
    const RunResult json = here("repr info r.exr --json");
    ASSERT_EQ(json.exit_code, 0) << json.output;
    EXPECT_EQ(json.output.front(), '{') << json.output;
    EXPECT_NE(json.output.find("\"representation\": \"azimuth-axis\""), std::string::npos) << json.output;
}

TEST_F(FirstHour, PlotDoesNotEchoItsPythonCommandLine) {
    // A copy of the program with a stand-in plotter beside it (../share/microshadow/plot_sweep.py) that
    // prints the figure it "wrote", as the real one does; the sweep is tiny and runs on the oracle.
    fs::create_directories(dir_ / "bin");
    fs::create_directories(dir_ / "share" / "microshadow");
    fs::copy_file(MICROSHADOW_CLI, dir_ / "bin" / "microshadow");
    std::ofstream(dir_ / "share" / "microshadow" / "plot_sweep.py") << "print('figures/terms.png')\n";
    std::ofstream(dir_ / "s.toml") << "[parameters]\nvisibility = [0.5, 0.9]\nn_dot_l = [0.5]\nroughness = [0.5]\n"
                                      "[comparators]\nanalytic = [\"naughty-dog\"]\n";
    const RunResult r = run_shell("cd '" + dir_.string() + "' && ./bin/microshadow sweep s.toml --out o --plot --backend oracle "
                                  "--method sampled --samples 64 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("figures/terms.png"), std::string::npos) << r.output;
    // Before: "sweep: /usr/bin/python3 .../plot_sweep.py heatmaps .../sweep.csv --out .../figures".
    EXPECT_EQ(r.output.find("plot_sweep.py"), std::string::npos) << r.output;
}

TEST_F(FirstHour, KernelCompilerWarningsStayInTheBuildLogUnlessAsked) {
    MS_SKIP_UNLESS_POCL();
    // The kernels with one that draws a compiler warning, from a cold kernel cache: PoCL's compiler
    // wrote "1 warning generated." on the command's stderr; it belongs to the build log (-v).
    const fs::path kernels = dir_ / "kernels";
    fs::copy(kFirstHourSource + "/kernels", kernels, fs::copy_options::recursive);
    std::ofstream(kernels / "term" / "generic_term.cl", std::ios::app)
        << "\nkernel void ms_warning_probe(global float* x) { if (x[0] = 1) { x[1] = 2; } }\n";
    const ms::testing::ShellVariables env = {{"MICROSHADOW_KERNEL_DIR", kernels.string()}, {"POCL_CACHE_DIR", (dir_ / "pocl").string()}};
    const std::string eval = "eval --method sampled --samples 1024 -q --in " + kFirstHourSource + "/examples/queries.csv --out t.csv";
    const RunResult quiet = here(eval, env);
    ASSERT_EQ(quiet.exit_code, 0) << quiet.output;
    EXPECT_EQ(quiet.output, "") << quiet.output;
    fs::remove_all(dir_ / "pocl");
    const RunResult verbose = here(eval + " -v", env);
    ASSERT_EQ(verbose.exit_code, 0) << verbose.output;
    EXPECT_NE(verbose.output.find("kernel build of term/generic_term.cl"), std::string::npos) << verbose.output;
    EXPECT_NE(verbose.output.find("using the result of an assignment as a condition"), std::string::npos) << verbose.output;
}

}  // namespace
}  // namespace ms
