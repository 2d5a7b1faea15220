// The chunk store every resumable job keeps its items in (schedule/chunk_store.hpp): the three seals,
// grouped syncs, temporaries a killed writer left, and the sequential item runner (run_item_job) that
// representation bakes and design reference sets split, resume and merge through.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>

#include "cli_runner.hpp"
#include "schedule/chunk_store.hpp"
#include "schedule/distributed.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;
using ms::testing::ScratchDirTest;

class ChunkStore : public ScratchDirTest {
protected:
    ChunkStore() : ScratchDirTest("chunk_store") {}
    std::string slurp(const std::string& p) {
        std::ifstream in(p, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), {}};
    }
};

TEST_F(ChunkStore, EachSealReadsBackWhatWasWrittenAndSetsAsideWhatChanged) {
    const std::string rows = "1,a\n2,b\n";
    for (const schedule::ItemSeal seal : {schedule::ItemSeal::header, schedule::ItemSeal::trailer, schedule::ItemSeal::recorded}) {
        schedule::ChunkLayout layout;
        layout.folder = path("seal" + std::to_string(int(seal)));
        layout.prefix = "chunk-";
        layout.suffix = ".csv";
        layout.digits = 6;
        layout.seal = seal;
        layout.spec_hash = "0123456789abcdef";
        schedule::ChunkFiles files(layout);
        const schedule::ItemDigest d = files.write(3, rows);
        EXPECT_EQ(d.rows, 2u);
        ASSERT_TRUE(fs::exists(layout.folder + "/chunk-000003.csv"));
        EXPECT_EQ(files.read(3).value(), rows);
        EXPECT_FALSE(files.read(4));
        // The trailer seal keeps the file a CSV with the digest line last, as reference-set chunks were.
        if (seal == schedule::ItemSeal::trailer) EXPECT_EQ(slurp(files.path(3)), rows + "# " + schedule::digest_text(d) + "\n");
        if (seal == schedule::ItemSeal::recorded) EXPECT_EQ(slurp(files.path(3)), rows);
        // One byte changed: the header and trailer seals notice it themselves, the recorded one through
        // the job's check (a sweep compares its manifest's digest there).
        {
            std::string text = slurp(files.path(3));
            text[text.find("2,b") + 2] = 'c';  // a payload byte (the header's spec hash holds a 'b' too)
            std::ofstream(files.path(3), std::ios::binary) << text;
        }
        std::string warning;
        const auto check = [&](const std::string& payload) {
            return schedule::digest_of(payload) == d ? std::string() : std::string("digest: not the recorded digest");
        };
        EXPECT_FALSE(files.read(3, &warning, check)) << int(seal);
        EXPECT_NE(warning.find("digest"), std::string::npos) << warning;
        EXPECT_TRUE(fs::exists(layout.folder + "/rejected/chunk-000003.csv.digest")) << warning;
        EXPECT_FALSE(fs::exists(files.path(3)));
    }
}

TEST_F(ChunkStore, WritesAreSyncedInGroupsAndOnCommit) {
    schedule::ChunkLayout layout;
    layout.folder = path("items");
    schedule::CommitPolicy policy;
    policy.items = 4;
    policy.interval = std::chrono::hours(1);
    schedule::ChunkFiles files(layout, policy);
    bool committed = true;
    for (std::uint64_t id = 0; id < 3; ++id) {
        files.write(id, "x");
        EXPECT_EQ(files.pending(), id + 1);
    }
    files.write(3, "x", &committed);
    EXPECT_TRUE(committed) << "the fourth item completes a group";
    EXPECT_EQ(files.pending(), 0u);
    files.write(4, "x", &committed);
    EXPECT_FALSE(committed);
    EXPECT_EQ(files.pending(), 1u);
    files.commit();
    EXPECT_EQ(files.pending(), 0u);
    // Each item is in place as soon as write() returns, synced or not: a killed process loses none.
    for (std::uint64_t id = 0; id < 5; ++id) EXPECT_EQ(files.read(id).value(), "x");
    // Not automatic: only commit_if_due() syncs, when the group is full.
    policy.automatic = false;
    schedule::ChunkFiles manual(layout, policy);
    for (std::uint64_t id = 10; id < 14; ++id) manual.write(id, "y", &committed);
    EXPECT_FALSE(committed);
    EXPECT_EQ(manual.pending(), 4u);
    EXPECT_TRUE(manual.commit_if_due());
    EXPECT_EQ(manual.pending(), 0u);
}

TEST_F(ChunkStore, TemporariesOfAKilledWriterAreRemovedAndALiveOnesKept) {
    fs::create_directories(path("items"));
    char host[256] = {};
    ASSERT_EQ(gethostname(host, sizeof host - 1), 0);
    std::string name(host);
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '.') c = '_';
    // A process id that cannot be running (above the kernel's limit), and this process's own.
    const std::string dead = path("items/.item-0000000001.bin.tmp." + name + ".999999999");
    const std::string live = path("items/.item-0000000002.bin.tmp." + name + "." + std::to_string(getppid()));
    std::ofstream(dead) << "half";
    std::ofstream(live) << "half";
    schedule::ChunkLayout layout;
    layout.folder = path("items");
    schedule::ChunkFiles files(layout);
    files.write(5, "whole");
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(live));
}

// A job of 7 items whose payload is its id's square: split, resumed and merged through run_item_job.
struct SquaresJob {
    std::map<std::uint64_t, std::string> got;
    std::uint64_t computed = 0;
    schedule::ItemJob job() {
        schedule::ItemJob j;
        j.name = "squares";
        j.items = 7;
        j.compute = [this](std::uint64_t id) {
            ++computed;
            return std::to_string(id * id);
        };
        j.accept = [this](std::uint64_t id, const std::string& payload) { got[id] = payload; };
        j.check = [](std::uint64_t id, const std::string& payload) {
            return payload == std::to_string(id * id) ? std::string() : std::string("payload: not the square");
        };
        return j;
    }
};

TEST_F(ChunkStore, ItemJobShardsResumeAndMergeToEveryItem) {
    const schedule::StoreKey key{"squares", "00000000000000aa", 7};
    for (std::uint32_t i = 0; i < 2; ++i) {
        schedule::ItemStore store(path("store"), key, {i, 2});
        schedule::ItemPlan plan;
        plan.store = &store;
        plan.shard = {i, 2};
        SquaresJob s;
        const auto report = schedule::run_item_job(s.job(), plan, {"here"});
        EXPECT_FALSE(report.complete);
        EXPECT_EQ(s.computed, i == 0 ? 4u : 3u);
    }
    // Shard 0 again: everything is found, nothing computed.
    {
        schedule::ItemStore store(path("store"), key, {0, 2});
        schedule::ItemPlan plan;
        plan.store = &store;
        plan.shard = {0, 2};
        SquaresJob s;
        const auto report = schedule::run_item_job(s.job(), plan, {"here"});
        EXPECT_EQ(s.computed, 0u);
        EXPECT_EQ(report.loaded, 4u);
    }
    // A changed item is set aside and the merge names its shard.
    std::ofstream(path("store/items/item-0000000003.bin"), std::ios::app) << "x";
    const schedule::ItemStore merged = schedule::ItemStore::open_for_merge(path("store"), key);
    schedule::ItemPlan plan;
    plan.store = &merged;
    plan.merge_only = true;
    std::vector<std::string> warnings;
    plan.warn = [&](const std::string& w) { warnings.push_back(w); };
    SquaresJob s;
    try {
        schedule::run_item_job(s.job(), plan, {});
        ADD_FAILURE() << "merged with an item missing";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("shard 1/2 lacks 1 item(s) (the first is 3)"), std::string::npos) << e.what();
    }
    EXPECT_EQ(warnings.size(), 1u);
    // Shard 1 resumes (computing only item 3), then the merge has every item.
    {
        schedule::ItemStore store(path("store"), key, {1, 2});
        schedule::ItemPlan p;
        p.store = &store;
        p.shard = {1, 2};
        SquaresJob again;
        schedule::run_item_job(again.job(), p, {"here"});
        EXPECT_EQ(again.computed, 1u);
    }
    SquaresJob all;
    const auto report = schedule::run_item_job(all.job(), plan, {});
    EXPECT_TRUE(report.complete);
    ASSERT_EQ(all.got.size(), 7u);
    for (std::uint64_t id = 0; id < 7; ++id) EXPECT_EQ(all.got[id], std::to_string(id * id));
    EXPECT_EQ(all.computed, 0u);
}

TEST_F(ChunkStore, DistributionRefusesWhatCannotBeCombined) {
    const schedule::StoreKey key{"squares", "00000000000000aa", 7};
    schedule::DistributionRequest merge_and_shard;
    merge_and_shard.merge = true;
    merge_and_shard.shard_given = true;
    EXPECT_THROW(schedule::Distribution(merge_and_shard, key, path("d")), std::invalid_argument);
    schedule::DistributionRequest merge_nothing;
    merge_nothing.merge = true;
    EXPECT_THROW(schedule::Distribution(merge_nothing, key, path("d")), std::invalid_argument);
    EXPECT_FALSE(fs::exists(path("d")));
    // One process without --store keeps nothing; a shard keeps its items in the default store.
    const schedule::Distribution alone(schedule::DistributionRequest{}, key, path("d"));
    EXPECT_EQ(alone.store(), nullptr);
    EXPECT_TRUE(alone.writer());
    schedule::DistributionRequest shard;
    shard.shard = {1, 3};
    const schedule::Distribution one_of_three(shard, key, path("d"));
    ASSERT_NE(one_of_three.store(), nullptr);
    EXPECT_EQ(one_of_three.store()->dir(), path("d"));
    EXPECT_FALSE(one_of_three.writer());
}

}  // namespace
