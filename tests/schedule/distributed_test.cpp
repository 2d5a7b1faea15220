// Work items beyond one process: shards (--shard I/N and Slurm array tasks), the chunk store of finished
// items, resume, the merge, and the scheduler's pull source that MPI ranks use. A bake split any way must
// give the unsplit bake's texels bit for bit and the same metadata.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <set>
#include <utility>

#include "cli_runner.hpp"
#include "integrands/lut_slice/lut_slice_integrand.hpp"
#include "jobs/bake.hpp"
#include "lut/exr_lut.hpp"
#include "repr/representation.hpp"
#include "repr/texture_repr.hpp"
#include "jobs/scene.hpp"
#include "scene/image_io.hpp"
#include "schedule/distributed.hpp"
#include "schedule/item_bytes.hpp"
#include "test_files.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

class Distributed : public ScratchDirTest {
protected:
    Distributed() : ScratchDirTest("distributed") {}
};

// A small sampled bake: 2 roughness channels x 3 NdotV = 6 slices of 5 x 4 texels.
BakeSpec small_bake() {
    BakeSpec s = default_bake_spec(LutLayout::custom, 4);
    s.visibility.count = 5;
    s.n_dot_l.count = 4;
    s.n_dot_v.count = 3;
    s.roughness = {0.3, 0.8};
    s.samples = 1024;
    s.seed = 7;
    s.backend.kind = schedule::Backend::Kind::oracle;
    s.backend.threads = 1;
    return s;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(Shards, ParseAndSlurmArrayVariables) {
    EXPECT_EQ(schedule::parse_shard("2/5").index, 2u);
    EXPECT_EQ(schedule::parse_shard("2/5").count, 5u);
    for (const char* bad : {"5/5", "1", "/3", "1/", "-1/3", "1/0", "a/3", "1/3x", "1 /3", "99999999/100000000"})
        EXPECT_THROW(schedule::parse_shard(bad), std::invalid_argument) << bad;

    std::map<std::string, std::string> env;
    auto lookup = [&](const char* name) -> const char* {
        const auto it = env.find(name);
        return it == env.end() ? nullptr : it->second.c_str();
    };
    EXPECT_FALSE(schedule::slurm_array_shard(lookup));  // not in an array
    env = {{"SLURM_ARRAY_TASK_ID", "2"}, {"SLURM_ARRAY_TASK_COUNT", "4"}, {"SLURM_ARRAY_TASK_MIN", "0"}, {"SLURM_ARRAY_TASK_MAX", "3"}};
    EXPECT_EQ(schedule::slurm_array_shard(lookup)->index, 2u);
    EXPECT_EQ(schedule::slurm_array_shard(lookup)->count, 4u);
    // --array=1-4 and --array=10-16:2 are shards too: the task's place in the array.
    env = {{"SLURM_ARRAY_TASK_ID", "1"}, {"SLURM_ARRAY_TASK_COUNT", "4"}, {"SLURM_ARRAY_TASK_MIN", "1"}, {"SLURM_ARRAY_TASK_MAX", "4"}};
    EXPECT_EQ(schedule::slurm_array_shard(lookup)->index, 0u);
    env = {{"SLURM_ARRAY_TASK_ID", "14"}, {"SLURM_ARRAY_TASK_COUNT", "4"}, {"SLURM_ARRAY_TASK_MIN", "10"},
           {"SLURM_ARRAY_TASK_MAX", "16"}, {"SLURM_ARRAY_TASK_STEP", "2"}};
    EXPECT_EQ(schedule::slurm_array_shard(lookup)->index, 2u);
    // --array=0,3,7 (count 3, max 7) has no I/N; neither has an ID without a COUNT or a non-number.
    env = {{"SLURM_ARRAY_TASK_ID", "3"}, {"SLURM_ARRAY_TASK_COUNT", "3"}, {"SLURM_ARRAY_TASK_MIN", "0"}, {"SLURM_ARRAY_TASK_MAX", "7"}};
    EXPECT_THROW(schedule::slurm_array_shard(lookup), std::invalid_argument);
    env = {{"SLURM_ARRAY_TASK_ID", "1"}, {"SLURM_ARRAY_TASK_COUNT", "2"}};  // no _MIN/_MAX: ids from 0
    EXPECT_EQ(schedule::slurm_array_shard(lookup)->index, 1u);
    env = {{"SLURM_ARRAY_TASK_ID", "2"}, {"SLURM_ARRAY_TASK_COUNT", "2"}};
    EXPECT_THROW(schedule::slurm_array_shard(lookup), std::invalid_argument);
    env = {{"SLURM_ARRAY_TASK_ID", "3"}};
    EXPECT_THROW(schedule::slurm_array_shard(lookup), std::invalid_argument);
    env = {{"SLURM_ARRAY_TASK_ID", "x"}, {"SLURM_ARRAY_TASK_COUNT", "3"}};
    EXPECT_THROW(schedule::slurm_array_shard(lookup), std::invalid_argument);
}

TEST_F(Distributed, StoreKeepsItemsAndRefusesAnotherJobOrSplit) {
    const std::string dir = path("store");
    const schedule::StoreKey key{"bake", "0123456789abcdef", 6};
    schedule::ItemStore store(dir, key, {1, 3});
    const std::string payload("\0\1\2binary\xff", 10);
    store.save(4, payload);
    EXPECT_EQ(store.load(4).value(), payload);
    EXPECT_FALSE(store.load(1));
    store.write_manifest(false, {"dev"}, 0);
    // Another shard count, spec, version-less key or job in the same folder is bad input.
    EXPECT_THROW(schedule::ItemStore(dir, key, {0, 2}), std::invalid_argument);
    EXPECT_THROW(schedule::ItemStore(dir, {"bake", "fedcba9876543210", 6}, {0, 3}), std::invalid_argument);
    EXPECT_THROW(schedule::ItemStore(dir, {"sweep", key.spec_hash, 6}, {0, 3}), std::invalid_argument);
    EXPECT_NO_THROW(schedule::ItemStore(dir, key, {2, 3}));
    // The same job and spec with another item count: the spec fixes the count, so the manifest is damaged.
    // It is set aside with a warning (the shard's next run writes it again), not refused on every resume.
    std::string aside;
    EXPECT_NO_THROW(schedule::ItemStore(dir, {"bake", key.spec_hash, 7}, {0, 3}, {}, {}, [&](const std::string& w) { aside = w; }));
    EXPECT_NE(aside.find("items: the manifest says 6 items where this job's spec has 7"), std::string::npos) << aside;
    EXPECT_TRUE(fs::exists(dir + "/items/rejected/manifest.shard-1-of-3.json.items"));
    // A damaged item (one byte flipped) is set aside with a warning, never returned.
    {
        const std::string file = dir + "/items/item-0000000004.bin";
        std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(-1, std::ios::end);
        f.put('X');
    }
    std::string warning;
    EXPECT_FALSE(store.load(4, &warning));
    EXPECT_NE(warning.find("digest"), std::string::npos) << warning;
    EXPECT_TRUE(fs::exists(dir + "/items/rejected/item-0000000004.bin.digest"));
    // An empty folder cannot be merged.
    fs::create_directories(path("empty"));
    EXPECT_THROW(schedule::ItemStore::open_for_merge(path("empty"), key), std::invalid_argument);
}

TEST(ItemBytes, RoundTripAndShortInput) {
    schedule::ItemWriter w;
    w.put(std::uint32_t(7));
    w.put_vector(std::vector<float>{1.5f, -0.0f, 3e-40f});
    const std::string bytes = w.take();
    schedule::ItemReader r(bytes, "item");
    EXPECT_EQ(r.get<std::uint32_t>(), 7u);
    const std::vector<float> v = r.get_vector<float>(3);
    EXPECT_TRUE(same_bits(v, {1.5f, -0.0f, 3e-40f}));
    EXPECT_NO_THROW(r.finish());
    const std::string short_bytes = bytes.substr(0, bytes.size() - 1);
    schedule::ItemReader cut(short_bytes, "item");
    cut.get<std::uint32_t>();
    EXPECT_THROW(cut.get_vector<float>(3), std::runtime_error);
    schedule::ItemReader wrong(bytes, "item");
    wrong.get<std::uint32_t>();
    EXPECT_THROW(wrong.get_vector<float>(4), std::runtime_error);
}

// Shards into one store, a resumed shard, a merge: the unsplit bake's texels and metadata.
TEST_F(Distributed, ShardedBakeMergesToTheUnsplitBake) {
    for (const Method method : {Method::sampled, Method::exact}) {
        SCOPED_TRACE(to_string(method));
        BakeSpec spec = small_bake();
        spec.method = method;
        if (method == Method::exact) spec.tolerance = 1e-4;
        schedule::Scheduler scheduler(spec.backend);
        const BakeResult whole = bake_lut(spec, scheduler);
        const std::string dir = path(std::string("store-") + to_string(method));
        const schedule::StoreKey key = bake_store_key(spec, scheduler);
        EXPECT_EQ(key.items, 6u);
        for (std::uint32_t i = 0; i < 3; ++i) {
            schedule::ItemStore store(dir, key, {i, 3});
            schedule::ItemPlan plan;
            plan.store = &store;
            plan.shard = {i, 3};
            const BakeResult part = bake_lut(spec, scheduler, {}, plan);
            EXPECT_FALSE(part.complete);
            EXPECT_EQ(part.computed_slices, 2u);
            if (i == 1) {
                // A merge before shard 2 ran names it, and writes nothing.
                schedule::ItemStore partial = schedule::ItemStore::open_for_merge(dir, key);
                schedule::ItemPlan merge;
                merge.store = &partial;
                merge.merge_only = true;
                try {
                    bake_lut(spec, scheduler, {}, merge);
                    ADD_FAILURE() << "merged with a shard missing";
                } catch (const std::invalid_argument& e) {
                    EXPECT_NE(std::string(e.what()).find("shard 2/3"), std::string::npos) << e.what();
                }
            }
        }
        // Rerunning a finished shard computes nothing: its slices come from the store.
        {
            schedule::ItemStore store(dir, key, {1, 3});
            schedule::ItemPlan plan;
            plan.store = &store;
            plan.shard = {1, 3};
            const BakeResult again = bake_lut(spec, scheduler, {}, plan);
            EXPECT_EQ(again.computed_slices, 0u);
            EXPECT_EQ(again.loaded_slices, 2u);
        }
        schedule::ItemStore store = schedule::ItemStore::open_for_merge(dir, key);
        schedule::ItemPlan merge;
        merge.store = &store;
        merge.merge_only = true;
        const BakeResult merged = bake_lut(spec, scheduler, {}, merge);
        ASSERT_TRUE(merged.complete);
        EXPECT_TRUE(same_bits(whole.value, merged.value));
        EXPECT_TRUE(same_bits(whole.std_error, merged.std_error));
        EXPECT_EQ(bake_metadata(spec, whole).dump(), bake_metadata(spec, merged).dump());
        // Another seed is another bake: its key differs, so the store refuses it.
        BakeSpec other = spec;
        other.seed = 8;
        other.tolerance = method == Method::exact ? 2e-4 : 0;
        EXPECT_NE(bake_store_key(other, scheduler).spec_hash, key.spec_hash);
    }
}

// An interrupted unsplit bake with a store resumes: the finished slices are read back, the rest computed.
TEST_F(Distributed, StoreResumesAnInterruptedBake) {
    const BakeSpec spec = small_bake();
    schedule::Scheduler scheduler(spec.backend);
    const BakeResult whole = bake_lut(spec, scheduler);
    const schedule::StoreKey key = bake_store_key(spec, scheduler);
    const std::string dir = path("store");
    {
        // As if killed after slices 0, 2 and 5: only they are in the store.
        schedule::ItemStore store(dir, key, {0, 1});
        for (std::uint64_t id : {0, 2, 5}) {
            // Slice id alone (the shard id/6 of six), saved as the bake's integrand saves it.
            lut_slice::LutSliceIntegrand one(spec);
            schedule::WorkSelection only;
            only.shard_index = id;
            only.shard_count = 6;
            scheduler.run(one, only);
            store.save(id, one.save_item(id));
        }
    }
    schedule::ItemStore store(dir, key, {0, 1});
    schedule::ItemPlan plan;
    plan.store = &store;
    const BakeResult resumed = bake_lut(spec, scheduler, {}, plan);
    EXPECT_TRUE(resumed.complete);
    EXPECT_EQ(resumed.loaded_slices, 3u);
    EXPECT_EQ(resumed.computed_slices, 3u);
    EXPECT_TRUE(same_bits(whole.value, resumed.value));
    EXPECT_EQ(bake_metadata(spec, whole).dump(), bake_metadata(spec, resumed).dump());
}

// The pull source MPI ranks use: items in any order and interleaving give the same texels.
TEST(SchedulerPull, ItemsFromASourceGiveTheSameTexels) {
    const BakeSpec spec = small_bake();
    schedule::Scheduler scheduler(schedule::Backend::oracle(2));
    const BakeResult whole = bake_lut(spec, scheduler);
    lut_slice::LutSliceIntegrand pulled(spec);
    std::vector<std::uint64_t> order{5, 1, 3, 0, 4, 2};
    std::size_t next = 0;
    schedule::WorkSelection source;
    source.next_item = [&](std::uint64_t& id) {
        if (next == order.size()) return false;
        id = order[next++];
        return true;
    };
    std::set<std::uint64_t> done;
    schedule::RunCallbacks cb;
    cb.on_done = [&](std::uint64_t id) { done.insert(id); };
    const schedule::RunReport report = scheduler.run(pulled, source, cb);
    EXPECT_EQ(report.selected, 6u);
    EXPECT_EQ(report.done, 6u);
    EXPECT_EQ(done.size(), 6u);
    EXPECT_TRUE(same_bits(whole.value, pulled.values()));
    // A source that hands out an id out of range stops the run with an error.
    lut_slice::LutSliceIntegrand bad(spec);
    schedule::WorkSelection wrong;
    bool given = false;
    wrong.next_item = [&](std::uint64_t& id) {
        id = 99;
        return !std::exchange(given, true);
    };
    EXPECT_THROW(scheduler.run(bad, wrong), std::runtime_error);
}

// --- the CLI: shards, the Slurm variables, --merge, and bad input (exit 2, nothing written) -------------

RunResult cli(const std::string& env, const std::string& args) {
    return run_shell(env + " " + std::string(MICROSHADOW_CLI) + " " + args + " 2>&1");
}

const std::string kBake =
    "bake --layout custom --size 4 --roughness 0.3,0.8 --size-n-dot-v 3 --samples 1024 --seed 3 --backend oracle --quiet";

// The texels bit for bit and the metadata apart from the command line.
void expect_same_lut(const std::string& a, const std::string& b) {
    LutFile x = read_lut(a), y = read_lut(b);
    EXPECT_TRUE(same_bits(x.data, y.data)) << a << " vs " << b;
    x.metadata.erase("command_line");
    y.metadata.erase("command_line");
    EXPECT_EQ(x.metadata.dump(), y.metadata.dump());
}

TEST_F(Distributed, CliShardsFromSlurmVariablesMergeToOneProcess) {
    const std::string whole = path("whole.exr"), out = path("lut.exr");
    ASSERT_EQ(cli("", kBake + " --out " + whole).exit_code, 0);
    for (int task = 1; task <= 2; ++task) {
        // An array submitted as --array=1-2: tasks 1 and 2 are shards 0/2 and 1/2.
        const std::string env = "SLURM_ARRAY_TASK_ID=" + std::to_string(task) +
                                " SLURM_ARRAY_TASK_COUNT=2 SLURM_ARRAY_TASK_MIN=1 SLURM_ARRAY_TASK_MAX=2";
        const RunResult r = cli(env, kBake + " --out " + out);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        EXPECT_FALSE(fs::exists(out)) << "a shard wrote the LUT";
    }
    EXPECT_TRUE(fs::exists(out + ".chunks/manifest.shard-0-of-2.json"));
    EXPECT_TRUE(fs::exists(out + ".chunks/manifest.shard-1-of-2.json"));
    const RunResult m = cli("", kBake + " --out " + out + " --merge");
    ASSERT_EQ(m.exit_code, 0) << m.output;
    expect_same_lut(whole, out);
}

// The sweep's existing shards take the Slurm array variables too, into one folder that merge joins.
TEST_F(Distributed, CliSweepShardsFromSlurmVariables) {
    {
        std::ofstream spec(path("s.toml"));
        spec << "[sweep]\nchunk_size = 4\n[parameters]\nvisibility = [0.3, 0.9]\nn_dot_l = [0.4, 0.8]\nn_dot_v = [0.5, 1.0]\n"
                "roughness = [0.3]\n[comparators]\nanalytic = [\"naughty-dog\"]\n";
    }
    const std::string sweep = "sweep " + path("s.toml") + " --quiet --tolerance 1e-6 --backend oracle";
    ASSERT_EQ(cli("", sweep + " --out " + path("whole")).exit_code, 0);
    for (int task = 0; task < 2; ++task) {
        const RunResult r = cli("SLURM_ARRAY_TASK_ID=" + std::to_string(task) + " SLURM_ARRAY_TASK_COUNT=2", sweep + " --out " + path("split"));
        ASSERT_EQ(r.exit_code, 0) << r.output;
    }
    EXPECT_TRUE(fs::exists(path("split/manifest.shard-1-of-2.json")));
    EXPECT_FALSE(fs::exists(path("split/sweep.csv")));
    ASSERT_EQ(cli("", "merge --quiet --out " + path("merged") + " " + path("split")).exit_code, 0);
    std::ifstream a(path("whole/sweep.csv")), b(path("merged/sweep.csv"));
    const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
    EXPECT_FALSE(x.empty());
    EXPECT_EQ(x, y);
}

TEST_F(Distributed, CliBadShardsAndMergesExitTwoAndWriteNothing) {
    const std::string out = path("lut.exr");
    auto refused = [&](const std::string& env, const std::string& args, const std::string& says) {
        const RunResult r = cli(env, kBake + " --out " + out + " " + args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(out));
    };
    refused("", "--shard 2/2", "--shard: expected I/N");
    refused("SLURM_ARRAY_TASK_ID=3 SLURM_ARRAY_TASK_COUNT=3 SLURM_ARRAY_TASK_MIN=0 SLURM_ARRAY_TASK_MAX=7", "",
            "evenly spaced");
    refused("", "--merge", "no shard manifests");
    EXPECT_FALSE(fs::exists(out + ".chunks/items")) << "a refused merge created the store";
    ASSERT_EQ(cli("", kBake + " --out " + out + " --shard 0/2").exit_code, 0);
    refused("", "--merge", "shard 1/2 lacks 3 item(s)");
    // The same store split another way, or of another bake.
    refused("", "--shard 0/3", "splits this job into 2 shards, not 3");
    refused("", "--shard 1/2 --replicates 4", "spec hash");
    refused("", "--merge --shard 1/2", "--merge assembles");
}

// Runs `command` (with OUT replaced by `out`) as shards 0/2 and 1/2, then as the merge; each shard
// writes nothing but its store, the merge writes `out`.
void shards_then_merge(const std::string& command, const std::string& out) {
    auto with = [&](const std::string& extra) {
        std::string c = command;
        c.replace(c.find("OUT"), 3, out);
        return c + " " + extra;
    };
    for (int i = 0; i < 2; ++i) {
        const RunResult r = cli("", with("--shard " + std::to_string(i) + "/2"));
        ASSERT_EQ(r.exit_code, 0) << r.output;
        EXPECT_FALSE(fs::exists(out)) << "shard " << i << " wrote " << out;
    }
    const RunResult m = cli("", with("--merge"));
    ASSERT_EQ(m.exit_code, 0) << m.output;
}

// A representation bake's items are its roughness nodes: shards merge to one process's texels, and the
// metadata differs only in the run's time and command line.
TEST_F(Distributed, CliReprBakeShardsMergeToOneProcess) {
    const std::string repr_bake =
        "repr bake -q --kind azimuth-harmonics --visibility-count 3 --n-dot-l-count 3 --n-dot-v-count 2 --azimuth-nodes 7 "
        "--roughness 0.3,0.6,0.9 --samples 512 --seed 5 --backend oracle --out OUT";
    std::string whole = repr_bake;
    whole.replace(whole.find("OUT"), 3, path("whole.exr"));
    ASSERT_EQ(cli("", whole).exit_code, 0);
    shards_then_merge(repr_bake, path("split.exr"));
    const auto a = repr::open_representation(path("whole.exr")), b = repr::open_representation(path("split.exr"));
    EXPECT_TRUE(same_bits(a->texels(), b->texels()));
    const auto* ta = dynamic_cast<const repr::TextureRepresentation*>(a.get());
    const auto* tb = dynamic_cast<const repr::TextureRepresentation*>(b.get());
    ASSERT_TRUE(ta && tb);
    nlohmann::json x = ta->metadata(), y = tb->metadata();
    ASSERT_TRUE(x.contains("bake"));
    for (auto* j : {&x, &y}) {
        for (const char* key : {"command_line", "seconds"}) (*j)["bake"].erase(key);
        j->erase("command_line");
    }
    EXPECT_EQ(x.dump(), y.dump());
    EXPECT_EQ(x["bake"]["queries"].get<std::uint64_t>(), 3u * 7 * 3 * 3 * 2);
    EXPECT_TRUE(fs::exists(path("split.exr.chunks/manifest.shard-1-of-2.json")));
}

// A design's reference set: its chunks split over shards (sharing the cache's chunk folder), merged
// into the same cached set and the same Pareto table.
TEST_F(Distributed, CliDesignShardsMergeToOneProcess) {
    // 2100 points: three chunks of the cache's 1024, two in shard 0 and one in shard 1.
    std::ofstream(path("ref.toml")) << "name = \"tiny\"\n[points]\ncount = 2100\n[sampling]\nmethod = \"sampled\"\nsamples = 256\n";
    const std::string design = "design -q --backend oracle --reference " + path("ref.toml") + " --cache OUT";
    std::string whole = design + " --out " + path("whole");
    whole.replace(whole.find("OUT"), 3, path("cache-whole"));
    ASSERT_EQ(cli("", whole).exit_code, 0);
    for (int i = 0; i < 2; ++i) {
        std::string c = design;
        c.replace(c.find("OUT"), 3, path("cache-split"));
        const RunResult r = cli("", c + " --shard " + std::to_string(i) + "/2");
        ASSERT_EQ(r.exit_code, 0) << r.output;
    }
    EXPECT_FALSE(fs::exists(path("split")));
    std::string merge = design + " --merge --out " + path("split");
    merge.replace(merge.find("OUT"), 3, path("cache-split"));
    const RunResult m = cli("", merge);
    ASSERT_EQ(m.exit_code, 0) << m.output;
    for (const char* f : {"pareto.csv", "pareto.md"}) {
        std::ifstream a(path("whole/") + f), b(path("split/") + f);
        const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
        EXPECT_FALSE(x.empty());
        EXPECT_EQ(x, y) << f;
    }
}

// bake --scene: the scene bake's slices split, merged into the same LUT texels.
TEST_F(Distributed, CliSceneBakeShardsMergeToOneProcess) {
    std::vector<float> ao(16);
    for (int i = 0; i < 16; ++i) ao[std::size_t(i)] = float(0.3 + 0.6 * (i % 4) / 3.0);
    scene::write_exr(path("ao.exr"), 4, 4, {{"ao", ao.data()}});
    std::ofstream(path("s.toml")) << "[normal]\nvalue = [0, 0, 1]\n[visibility]\nfile = \"ao.exr\"\nchannel = \"ao\"\n"
                                     "[roughness]\nvalue = 0.5\n[view]\ndirection = [0.8, 0, 0.6]\n[[light]]\nname = \"sun\"\n"
                                     "direction = [0, 0.6, 0.8]\n";
    const std::string bake = "bake --scene " + path("s.toml") + " --scene-layout layout --size 4 --samples 1024 --backend oracle "
                             "--no-scene-compare --quiet --out OUT --scene-report " + path("rep");
    std::string whole = bake;
    whole.replace(whole.find("OUT"), 3, path("whole.exr"));
    ASSERT_EQ(cli("", whole).exit_code, 0);
    shards_then_merge(bake, path("split.exr"));
    EXPECT_TRUE(same_bits(read_lut(path("whole.exr")).data, read_lut(path("split.exr")).data));
}

TEST_F(Distributed, CliNewJobsRefuseBadSplitsExitTwoAndWriteNothing) {
    std::ofstream(path("ref.toml")) << "name = \"tiny\"\n[points]\ncount = 24\n[sampling]\nmethod = \"sampled\"\nsamples = 512\n";
    const std::string design = "design -q --backend oracle --reference " + path("ref.toml") + " --cache " + path("cache");
    auto refused = [&](const std::string& args, const std::string& says) {
        const RunResult r = cli("", args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(path("out")));
        EXPECT_FALSE(fs::exists(path("out.exr")));
    };
    refused(design + " --merge --out " + path("out"), "no shard manifests");
    ASSERT_EQ(cli("", design + " --shard 0/2").exit_code, 0);
    refused(design + " --shard 0/3", "splits this job into 2 shards, not 3");
    refused(design + " --merge --shard 1/2", "--merge assembles");
    const std::string repr_bake = "repr bake -q --kind azimuth-axis --visibility-count 2 --n-dot-l-count 2 --n-dot-v-count 2 "
                                  "--azimuth-nodes 3 --roughness 0.3,0.9 --samples 256 --backend oracle --out " + path("out.exr");
    refused(repr_bake + " --merge", "no shard manifests");
    refused(repr_bake + " --shard 3/2", "--shard: expected I/N");
    ASSERT_EQ(cli("", repr_bake + " --shard 0/2").exit_code, 0);
    refused(repr_bake + " --merge", "shard 1/2 lacks 1 item(s)");
}

// `scene`: a 6 x 4 scene of three lights (directional, point, sphere), masked pixels and materials, in
// tiles of 5 pixels: 3 lights x 5 tiles = 15 items.
std::string small_scene_description(const std::string& dir) {
    std::vector<float> ao(24), rough(24), mat(24), mask(24);
    for (int i = 0; i < 24; ++i) {
        ao[std::size_t(i)] = float(0.3 + 0.6 * (i % 5) / 4.0);
        rough[std::size_t(i)] = float(0.2 + 0.7 * (i % 7) / 6.0);
        mat[std::size_t(i)] = float(i % 3);
        mask[std::size_t(i)] = i % 11 == 4 ? 0.f : 1.f;
    }
    scene::write_exr(dir + "/maps.exr", 6, 4, {{"ao", ao.data()}, {"rough", rough.data()}, {"mat", mat.data()}, {"m", mask.data()}});
    std::ofstream(dir + "/s.toml")
        << "[normal]\nvalue = [0, 0, 1]\n[visibility]\nfile = \"maps.exr\"\nchannel = \"ao\"\n[roughness]\nfile = \"maps.exr\"\n"
           "channel = \"rough\"\n[material]\nfile = \"maps.exr\"\nchannel = \"mat\"\nnames = [\"a\", \"b\", \"c\"]\n[mask]\nfile = "
           "\"maps.exr\"\nchannel = \"m\"\n[view]\ndirection = [0.6, 0, 0.8]\n"
           "[[light]]\nname = \"sun\"\ndirection = [0, 0.6, 0.8]\n"
           "[[light]]\nname = \"lamp\"\ntype = \"point\"\nposition = [0.3, -0.2, 1.5]\nintensity = 2\n"
           "[[light]]\nname = \"ball\"\ntype = \"sphere\"\nposition = [-0.5, 0.4, 2]\nradius = 0.4\n"
           "[comparators]\nanalytic = [\"pz-analytic\", \"naughty-dog\"]\nseed_3d = false\nseed_2d = false\n"
           "[sampling]\nmethod = \"sampled\"\ntolerance = 0.02\narea_tolerance = 0.02\nmin_samples = 1024\nmax_samples = 16384\n"
           "tile_pixels = 5\n";
    return dir + "/s.toml";
}

using ms::testing::slurp_file;

// Two scene output folders hold the same run: every file byte for byte, but for what records the run
// (report.json's provenance and times, report.md's line of times, scene.exr's header holding the report):
// scene.exr is compared layer by layer, bit for bit.
void expect_same_scene(const std::string& a, const std::string& b) {
    std::set<std::string> files_a, files_b;
    for (const auto& e : fs::directory_iterator(a)) files_a.insert(e.path().filename().string());
    for (const auto& e : fs::directory_iterator(b))
        if (e.path().filename() != "chunks") files_b.insert(e.path().filename().string());
    EXPECT_EQ(files_a, files_b);
    for (const auto& f : files_a) {
        const std::string x = slurp_file(a + "/" + f), y = slurp_file(b + "/" + f);
        if (f == "report.json") {
            nlohmann::json jx = nlohmann::json::parse(x), jy = nlohmann::json::parse(y);
            for (auto* j : {&jx, &jy}) {
                j->erase("provenance");
                j->erase("seconds");
                for (auto& l : (*j)["lights"]) l.erase("seconds");
            }
            EXPECT_EQ(jx.dump(), jy.dump());
            EXPECT_GT(jx["work"]["sampled"].get<std::uint64_t>(), 0u);
        } else if (f == "report.md") {
            // The first paragraph holds the run's times; the tables after it are compared whole.
            const auto tables = [](const std::string& s) { return s.substr(s.find("\n| pixel x light")); };
            EXPECT_EQ(tables(x), tables(y));
        } else if (f == "scene.exr") {
            const std::vector<std::string> layers = scene::list_channels(a + "/" + f);
            EXPECT_EQ(layers, scene::list_channels(b + "/" + f));
            const auto pa = scene::read_channels(a + "/" + f, layers), pb = scene::read_channels(b + "/" + f, layers);
            ASSERT_EQ(pa.size(), pb.size());
            for (std::size_t k = 0; k < pa.size(); ++k) EXPECT_TRUE(same_bits(pa[k].data, pb[k].data)) << layers[k];
        } else {
            EXPECT_EQ(x, y) << f;
        }
    }
}

const char* kSceneArgs = " --backend oracle --no-seed-luts -q --out ";

TEST_F(Distributed, CliSceneShardsMergeToOneProcess) {
    const std::string toml = small_scene_description(dir_.string());
    const std::string scene = "scene " + toml + kSceneArgs;
    ASSERT_EQ(cli("", scene + path("whole")).exit_code, 0);
    // Three shards of the 15 tiles; shard 1 is run twice (the second run finds its items and resumes).
    for (const char* shard : {"0/3", "1/3", "1/3", "2/3"}) {
        const RunResult r = cli("", scene + path("split") + " --shard " + shard);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        EXPECT_FALSE(fs::exists(path("split/report.json"))) << "a shard wrote the report";
    }
    EXPECT_EQ(std::distance(fs::directory_iterator(path("split/chunks/items")), fs::directory_iterator()), 15);
    const RunResult m = cli("", scene + path("split") + " --merge");
    ASSERT_EQ(m.exit_code, 0) << m.output;
    expect_same_scene(path("whole"), path("split"));
    // A store of this one process (--store, no shard) gives the same again, from its items alone on a rerun.
    for (int run = 0; run < 2; ++run) ASSERT_EQ(cli("", scene + path("stored") + " --store " + path("store")).exit_code, 0);
    expect_same_scene(path("whole"), path("stored"));
    // Items computed after the ones found in the store (the first tile of the first light, a middle one)
    // are assembled in item order all the same.
    for (const char* item : {"item-0000000000.bin", "item-0000000007.bin"}) ASSERT_TRUE(fs::remove(path("store/items/") + item));
    const RunResult resumed = cli("", scene + path("resumed") + " --store " + path("store"));
    ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
    expect_same_scene(path("whole"), path("resumed"));
}

TEST_F(Distributed, CliSceneRefusesBadSplitsExitTwoAndWritesNothing) {
    const std::string toml = small_scene_description(dir_.string());
    const std::string scene = "scene " + toml + kSceneArgs + path("out");
    auto refused = [&](const std::string& env, const std::string& args, const std::string& says) {
        const RunResult r = cli(env, scene + " " + args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(says), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(path("out/report.json")));
        EXPECT_FALSE(fs::exists(path("out/scene.exr")));
    };
    refused("", "--shard 3/3", "--shard: expected I/N");
    refused("SLURM_ARRAY_TASK_ID=5 SLURM_ARRAY_TASK_COUNT=3", "", "evenly spaced");
    refused("", "--merge", "no shard manifests");
    EXPECT_FALSE(fs::exists(path("out"))) << "a refused merge created the output folder";
    ASSERT_EQ(cli("", scene + " --shard 0/3").exit_code, 0);
    ASSERT_EQ(cli("", scene + " --shard 2/3").exit_code, 0);
    // 15 items, shard 1 of 3 holds ids 1, 4, 7, 10, 13.
    refused("", "--merge", "shard 1/3 lacks 5 item(s) (the first is 1)");
    refused("", "--shard 1/2", "splits this job into 3 shards, not 2");
    refused("", "--shard 1/3 --tolerance 0.03", "spec hash");
    refused("", "--merge --shard 1/3", "--merge assembles");
    EXPECT_EQ(std::distance(fs::directory_iterator(path("out")), fs::directory_iterator()), 1) << "only the chunk store";
}

}  // namespace
