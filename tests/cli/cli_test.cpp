// The microshadow CLI end to end: eval on good and bad input, exit codes, messages, no partial files.
#include <gtest/gtest.h>


#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_runner.hpp"
#include "io/csv.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

RunResult run(const std::string& args) {
    const std::string cmd = std::string(MICROSHADOW_CLI) + " " + args + " 2>&1";
    return run_shell(cmd);
}

class CliTest : public ScratchDirTest {
protected:
    CliTest() : ScratchDirTest("cli") {}
    std::string write(const std::string& name, const std::string& text) {
        const auto p = dir_ / name;
        std::ofstream(p, std::ios::binary) << text;
        return p.string();
    }
};

const std::string kHeader = "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n";

TEST_F(CliTest, EvalWritesInputColumnsPlusTermAndError) {
    const auto in = write("q.csv", kHeader +
                                       "0.5,0.16,0.16,0.9797959,0,0.2,0.6,0,0.8\n"
                                       "0.5,0.16,0.16,0,0,2,0.6,0,-0.8\n"     // wo below the horizon: 0
                                       "1,0.3,0.1,0,0,1,0.3,0.3,0.5\n");      // v = 1: exactly 1
    for (const std::string backend : {"opencl", "oracle"}) {
        const auto out = path("r_" + backend + ".csv");
        const auto r = run("eval --method sampled --in " + in + " --out " + out + " --backend " + backend + " --samples 16384");
        ASSERT_EQ(r.exit_code, 0) << r.output;
        const auto table = ms::read_numeric_csv(out, [] {
            auto c = ms::kQueryColumns;
            c.push_back("term");
            c.push_back("std_error");
            return c;
        }());
        ASSERT_EQ(table.rows.size(), 3u);
        // docs/method.md quotes about 0.90 for this query (its known answer); 2 digits => within 0.005 plus 5 standard errors.
        EXPECT_NEAR(table.rows[0][9], 0.90, 0.005 + 5 * table.rows[0][10]);
        EXPECT_EQ(table.rows[1][9], 0.0);
        EXPECT_EQ(table.rows[2][9], 1.0);
        EXPECT_TRUE(fs::exists(out + ".json"));
    }
}

TEST_F(CliTest, DevicesListsPoclCpu) {
    const auto r = run("devices");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("(default)"), std::string::npos) << r.output;
}

struct BadInput {
    const char* name;
    std::string text;
    const char* expected;  // part of the message
};

TEST_F(CliTest, BadInputGetsAClearMessageAndNoOutputFile) {
    const std::string good_row = "0.5,0.2,0.2,0,0,1,0.5,0,0.8\n";
    const std::vector<BadInput> cases = {
        {"empty", "", "empty file"},
        {"missing_column", "visibility,alpha_x,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n", "missing column 'alpha_y'"},
        {"unknown_column", "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,extra\n", "unknown column 'extra'"},
        {"duplicate_column", "visibility,visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n", "duplicate column"},
        {"not_a_number", kHeader + good_row + "0.5,abc,0.2,0,0,1,0.5,0,0.8\n", ":3: column 'alpha_x': 'abc' is not a number"},
        {"nan", kHeader + "nan,0.2,0.2,0,0,1,0.5,0,0.8\n", "column 'visibility': 'nan' is not a finite number"},
        {"infinity", kHeader + "0.5,inf,0.2,0,0,1,0.5,0,0.8\n", "column 'alpha_x': 'inf' is not a finite number"},
        {"huge", kHeader + "0.5,1e999,0.2,0,0,1,0.5,0,0.8\n", "out of the range"},
        {"visibility_range", kHeader + "1.5,0.2,0.2,0,0,1,0.5,0,0.8\n", "column 'visibility': 1.5 is outside [0, 1]"},
        {"alpha_zero", kHeader + "0.5,0.2,0,0,0,1,0.5,0,0.8\n", "column 'alpha_y': 0 must be > 0"},
        {"alpha_negative", kHeader + "0.5,-0.2,0.2,0,0,1,0.5,0,0.8\n", "column 'alpha_x'"},
        {"zero_wi", kHeader + "0.5,0.2,0.2,0,0,0,0.5,0,0.8\n", "'wi_x,wi_y,wi_z': zero-length"},
        {"zero_wo", kHeader + "0.5,0.2,0.2,0,0,1,0,0,0\n", "'wo_x,wo_y,wo_z': zero-length"},
        {"wi_below", kHeader + "0.5,0.2,0.2,0,0.5,-0.1,0.5,0,0.8\n", "above the horizon"},
        {"short_row", kHeader + "0.5,0.2,0.2,0,0,1\n", "6 fields, but the header has 9"},
        {"binary", std::string("\x7f" "ELF\0\0\x01", 7), "binary data"},
    };
    for (const auto& c : cases) {
        const auto in = write(std::string(c.name) + ".csv", c.text);
        const auto out = path(std::string(c.name) + "_out.csv");
        const auto r = run("eval --method sampled --in " + in + " --out " + out + " --samples 1024");
        EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.output;
        EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.name << ": " << r.output;
        EXPECT_FALSE(fs::exists(out)) << c.name;
    }
    // Nothing but the inputs is left in the directory (no temporary files either).
    std::size_t files = 0;
    for (auto& e : fs::directory_iterator(dir_)) files += e.is_regular_file();
    EXPECT_EQ(files, cases.size());
}

TEST_F(CliTest, BadCommandLinesExitWithUsageErrors) {
    const auto in = write("q.csv", kHeader + "0.5,0.2,0.2,0,0,1,0.5,0,0.8\n");
    EXPECT_EQ(run("").exit_code, 2);
    EXPECT_EQ(run("frobnicate").exit_code, 2);
    EXPECT_EQ(run("eval --method sampled --in " + in).exit_code, 2);  // --out missing
    EXPECT_EQ(run("eval --method sampled --in " + in + " --out " + path("o.csv") + " --form wrong").exit_code, 2);
    EXPECT_EQ(run("eval --method sampled --in " + in + " --out " + path("o.csv") + " --samples -5").exit_code, 2);
    const auto missing = run("eval --method sampled --in " + path("does_not_exist.csv") + " --out " + path("o.csv"));
    EXPECT_EQ(missing.exit_code, 2);
    EXPECT_NE(missing.output.find("cannot open"), std::string::npos);
    const auto baddir = run("eval --method sampled --in " + in + " --out /nonexistent_dir/o.csv");
    EXPECT_NE(baddir.exit_code, 0);
    EXPECT_NE(baddir.output.find("does not exist"), std::string::npos) << baddir.output;
    const auto device = run("eval --method sampled --in " + in + " --out " + path("o.csv") + " --device no-such-device");
    EXPECT_EQ(device.exit_code, 2);  // a --device naming no device is bad input
    EXPECT_NE(device.output.find("no OpenCL device matches"), std::string::npos) << device.output;
    EXPECT_FALSE(fs::exists(path("o.csv")));
}

}  // namespace
