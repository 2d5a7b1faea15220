// A sweep's chunks are items of the shared item store. Folders written in the format before it
// (manifest format "microshadow-sweep-manifest/1" and "/2", chunks/chunk-*.csv) are still read: a
// merge assembles them to the bytes the old code wrote, a resume takes their sound chunks and computes
// the rest; `merge` and `sweep --merge` are one code path; a value less accurate than the tolerance
// asked is flagged (summary, sweep.json, exit status 3). tests/data/sweep-v2 was written by the
// code before the item store (its README says how).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "oracle/oracle.hpp"
#include "test_files.hpp"

namespace ms {
namespace {

namespace fs = std::filesystem;
using ms::testing::slurp_file;

const fs::path kOld = fs::path(MICROSHADOW_TEST_DATA) / "sweep-v2";

class SweepLegacy : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("microshadow_sweep_legacy_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        for (const char* folder : {"split", "part"}) fs::copy(kOld / folder, dir_ / folder, fs::copy_options::recursive);
        fs::copy(kOld / "s.toml", dir_ / "s.toml");
    }
    void TearDown() override { fs::remove_all(dir_); }
    // The run the fixture's command line made: the oracle, the exact method at 1e-6.
    sweep::RunConfig config(const fs::path& out) {
        sweep::RunConfig c;
        c.out_dir = out.string();
        c.plan.method = Method::exact;
        c.plan.tolerance = 1e-6;
        c.backend = backend_.get();
        return c;
    }
    sweep::Spec spec() const { return sweep::parse_spec_file((dir_ / "s.toml").string()); }
    // The old manifest of `folder` made this build's: its spec hash (which holds the version) set to ours.
    void adopt(const fs::path& manifest, const std::function<void(nlohmann::json&)>& change = {}) {
        nlohmann::json m = nlohmann::json::parse(slurp_file(manifest));
        m["spec_hash"] = sweep::sweep_cache_key(spec(), config(dir_)).hash();
        if (change) change(m);
        std::ofstream(manifest, std::ios::trunc) << m.dump(1);
    }
    fs::path dir_;
    std::unique_ptr<TermBackend> backend_ = make_oracle_backend(1);
};

TEST_F(SweepLegacy, AShardedOldFolderMergesToTheBytesTheOldCodeWrote) {
    // Two shards' old manifests in one folder: the merge upgrades it and assembles the old run's bytes.
    const sweep::MergeResult r = sweep::merge_shards({(dir_ / "split").string()}, (dir_ / "merged").string(), "test");
    EXPECT_EQ(slurp_file(dir_ / "merged" / "sweep.csv"), slurp_file(kOld / "whole-sweep.csv"));
    EXPECT_EQ(r.points, 8u);
    EXPECT_TRUE(r.tolerance.met());
    // Upgraded in place: the chunks are items of the store, the manifests the store's own.
    EXPECT_TRUE(fs::exists(dir_ / "split" / "items" / "item-0000000002.bin"));
    EXPECT_FALSE(fs::exists(dir_ / "split" / "chunks" / "chunk-0000000002.csv"));
    EXPECT_EQ(nlohmann::json::parse(slurp_file(dir_ / "split" / "manifest.shard-1-of-2.json")).at("job"), "sweep");
    // The command `merge` and `sweep --merge` take the same path: the same bytes again, from the upgraded folder.
    auto m = testing::cli("merge -q --out " + (dir_ / "again").string() + " " + (dir_ / "split").string());
    ASSERT_EQ(m.exit_code, 0) << m.output;
    EXPECT_EQ(slurp_file(dir_ / "again" / "sweep.csv"), slurp_file(kOld / "whole-sweep.csv"));
}

TEST_F(SweepLegacy, AnUnfinishedOldRunResumesWithItsChunks) {
    adopt(dir_ / "part" / "manifest.json");
    const sweep::RunResult r = sweep::run_sweep(spec(), config(dir_ / "part"));
    ASSERT_TRUE(r.assembled);
    EXPECT_EQ(r.skipped, 1u);
    EXPECT_EQ(r.computed, 2u);
    // Chunk 0 is the old run's rows as they were; chunks 1 and 2 are what this build computes.
    const sweep::RunResult fresh = sweep::run_sweep(spec(), config(dir_ / "fresh"));
    ASSERT_TRUE(fresh.assembled);
    const std::string computed = slurp_file(dir_ / "fresh" / "sweep.csv");
    std::size_t rest = 0;
    for (int line = 0; line < 4; ++line) rest = computed.find('\n', rest) + 1;  // the header and chunk 0's 3 rows
    const std::string header = computed.substr(0, computed.find('\n') + 1);
    EXPECT_EQ(slurp_file(dir_ / "part" / "sweep.csv"),
              header + slurp_file(kOld / "part" / "chunks" / "chunk-0000000000.csv") + computed.substr(rest));
    EXPECT_FALSE(fs::exists(dir_ / "part" / "manifest.json"));
}

TEST_F(SweepLegacy, AFormatOneChunkIsCheckedByItsRows) {
    // Format 1 recorded no digests: a removed row is still caught by the point indices, set aside and computed again.
    adopt(dir_ / "part" / "manifest.json", [](nlohmann::json& m) {
        m.erase("digests");
        m["format"] = "microshadow-sweep-manifest/1";
    });
    const fs::path chunk = dir_ / "part" / "chunks" / "chunk-0000000000.csv";
    const std::string rows = slurp_file(chunk);
    std::ofstream(chunk, std::ios::trunc) << rows.substr(rows.find('\n') + 1);
    std::vector<std::string> told;
    sweep::RunConfig c = config(dir_ / "part");
    c.warn = [&](const std::string& w) { told.push_back(w); };
    const sweep::RunResult r = sweep::run_sweep(spec(), c);
    ASSERT_EQ(told.size(), 1u);
    EXPECT_NE(told[0].find("index: expected point 0"), std::string::npos) << told[0];
    EXPECT_TRUE(fs::exists(dir_ / "part" / "chunks" / "rejected" / "chunk-0000000000.csv.index"));
    ASSERT_TRUE(r.assembled);
    EXPECT_EQ(r.computed, 3u);
    ASSERT_TRUE(sweep::run_sweep(spec(), config(dir_ / "fresh")).assembled);
    EXPECT_EQ(slurp_file(dir_ / "part" / "sweep.csv"), slurp_file(dir_ / "fresh" / "sweep.csv"));
}

TEST_F(SweepLegacy, AnOldFolderOfAnotherSweepIsRefusedAndLeftAsItWas) {
    // The fixture's spec hash is not this run's (another tolerance): refused, nothing moved.
    sweep::RunConfig other = config(dir_ / "part");
    other.plan.tolerance = 1e-8;
    try {
        sweep::run_sweep(spec(), other);
        ADD_FAILURE() << "resumed an old folder of another sweep";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("different sweep"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(fs::exists(dir_ / "part" / "manifest.json"));
    EXPECT_TRUE(fs::exists(dir_ / "part" / "chunks" / "chunk-0000000000.csv"));
    EXPECT_FALSE(fs::exists(dir_ / "part" / "items"));
}

TEST_F(SweepLegacy, SweepMergeIsMergeAndRefusesAnotherSweepsFolder) {
    // Shards into one folder, assembled by sweep --merge: the bytes of the unsharded run.
    const std::string sweep = "sweep " + (dir_ / "s.toml").string() + " -q --backend oracle --tolerance 1e-6";
    for (const char* shard : {"0/2", "1/2"}) {
        auto r = testing::cli(sweep + " --shard " + shard + " --out " + (dir_ / "shared").string());
        ASSERT_EQ(r.exit_code, 0) << r.output;
        EXPECT_NE(r.output.find("--merge --out"), std::string::npos) << r.output;
    }
    auto r = testing::cli(sweep + " --merge --out " + (dir_ / "shared").string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = testing::cli(sweep + " --out " + (dir_ / "whole").string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(slurp_file(dir_ / "shared" / "sweep.csv"), slurp_file(dir_ / "whole" / "sweep.csv"));
    // The spec names the sweep a --merge must find: another tolerance is another sweep (exit 2).
    r = testing::cli("sweep " + (dir_ / "s.toml").string() + " -q --backend oracle --tolerance 1e-7 --merge --out " +
                     (dir_ / "shared").string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("holds another sweep"), std::string::npos) << r.output;
    r = testing::cli(sweep + " --merge --shard 0/2 --out " + (dir_ / "shared").string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST(SweepTolerance, APointLessAccurateThanAskedIsFlaggedWithItsOwnExitStatus) {
    // The exact method's float kernel is limited by float rounding (~1e-5) whatever the tolerance: at
    // the default 1e-10 the sweep's values miss it. Before, exit 0 and no word.
    const fs::path dir = fs::temp_directory_path() / ("microshadow_sweep_tolerance_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "s.toml") << "[sweep]\nchunk_size = 4\n[parameters]\nvisibility = [0.3, 0.9]\nn_dot_l = [0.4, 0.8]\n"
                                     "roughness = [0.3, 0.6]\n";
    const std::string sweep = "sweep " + (dir / "s.toml").string() + " --exact-float --out " + (dir / "f").string();
    auto r = testing::cli(sweep);
    EXPECT_EQ(r.exit_code, 3) << r.output;
    EXPECT_NE(r.output.find("(TOLERANCE NOT MET: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("points is above the tolerance 1e-10"), std::string::npos) << r.output;
    ASSERT_TRUE(fs::exists(dir / "f" / "sweep.csv")) << "the values are written all the same";
    const auto provenance = nlohmann::json::parse(slurp_file(dir / "f" / "sweep.json"));
    EXPECT_EQ(provenance.at("tolerance_met"), false);
    EXPECT_GT(provenance.at("points_over_tolerance").get<int>(), 0);
    // Asked again (the finished sweep found), under --quiet, and merged: still flagged; allowed: exit 0.
    r = testing::cli(sweep + " -q");
    EXPECT_EQ(r.exit_code, 3) << r.output;
    EXPECT_NE(r.output.find("exit status 3 (--allow-tolerance-miss: 0)"), std::string::npos) << r.output;
    r = testing::cli("merge -q --out " + (dir / "m").string() + " " + (dir / "f").string());
    EXPECT_EQ(r.exit_code, 3) << r.output;
    r = testing::cli(sweep + " -q --allow-tolerance-miss");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    // The double evaluator meets it: exit 0, and the summary says so.
    r = testing::cli("sweep " + (dir / "s.toml").string() + " --out " + (dir / "d").string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("(tolerance 1e-10 met)"), std::string::npos) << r.output;
    EXPECT_EQ(nlohmann::json::parse(slurp_file(dir / "d" / "sweep.json")).at("tolerance_met"), true);
    // A sampled sweep asks no tolerance: nothing to flag.
    r = testing::cli("sweep " + (dir / "s.toml").string() + " -q --method sampled --samples 256 --out " + (dir / "s").string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_FALSE(nlohmann::json::parse(slurp_file(dir / "s" / "sweep.json")).contains("tolerance_met"));
    fs::remove_all(dir);
}

}  // namespace
}  // namespace ms
