// Sweep integrity: chunks never trusted blindly, --restart leaves nothing behind, a light just above
// the horizon, error bars on rare events that are never 0, and a --device all resume. Each test failed
// on the code before its fix: chunks were concatenated unchecked (a removed line gave 527 of 528 rows, exit
// 0), --restart kept the old sweep.csv, the light 1e-46 above the horizon gave 0 on OpenCL, and a
// query no sample passed reported 0 +- 0.
#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "core/digest.hpp"
#include "core/estimate.hpp"
#include "device/runtime.hpp"
#include "jobs/eval.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "oracle/oracle.hpp"
#include "schedule/distributed.hpp"
#include "test_files.hpp"

namespace ms {
namespace {

namespace fs = std::filesystem;
using sweep::RunConfig;
using sweep::Spec;

using ms::testing::slurp_file;

void spit(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary | std::ios::trunc) << text; }

fs::path fresh_dir(const std::string& name) {
    const fs::path d = fs::temp_directory_path() / ("microshadow_integrity_" + std::to_string(::getpid())) / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

Spec small_spec() {
    return sweep::parse_spec("[sweep]\nchunk_size = 8\n[parameters]\nvisibility = {start = 0.1, stop = 0.9, count = 4}\n"
                             "n_dot_l = {start = 0.2, stop = 1, count = 4}\nroughness = [0.3, 0.6]\n",
                             "t.toml");
}

RunConfig config(const fs::path& out, TermBackend& backend) {
    RunConfig c;
    c.out_dir = out.string();
    c.plan.samples = 256;
    c.plan.replicates = 4;
    c.plan.seed = 3;
    c.backend = &backend;
    return c;
}

// Chunk c's item in the sweep's store (schedule/chunk_store.hpp): a five-line header (magic, spec hash,
// id, payload size, payload digest), then the chunk's rows.
std::string chunk(const fs::path& dir, int c) {
    char name[32];
    std::snprintf(name, sizeof name, "item-%010d.bin", c);
    return (dir / "items" / name).string();
}
std::size_t header_end(const std::string& item) {
    std::size_t at = 0;
    for (int line = 0; line < 5; ++line) at = item.find('\n', at) + 1;
    return at;
}
std::string rows_of(const std::string& item) { return item.substr(header_end(item)); }
// The item's rows replaced, its header kept (the seal no longer matches).
std::string with_rows(const std::string& item, const std::string& rows) { return item.substr(0, header_end(item)) + rows; }
// The item's rows replaced and sealed again, size and digest recomputed: what anyone can forge.
std::string resealed(const std::string& item, const std::string& rows) {
    std::istringstream in(item);
    std::string magic, hash, id;
    std::getline(in, magic) && std::getline(in, hash) && std::getline(in, id);
    return magic + "\n" + hash + "\n" + id + "\n" + std::to_string(rows.size()) + "\n" + hex16(fnv1a(rows)) + "\n" + rows;
}
bool set_aside(const fs::path& dir, const std::string& name) {
    if (!fs::is_directory(dir / "items" / "rejected")) return false;
    for (const auto& e : fs::directory_iterator(dir / "items" / "rejected"))
        if (e.path().filename().string().rfind(name + ".", 0) == 0) return true;
    return false;
}

// Each kind of damage a user can do, applied to one finished chunk of an interrupted sweep.
struct Damage {
    const char* name;
    std::string (*apply)(const std::string&);
};
const Damage kDamages[] = {
    {"a removed line", [](const std::string& t) { return t.substr(t.find('\n') + 1); }},
    {"a duplicated line", [](const std::string& t) { return t.substr(0, t.find('\n') + 1) + t; }},
    {"a changed term", [](const std::string& t) {
         std::string s = t;
         const auto comma = s.rfind(',', s.find('\n'));  // the std_error field of the first row
         const auto prev = s.rfind(',', comma - 1);       // the term field
         return s.replace(prev + 1, comma - prev - 1, "0.123456");
     }},
    {"100 appended bytes", [](const std::string& t) { return t + std::string(100, '\x9c'); }},
    {"a row cut mid-way", [](const std::string& t) { return t.substr(0, t.size() - 7); }},
};

TEST(SweepIntegrity, EveryKindOfChunkDamageIsSetAsideAndRecomputed) {
    const Spec spec = small_spec();
    auto backend = make_oracle_backend(1);
    const fs::path clean = fresh_dir("clean");
    ASSERT_TRUE(sweep::run_sweep(spec, config(clean, *backend)).assembled);
    const std::string expected = slurp_file(clean / "sweep.csv");
    // Each damage to the rows, once under the item's own seal (its digest no longer matches) and once
    // sealed again (the rows' own checks catch it); a changed term stays a fraction, so only the seal can.
    for (const bool forge : {false, true}) {
        for (const Damage& d : kDamages) {
            if (forge && std::string(d.name) == "a changed term") continue;
            const std::string what = std::string(d.name) + (forge ? ", sealed again" : "");
            const fs::path dir = fresh_dir("damaged");
            RunConfig c = config(dir, *backend);
            c.max_chunks = 2;
            ASSERT_FALSE(sweep::run_sweep(spec, c).complete);
            const std::string item = slurp_file(chunk(dir, 1));
            const std::string rows = d.apply(rows_of(item));
            spit(chunk(dir, 1), forge ? resealed(item, rows) : with_rows(item, rows));
            c.max_chunks = 0;
            std::vector<std::string> told;
            c.warn = [&](const std::string& w) { told.push_back(w); };
            const sweep::RunResult r = sweep::run_sweep(spec, c);
            ASSERT_TRUE(r.assembled) << what;
            EXPECT_EQ(slurp_file(dir / "sweep.csv"), expected) << what;
            ASSERT_EQ(told.size(), 1u) << what;
            EXPECT_NE(told[0].find("item-0000000001.bin"), std::string::npos) << told[0];
            // Says what follows, once (the store's message carries it; the sweep adds nothing).
            const std::size_t said = told[0].find("; computed again");
            EXPECT_NE(said, std::string::npos) << told[0];
            EXPECT_EQ(told[0].find("computed again", said + 2 + 1), std::string::npos) << told[0];
            EXPECT_EQ(r.warnings, told);
            // The evidence is kept, apart from the chunks the sweep reads.
            EXPECT_TRUE(set_aside(dir, "item-0000000001.bin")) << what;
            EXPECT_EQ(r.skipped, 1u) << what;  // chunk 0 was sound and kept
        }
    }
}

TEST(SweepIntegrity, MergeNamesADamagedShardChunkAndARerunRepairsIt) {
    const Spec spec = small_spec();
    auto backend = make_oracle_backend(1);
    const fs::path clean = fresh_dir("mclean"), s0 = fresh_dir("s0"), s1 = fresh_dir("s1"), out = fresh_dir("merged");
    ASSERT_TRUE(sweep::run_sweep(spec, config(clean, *backend)).assembled);
    for (auto [dir, index] : {std::pair{s0, 0u}, std::pair{s1, 1u}}) {
        RunConfig c = config(dir, *backend);
        c.shard = {index, 2};
        ASSERT_TRUE(sweep::run_sweep(spec, c).complete);
    }
    const std::string item = slurp_file(chunk(s1, 3));
    spit(chunk(s1, 3), with_rows(item, kDamages[4].apply(rows_of(item))));
    std::vector<std::string> told;
    try {
        sweep::merge_shards({s0.string(), s1.string()}, out.string(), "test", "", [&](const std::string& w) { told.push_back(w); });
        FAIL() << "merged a truncated chunk";
    } catch (const std::invalid_argument& e) {  // damaged input: exit status 2, as bake --merge says it
        EXPECT_NE(std::string(e.what()).find("shard 1/2 lacks 1 item(s) (the first is 3)"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("rerun those shards"), std::string::npos) << e.what();
    }
    ASSERT_FALSE(told.empty());
    EXPECT_NE(told[0].find("item-0000000003.bin"), std::string::npos) << told[0];
    EXPECT_FALSE(fs::exists(out / "sweep.csv"));
    RunConfig c = config(s1, *backend);
    c.shard = {1, 2};
    EXPECT_EQ(sweep::run_sweep(spec, c).computed, 1u);
    sweep::merge_shards({s0.string(), s1.string()}, out.string(), "test");
    EXPECT_EQ(slurp_file(out / "sweep.csv"), slurp_file(clean / "sweep.csv"));
}

// An MPI world in one process: the ranks are threads sharing a queue of items and one of results, as
// cli/mpi_world's MPI messages carry them between processes.
class ThreadWorld {
public:
    explicit ThreadWorld(int ranks) : ranks_(ranks) {}
    class Rank final : public schedule::ItemTransport {
    public:
        Rank(ThreadWorld& world, int rank) : w_(world), rank_(rank) {}
        int rank() const override { return rank_; }
        int ranks() const override { return w_.ranks_; }
        void coordinate(std::deque<std::uint64_t> pending, const std::function<void(std::uint64_t, const std::string&)>& on_result,
                        const std::function<void(std::uint64_t, std::uint64_t)>& progress) override {
            std::unique_lock<std::mutex> lock(w_.mutex_);
            const std::uint64_t total = pending.size();
            w_.pending_ = std::move(pending);
            w_.handed_ = true;
            w_.changed_.notify_all();
            std::uint64_t done = 0;
            while (true) {
                w_.changed_.wait(lock, [&] { return !w_.results_.empty() || w_.finished_ == w_.ranks_ - 1; });
                if (w_.results_.empty()) break;
                auto [id, payload] = std::move(w_.results_.front());
                w_.results_.pop_front();
                lock.unlock();
                on_result(id, payload);
                if (progress) progress(++done, total);
                lock.lock();
            }
            if (!w_.failure_.empty()) throw std::runtime_error("a rank failed: " + w_.failure_);
        }
        bool next_item(std::uint64_t& id) override {
            std::unique_lock<std::mutex> lock(w_.mutex_);
            w_.changed_.wait(lock, [&] { return w_.handed_; });
            if (w_.pending_.empty()) return false;
            id = w_.pending_.front();
            w_.pending_.pop_front();
            return true;
        }
        void send_result(std::uint64_t id, const std::string& payload) override {
            std::lock_guard<std::mutex> lock(w_.mutex_);
            w_.results_.emplace_back(id, payload);
            w_.changed_.notify_all();
        }
        void finish(const std::string& failure) override {
            std::lock_guard<std::mutex> lock(w_.mutex_);
            ++w_.finished_;
            if (!failure.empty()) w_.failure_ = failure;
            w_.changed_.notify_all();
        }

    private:
        ThreadWorld& w_;
        int rank_;
    };

private:
    int ranks_;
    std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<std::uint64_t> pending_;
    bool handed_ = false;
    std::deque<std::pair<std::uint64_t, std::string>> results_;
    int finished_ = 0;
    std::string failure_;
};

// Rank 0 and two computing ranks of a world run `spec` into `out`; the computing ranks write nothing.
sweep::RunResult run_in_world(const Spec& spec, const fs::path& out, const fs::path& elsewhere) {
    ThreadWorld world(3);
    std::vector<std::unique_ptr<ThreadWorld::Rank>> ranks;
    for (int r = 0; r < 3; ++r) ranks.push_back(std::make_unique<ThreadWorld::Rank>(world, r));
    std::vector<std::thread> computing;
    std::vector<std::string> errors(3);
    for (int r = 1; r < 3; ++r)
        computing.emplace_back([&, r] {
            try {
                auto backend = make_oracle_backend(1);
                RunConfig c = config(elsewhere, *backend);
                c.transport = ranks[r].get();
                sweep::run_sweep(spec, c);
            } catch (const std::exception& e) {
                errors[r] = e.what();
            }
        });
    auto backend = make_oracle_backend(1);
    RunConfig c = config(out, *backend);
    c.transport = ranks[0].get();
    sweep::RunResult result;
    try {
        result = sweep::run_sweep(spec, c);
    } catch (const std::exception& e) {
        errors[0] = e.what();
    }
    for (auto& t : computing) t.join();
    for (const auto& e : errors) EXPECT_EQ(e, "");
    return result;
}

TEST(SweepIntegrity, AnMpiWorldGathersTheSameBytesAndResumesFromTheStore) {
    // The MPI path is the shared item store's (schedule/distributed.hpp): rank 0 keeps the chunks the
    // other ranks send, checked like stored ones, and resumes from what the folder already holds.
    const Spec spec = small_spec();
    auto backend = make_oracle_backend(1);
    const fs::path clean = fresh_dir("wclean"), out = fresh_dir("world"), elsewhere = fresh_dir("ranks") / "never";
    ASSERT_TRUE(sweep::run_sweep(spec, config(clean, *backend)).assembled);
    const sweep::RunResult whole = run_in_world(spec, out, elsewhere);
    ASSERT_TRUE(whole.assembled);
    EXPECT_EQ(whole.computed, whole.chunks);
    EXPECT_EQ(slurp_file(out / "sweep.csv"), slurp_file(clean / "sweep.csv"));
    EXPECT_FALSE(fs::exists(elsewhere)) << "a computing rank wrote into its --out";
    // Two chunks finished by one process, the rest by the world.
    const fs::path half = fresh_dir("whalf");
    RunConfig c = config(half, *backend);
    c.max_chunks = 2;
    ASSERT_FALSE(sweep::run_sweep(spec, c).complete);
    const sweep::RunResult rest = run_in_world(spec, half, elsewhere);
    ASSERT_TRUE(rest.assembled);
    EXPECT_EQ(rest.skipped, 2u);
    EXPECT_EQ(rest.computed, rest.chunks - 2);
    EXPECT_EQ(slurp_file(half / "sweep.csv"), slurp_file(clean / "sweep.csv"));
}

TEST(SweepIntegrity, AForgedManifestItemCountIsSetAsideAndTheMergeHeals) {
    // The sweep's manifests are the item store's: one whose chunk count was changed is set aside with a
    // warning (before, a sweep's own manifest format had no such check), and the merge completes.
    const Spec spec = small_spec();
    auto backend = make_oracle_backend(1);
    const fs::path clean = fresh_dir("fclean"), split = fresh_dir("fsplit"), out = fresh_dir("fmerged");
    ASSERT_TRUE(sweep::run_sweep(spec, config(clean, *backend)).assembled);
    for (std::uint32_t i = 0; i < 2; ++i) {
        RunConfig c = config(split, *backend);
        c.shard = {i, 2};
        ASSERT_TRUE(sweep::run_sweep(spec, c).complete);
    }
    const fs::path manifest = split / "manifest.shard-0-of-2.json";
    nlohmann::json m = nlohmann::json::parse(slurp_file(manifest));
    m["items"] = m["items"].get<std::uint64_t>() + 5;
    spit(manifest, m.dump(1));
    std::vector<std::string> told;
    sweep::merge_shards({split.string()}, out.string(), "test", "", [&](const std::string& w) { told.push_back(w); });
    EXPECT_EQ(slurp_file(out / "sweep.csv"), slurp_file(clean / "sweep.csv"));
    ASSERT_FALSE(told.empty());
    EXPECT_NE(told[0].find("items: the manifest says"), std::string::npos) << told[0];
    EXPECT_FALSE(fs::exists(manifest));
}

TEST(SweepIntegrity, RestartRemovesEverythingTheOldSweepWrote) {
    auto backend = make_oracle_backend(1);
    const fs::path dir = fresh_dir("restart");
    ASSERT_TRUE(sweep::run_sweep(small_spec(), config(dir, *backend)).assembled);
    fs::create_directories(dir / "figures");
    spit(dir / "figures" / "old.png", "x");
    // Another sweep, stopped before it assembles: only its own unfinished state may be left.
    RunConfig c = config(dir, *backend);
    c.restart = true;
    c.max_chunks = 1;
    const Spec other = sweep::parse_spec(
        "[sweep]\nchunk_size = 1\n[parameters]\nvisibility = [0.3, 0.5]\nn_dot_l = [0.9]\nroughness = [0.5]\n", "o.toml");
    ASSERT_FALSE(sweep::run_sweep(other, c).complete);
    for (const char* old : {"sweep.csv", "sweep.json", "summary.md", "summary.csv", "figures"})
        EXPECT_FALSE(fs::exists(dir / old)) << old;
    EXPECT_TRUE(fs::exists(dir / "manifest.shard-0-of-1.json"));
}

TEST(RareEvents, NoSamplePassingGivesAnHonestBoundNotZero) {
    // The hardest query: grazing view and light, 1:50 anisotropy. Reference: the kernels at 2^24 samples.
    auto backend = make_opencl_backend(ocl::select_devices("default"));
    Query q;
    q.visibility = 0.8866;
    q.alpha_x = 0.5;
    q.alpha_y = 0.01;
    q.wi = {-0.5708, 0.8211, 0.001};
    q.wo = {0.7303, 0.6831, 0.001};
    SamplingPlan ref_plan;
    ref_plan.samples = std::uint64_t(1) << 24;
    ref_plan.seed = 99;
    const Estimate ref = evaluate(*backend, {q}, TermOptions{}, ref_plan).at(0);
    ASSERT_GT(ref.term, 0.0);
    const int seeds = 20;
    // 99.9 % over the whole test (Bonferroni over the seeds), Student t with R - 1 = 7 degrees of freedom.
    const double t = student_t_quantile(1 - 0.001 / seeds, 7);
    int zero_estimates = 0;
    for (int seed = 0; seed < seeds; ++seed) {
        SamplingPlan plan;
        plan.samples = 65536;
        plan.seed = std::uint64_t(seed);
        const Estimate e = evaluate(*backend, {q}, TermOptions{}, plan).at(0);
        EXPECT_GT(e.std_error, 0.0) << "seed " << seed << ": " << e.term << " +- 0 while the term is " << ref.term;
        zero_estimates += e.term == 0;
        EXPECT_LE(std::abs(e.term - ref.term), t * std::hypot(e.std_error, ref.std_error))
            << "seed " << seed << ": " << e.term << " +- " << e.std_error << " vs " << ref.term;
    }
    EXPECT_GT(zero_estimates, 0) << "the case no longer exercises the rare-event bound";
}

TEST(Horizon, ALightJustAboveTheHorizonIsNotRoundedOntoIt) {
    // wo_z = 1e-46 underflowed to 0 in float: OpenCL said 0 +- 0, the oracle 0.959 +- 0.0004.
    Query q;
    q.visibility = 0.999;
    q.alpha_x = q.alpha_y = 1;
    q.wi = {0.6, 0, 0.8};
    q.wo = {1, 0, 1e-46};
    SamplingPlan plan;
    plan.samples = 65536;
    auto cl = make_opencl_backend(ocl::select_devices("default"));
    auto oracle = make_oracle_backend(2);
    const Estimate a = evaluate(*cl, {q}, TermOptions{}, plan).at(0);
    const Estimate b = evaluate(*oracle, {q}, TermOptions{}, plan).at(0);
    EXPECT_GT(a.term, 0.9);
    EXPECT_LE(std::abs(a.term - b.term), student_t_quantile(0.999, 7) * std::hypot(a.std_error, b.std_error) + 1e-6)
        << a.term << " +- " << a.std_error << " vs oracle " << b.term << " +- " << b.std_error;
}

TEST(SweepIntegrity, ASweepBegunOnOneDeviceResumesOnAllOfThem) {
    const fs::path dir = fresh_dir("devices");
    const std::string spec = (dir / "s.toml").string();
    spit(spec, "[sweep]\nchunk_size = 4\n[parameters]\nvisibility = [0.3, 0.6, 0.9]\nn_dot_l = [0.5, 0.8, 1]\nroughness = [0.5]\n");
    const std::string bin = MICROSHADOW_CLI;
    const std::string env = "POCL_CACHE_DIR=" + (fs::temp_directory_path() / "pocl-cache-integrity").string() + " ";
    const auto one = testing::run_shell(env + bin + " sweep " + spec + " --out " + (dir / "a").string() +
                                        " --method sampled --samples 1024 --max-chunks 1 -q 2>&1");
    ASSERT_EQ(one.exit_code, 0) << one.output;
    const auto all = testing::run_shell(env + "POCL_DEVICES='pthread pthread' " + bin + " sweep " + spec + " --out " +
                                        (dir / "a").string() + " --method sampled --samples 1024 --device all -q 2>&1");
    ASSERT_EQ(all.exit_code, 0) << all.output;
    const auto whole = testing::run_shell(env + bin + " sweep " + spec + " --out " + (dir / "b").string() +
                                          " --method sampled --samples 1024 -q 2>&1");
    ASSERT_EQ(whole.exit_code, 0) << whole.output;
    EXPECT_EQ(slurp_file(dir / "a" / "sweep.csv"), slurp_file(dir / "b" / "sweep.csv"));
}

}  // namespace
}  // namespace ms
