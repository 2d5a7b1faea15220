// Issue 12, "installable and quiet": `microshadow help [COMMAND]`, and the closest spelling for a
// mistyped option or command (before: "not expected: 16 --szie" and nothing else; `help` was refused).
#include <gtest/gtest.h>

#include "cli_runner.hpp"

namespace ms {
namespace {

testing::RunResult cli(const std::string& args) { return testing::run_shell(std::string(MICROSHADOW_CLI) + " " + args + " 2>&1"); }

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

}  // namespace
}  // namespace ms
