// Hostile input through the real CLI: the hand-made corpus in tests/data/hostile (bad CSV query files,
// bad sweep specs) and bad command lines. Each must end with a clear message naming the problem and a
// non-zero exit, within a time limit and a memory limit, without a crash and without leaving an
// output (or a temporary file) behind. The valid-but-odd files (tests/data/hostile/valid) must work.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include "cli_runner.hpp"
#include "io/csv.hpp"
#include "sanitizers.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

using ms::testing::kAsan;

// Runs the CLI under `timeout` (a hang is a failure, exit 124) and, outside ASan (which reserves
// terabytes of address space), a 2 GiB address-space limit: an input that makes the program allocate
// without bound fails with bad_alloc (exit 1, "std::bad_alloc" in the message) instead of thrashing.
RunResult run_cli(const std::string& args, const std::string& env = "") {
    std::string cmd = "cd " + fs::temp_directory_path().string() + " && ";
    if (!kAsan) cmd += "ulimit -v 2097152 && ";
    cmd += env + " timeout 120 " + std::string(MICROSHADOW_CLI) + " " + args + " 2>&1 </dev/null";
    return run_shell(cmd);
}

const fs::path kCorpus = fs::path(MICROSHADOW_TEST_DATA) / "hostile";

class HostileInput : public ScratchDirTest {
protected:
    HostileInput() : ScratchDirTest("hostile") {}
    // Nothing but what the test put there: no output, no temporary file.
    void expect_dir_empty(const std::string& context) const {
        for (const auto& e : fs::directory_iterator(dir_)) ADD_FAILURE() << context << ": left behind " << e.path();
    }
};

// A clean failure: non-zero exit (not a signal, not the timeout), one "error" line naming the input,
// no sign of a crash or a sanitizer report.
void expect_clean_failure(const RunResult& r, const std::string& must_contain, const std::string& context) {
    EXPECT_NE(r.exit_code, 0) << context << "\n" << r.output;
    EXPECT_NE(r.exit_code, -1) << context << ": killed by a signal\n" << r.output;
    EXPECT_NE(r.exit_code, 124) << context << ": hung (timeout)\n" << r.output;
    EXPECT_NE(r.output.find(must_contain), std::string::npos) << context << ": expected '" << must_contain << "' in\n" << r.output;
    for (const char* bad : {"terminate called", "Sanitizer", "runtime error", "Segmentation", "Aborted", "bad_alloc", "core dumped"})
        EXPECT_EQ(r.output.find(bad), std::string::npos) << context << ": '" << bad << "' in\n" << r.output;
}

TEST_F(HostileInput, BadQueryFilesFailCleanly) {
    // Each file with the words its message must contain (the reader names file, line and column).
    const std::map<std::string, std::string> expected = {
        {"empty.csv", "empty file"},
        {"blank_lines.csv", "empty file"},
        {"truncated_header.csv", "unknown column 'alp'"},
        {"truncated_row.csv", "truncated_row.csv:2: 8 fields, but the header has 9"},
        {"binary.csv", "binary data"},
        {"nul_in_row.csv", "nul_in_row.csv:2: binary data"},
        {"utf16.csv", "binary data"},
        {"huge_number.csv", "'1e999' is out of the range of a double"},
        {"huge_negative.csv", "'-1e400' is out of the range of a double"},
        {"huge_direction.csv", "columns 'wi_x,wi_y,wi_z': zero-length or overflowing direction"},
        {"nan_lower.csv", "'nan' is not a finite number"},
        {"nan_mixed.csv", "'NaN' is not a finite number"},
        {"nan_negative.csv", "'-nan' is not a finite number"},
        {"nan_payload.csv", "'nan(0x7ff)' is not a finite number"},
        {"nan_upper.csv", "'NAN' is not a finite number"},
        {"nan_excel.csv", "'#N/A' is not a number"},
        {"nan_msvc.csv", "'1.#QNAN' is not a number"},
        {"inf.csv", "'inf' is not a finite number"},
        {"infinity.csv", "'Infinity' is not a finite number"},
        {"negative_inf.csv", "'-inf' is not a finite number"},
        {"hex_float.csv", "'0x1p-3' is not a number"},
        {"not_a_number.csv", "'abc' is not a number"},
        {"two_dots.csv", "'0.5.5' is not a number"},
        {"dangling_exponent.csv", "'1e' is not a number"},
        {"empty_field.csv", "column 'wo_y': empty field"},
        {"extra_field.csv", "10 fields, but the header has 9"},
        {"missing_field.csv", "8 fields, but the header has 9"},
        {"missing_column.csv", "missing column 'wo_z'"},
        {"duplicate_column.csv", "duplicate column 'visibility'"},
        {"unknown_column.csv", "unknown column 'roughness'"},
        {"empty_column_name.csv", "empty column name"},
        {"header_only_wrong.csv", "unknown column 'a'"},
        {"visibility_negative.csv", "column 'visibility': -0.1 is outside [0, 1]"},
        {"visibility_above_one.csv", "column 'visibility': 1.0000001 is outside [0, 1]"},
        {"alpha_zero.csv", "column 'alpha_x': 0 must be > 0"},
        {"alpha_negative.csv", "column 'alpha_y': -0.2 must be > 0"},
        {"alpha_negative_zero.csv", "column 'alpha_x': -0 must be > 0"},
        {"wi_at_horizon.csv", "above the horizon"},
        {"wi_below_horizon.csv", "above the horizon"},
        {"wi_denormal_horizon.csv", "above the horizon"},
        {"wi_zero.csv", "zero-length"},
        {"wo_zero.csv", "zero-length"},
        {"good_then_bad.csv", "good_then_bad.csv:4: column 'alpha_x': 'oops' is not a number"},
    };
    // Every corpus file has an expectation, so a file added without one fails here.
    std::size_t files = 0;
    for (const auto& e : fs::directory_iterator(kCorpus))
        if (e.is_regular_file() && e.path().extension() == ".csv") {
            ++files;
            EXPECT_TRUE(expected.count(e.path().filename().string())) << "no expectation for " << e.path();
        }
    EXPECT_EQ(files, expected.size());
    for (const auto& [name, message] : expected) {
        const fs::path out = dir_ / "out.csv";
        // The oracle backend: no device start-up per file (the reader runs before any backend anyway).
        const auto r = run_cli("eval --method sampled --in " + (kCorpus / name).string() + " --out " + out.string() + " --backend oracle -q");
        EXPECT_EQ(r.exit_code, 2) << name << ": bad input is exit code 2\n" << r.output;
        expect_clean_failure(r, message, name);
        EXPECT_NE(r.output.find(name), std::string::npos) << name << ": the message must name the file\n" << r.output;
        expect_dir_empty(name);
    }
}

TEST_F(HostileInput, OddButValidQueryFilesWork) {
    // Denormals, directions whose squared length under- or overflows (1e-200, 1e200), a leading '+', CRLF, a UTF-8 byte-order mark, reordered columns, unnormalised directions, 5000-digit numbers,
    // a header without rows, and the extreme values of the stress suite: all valid input.
    std::vector<std::string> columns = ms::kQueryColumns;
    columns.push_back("term");
    columns.push_back("std_error");
    for (const auto& e : fs::directory_iterator(kCorpus / "valid")) {
        const std::string name = e.path().filename().string();
        const auto rows_in = ms::read_query_csv(e.path().string()).size();
        for (const std::string backend : {"opencl", "oracle"}) {
            const fs::path out = dir_ / (name + "." + backend + ".csv");
            const auto r = run_cli("eval --method sampled --in " + e.path().string() + " --out " + out.string() + " --backend " + backend +
                                   " --samples 4096 -q");
            ASSERT_EQ(r.exit_code, 0) << name << " " << backend << "\n" << r.output;
            const auto table = ms::read_numeric_csv(out.string(), columns);  // rejects NaN and infinity itself
            ASSERT_EQ(table.rows.size(), rows_in) << name;
            for (const auto& row : table.rows) {
                EXPECT_GE(row[9], 0.0) << name << " " << backend;
                EXPECT_LE(row[9], 1.0) << name << " " << backend;
            }
        }
    }
}

TEST_F(HostileInput, BadSweepSpecsFailCleanly) {
    const std::map<std::string, std::string> expected = {
        {"empty.toml", "[parameters] table is required"},
        {"syntax_error.toml", "syntax_error.toml:1:12: TOML syntax"},
        {"binary.toml", "TOML syntax"},
        {"truncated.toml", "TOML syntax"},
        {"duplicate_key.toml", "cannot redefine"},
        {"unknown_key.toml", "parameters.colour: unknown key"},
        {"missing_visibility.toml", "parameters.visibility: required"},
        {"wrong_type_string.toml", "parameters.visibility: must be a number"},
        {"wrong_type_bool.toml", "parameters.visibility[0]: must be a number"},
        {"wrong_type_table.toml", "parameters.visibility.from: unknown key"},
        {"wrong_type_samples.toml", "sampling.samples: must be an integer"},
        {"wrong_type_form.toml", "parameters.form[0]: must be a string"},
        {"unknown_form.toml", "unknown form 'correlated-ish'"},
        {"negative_count.toml", "parameters.visibility.count: must be positive"},
        {"zero_count.toml", "parameters.visibility.count: must be positive"},
        {"zero_length_range.toml", "zero-length range"},
        {"log_range_zero.toml", "a log range needs start > 0"},
        {"negative_samples.toml", "sampling.samples: must be positive"},
        {"negative_replicates.toml", "sampling.replicates: must be positive"},
        {"negative_chunk.toml", "sweep.chunk_size: must be positive"},
        {"zero_chunk.toml", "sweep.chunk_size: must be positive"},
        {"huge_integer.toml", "not representable in 64 bits"},
        {"absurd_axis.toml", "more than the limit"},
        {"absurd_max_points.toml", "sweep.max_points: too large"},
        {"nan_value.toml", "parameters.visibility[0]: must be a finite number"},
        {"inf_value.toml", "parameters.n_dot_l[0]: must be a finite number"},
        {"nan_range.toml", "parameters.visibility.stop: must be a finite number"},
        {"out_of_range_visibility.toml", "value 1.5 outside [0, 1]"},
        {"n_dot_v_zero.toml", "above the horizon"},
        {"roughness_and_alpha.toml", "not both"},
        {"negative_roughness.toml", "value -0.5 outside"},
        {"empty_list.toml", "the list is empty"},
        {"deep_nesting.toml", "maximum nested value depth"},
        {"missing_lut.toml", "does-not-exist.exr"},
    };
    std::size_t files = 0;
    for (const auto& e : fs::directory_iterator(kCorpus / "spec")) {
        ++files;
        EXPECT_TRUE(expected.count(e.path().filename().string())) << "no expectation for " << e.path();
    }
    EXPECT_EQ(files, expected.size());
    for (const auto& [name, message] : expected) {
        const fs::path out = dir_ / "sweep.out";
        const auto r = run_cli("sweep " + (kCorpus / "spec" / name).string() + " --out " + out.string() +
                               " --backend oracle --samples 64 -q");
        expect_clean_failure(r, message, name);
        expect_dir_empty(name);
    }
}

TEST_F(HostileInput, BadCommandLinesFailCleanly) {
    const std::string q = (fs::path(MICROSHADOW_SOURCE_DIR) / "examples" / "queries.csv").string();
    const std::string out = (dir_ / "o").string();
    struct Case {
        std::string args, message;
        int exit_code;
    };
    const std::vector<Case> cases = {
        {"", "a command is required", 2},
        {"frobnicate", "'frobnicate' is not a command", 2},
        {"eval", "--in is required", 2},
        {"eval --method sampled --in " + q, "--out is required", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --samples 0", "--samples: Value 0 not in range", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --samples -5", "--samples", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --samples 1e20", "--samples", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --samples 18446744073709551617", "--samples", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --replicates 1", "--replicates", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --replicates 100000", "--replicates", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --form bogus", "--form", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --backend cuda", "--backend", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --unknown-flag", "--unknown-flag", 2},
        {"eval --method sampled --in /nonexistent-microshadow.csv --out " + out + ".csv", "cannot open for reading", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --device 999", "no OpenCL device 999; the devices are", 2},
        {"eval --method sampled --in " + q + " --out " + out + ".csv --device nosuchdevice", "no OpenCL device matches 'nosuchdevice'", 2},
        // A bad destination is bad input (exit 2), refused before any work.
        {"eval --method sampled --in " + q + " --out /nonexistent-microshadow/dir/o.csv", "does not exist", 2},
        {"eval --method sampled --in " + q + " --out " + dir_.string(), "it is a directory", 2},
        // Absurd sizes: a 10^6-texel axis is refused before anything is allocated.
        {"bake --out " + out + ".exr --size 1000000", "--size: Value 1000000 not in range 1 to 4096", 2},
        {"bake --out " + out + ".exr --size-visibility 1000000", "--size-visibility", 2},
        {"bake --out " + out + ".exr --size 0", "--size", 2},
        {"bake --out " + out + ".exr --layout custom --roughness -1", "roughness must be in (0, 1]", 2},
        {"bake --out " + out + ".exr --layout custom --roughness 0.5 --visibility-range 0.5,0.5", "range is empty", 2},
        {"bake --out " + out + ".exr --layout custom --roughness 0.5 --visibility-range nan,1", "visibility range", 2},
        {"bake --out " + out + ".exr --azimuth abc", "--azimuth must be", 2},
        {"bake --out " + out + ".exr --azimuth nan", "azimuth must be", 2},
        {"bake --out " + out + ".exr --tolerance nan", "tolerance", 2},
        {"bake --out /nonexistent-microshadow/l.exr --size 2", "does not exist", 2},
        {"sweep /nonexistent-microshadow.toml", "File does not exist", 2},
    };
    for (const auto& c : cases) {
        const auto r = run_cli(c.args);
        EXPECT_EQ(r.exit_code, c.exit_code) << c.args << "\n" << r.output;
        expect_clean_failure(r, c.message, c.args);
        for (const auto& e : fs::directory_iterator(dir_)) ADD_FAILURE() << c.args << ": left behind " << e.path();
    }
}

}  // namespace
