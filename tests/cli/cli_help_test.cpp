// `microshadow help [COMMAND]`, and the closest spelling for a
// mistyped option or command (before: "not expected: 16 --szie" and nothing else; `help` was refused).
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>

#include "cli_runner.hpp"

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

}  // namespace
}  // namespace ms
