// `microshadow design`: the reference cache resumes from its chunks and a changed definition
// is another cache; the weighted metrics, the Pareto front and the budget choice on known numbers; and
// the command on a tiny reference set ranks a known-better comparator first and refuses bad input
// before writing anything.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_runner.hpp"
#include "core/cancel.hpp"
#include "jobs/design.hpp"
#include "jobs/eval.hpp"
#include "jobs/reference_set.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::run_shell;

class DesignTest : public ms::testing::ScratchDirTest {
protected:
    DesignTest() : ScratchDirTest("design") {}
};

// A small region: 40 points, 1024 oracle samples each (the oracle: no device needed, and exact bits).
ms::design::ReferenceDefinition small_definition() {
    ms::design::ReferenceDefinition d;
    d.name = "small";
    d.count = 40;
    d.plan.samples = 1024;
    d.plan.replicates = 8;
    d.backend_label = "oracle";
    return d;
}

TEST_F(DesignTest, ReferenceCacheResumesFromChunksAndAChangedDefinitionIsAnotherCache) {
    auto backend = ms::make_oracle_backend(2);
    const ms::design::ReferenceDefinition def = small_definition();
    ms::design::CacheConfig config;
    config.dir = path("cache");
    config.backend = backend.get();
    config.chunk_points = 16;  // 3 chunks
    config.max_chunks = 1;
    // Stopped after one chunk: that chunk is on disk, the finished file is not.
    EXPECT_THROW(ms::design::load_or_compute(def, config), ms::design::IncompleteReference);
    const std::string file = ms::design::cache_file(def, config.dir);
    EXPECT_FALSE(fs::exists(file));
    const std::string chunks = fs::path(file).replace_extension(".chunks").string();
    EXPECT_TRUE(fs::exists(chunks + "/chunk-000000.csv"));
    EXPECT_FALSE(fs::exists(chunks + "/chunk-000001.csv"));
    // Resumed: the kept chunk is read, the other two computed.
    config.max_chunks = 0;
    ms::design::CacheReport resumed_report;
    const auto resumed = ms::design::load_or_compute(def, config, &resumed_report);
    EXPECT_FALSE(resumed_report.from_cache);
    EXPECT_EQ(resumed_report.chunks_found, 1u);
    EXPECT_EQ(resumed_report.chunks_computed, 2u);
    EXPECT_TRUE(fs::exists(file));
    EXPECT_FALSE(fs::exists(chunks));  // removed once the set is written
    // The same bits as one uninterrupted run elsewhere.
    ms::design::CacheConfig fresh = config;
    fresh.dir = path("fresh");
    const auto whole = ms::design::load_or_compute(def, fresh);
    ASSERT_EQ(whole.values.size(), resumed.values.size());
    for (std::size_t i = 0; i < whole.values.size(); ++i) {
        EXPECT_EQ(whole.values[i].term, resumed.values[i].term) << i;
        EXPECT_EQ(whole.values[i].std_error, resumed.values[i].std_error) << i;
    }
    // Loaded again: from the cache, no backend needed.
    ms::design::CacheConfig no_backend = config;
    no_backend.backend = nullptr;
    ms::design::CacheReport again;
    const auto cached = ms::design::load_or_compute(def, no_backend, &again);
    EXPECT_TRUE(again.from_cache);
    EXPECT_EQ(cached.values[5].term, whole.values[5].term);
    // A changed definition (samples, a region bound, the point seed) has another hash: not this cache.
    for (int change = 0; change < 3; ++change) {
        ms::design::ReferenceDefinition other = def;
        if (change == 0) other.plan.samples = 2048;
        if (change == 1) other.visibility.hi = 0.97;
        if (change == 2) other.point_seed = 2;
        EXPECT_NE(other.hash(), def.hash()) << change;
        ms::design::CacheReport r;
        ms::design::load_or_compute(other, config, &r);
        EXPECT_FALSE(r.from_cache) << change;
        EXPECT_EQ(r.chunks_computed, 3u) << change;
    }
    // A damaged cache file is refused, naming it.
    {
        std::ofstream f(file, std::ios::app);
        f << "0.5,0.5,0.5,0.5,0,1,0.5,0.01\n";
    }
    try {
        ms::design::load_or_compute(def, no_backend);
        ADD_FAILURE() << "a damaged cache was read";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
}

TEST(DesignMetrics, WeightedRmsPercentileAndMaxOnKnownErrors) {
    // 100 errors 0.01 .. 1.00 with weight 1, and a huge error of weight 0 (a light on the horizon).
    std::vector<double> e, w;
    for (int i = 1; i <= 100; ++i) e.push_back(i / 100.0), w.push_back(1);
    e.push_back(50);
    w.push_back(0);
    const auto m = ms::design::error_metrics(e, w);
    EXPECT_EQ(m.points, 100u);
    EXPECT_DOUBLE_EQ(m.max_abs, 1.0);
    EXPECT_DOUBLE_EQ(m.weighted_p99, 0.99);  // 99 % of the weight lies at |e| <= 0.99
    double s = 0;
    for (int i = 1; i <= 100; ++i) s += (i / 100.0) * (i / 100.0);
    EXPECT_NEAR(m.weighted_rms, std::sqrt(s / 100), 1e-15);
    // Weight moves the percentile: the last point carrying 5 % of the weight is the p99.
    w[99] = 100.0 / 19;  // 99 x 1 + w = total, w / total = 0.05
    EXPECT_DOUBLE_EQ(ms::design::error_metrics(e, w).weighted_p99, 1.0);
}

TEST(DesignPareto, FrontAndBudgetChoice) {
    auto candidate = [](const std::string& name, std::uint64_t bytes, unsigned fetches, unsigned alu) {
        ms::design::Candidate c;
        c.name = name;
        c.cost.bytes = bytes;
        c.cost.fetches_per_light = fetches;
        c.cost.alu_per_light = alu;
        return c;
    };
    const std::vector<ms::design::Candidate> c = {candidate("cheap-bad", 0, 0, 5), candidate("formula", 0, 0, 20),
                                                  candidate("small-lut", 1024, 1, 30), candidate("dominated", 4096, 1, 30),
                                                  candidate("big-lut", 65536, 2, 40)};
    std::vector<ms::design::Metrics> m(5);
    m[0].weighted_rms = 0.3, m[1].weighted_rms = 0.1, m[2].weighted_rms = 0.05, m[3].weighted_rms = 0.06,
    m[4].weighted_rms = 0.01;
    EXPECT_EQ(ms::design::pareto_front(c, m), (std::vector<std::size_t>{0, 1, 2, 4}));
    EXPECT_EQ(ms::design::choose(c, m, {}), 4u);
    ms::design::Budget b;
    b.max_fetches = 1;
    EXPECT_EQ(ms::design::choose(c, m, b), 2u);
    b.max_bytes = 0;
    EXPECT_EQ(ms::design::choose(c, m, b), 1u);
    b.max_alu = 4;
    EXPECT_THROW(ms::design::choose(c, m, b), std::invalid_argument);
}

using ms::testing::cli;

// The command end to end on a tiny reference set of 48 points at relative azimuth 0 and roughness
// 0.4: a LUT baked at that azimuth and roughness must rank first (its only error is interpolation,
// RMS about 0.003 at 16 texels per axis, docs/study.md section 3), before the azimuth-mean LUT of the
// same size (RMS 0.08 at azimuth 0) and every part 1 term (>= 0.19).
TEST_F(DesignTest, CommandRanksAKnownBetterComparatorFirstAndRefusesBadInput) {
    {
        std::ofstream f(path("points.csv"));
        f << "visibility,n_dot_l,n_dot_v,roughness,relative_azimuth_deg,weight\n";
        for (int i = 0; i < 48; ++i)
            f << 0.55 + 0.4 * ((i * 7) % 48) / 47.0 << "," << 0.1 + 0.85 * ((i * 5) % 48) / 47.0 << ","
              << 0.3 + 0.6 * (i % 4) / 3.0 << ",0.4,0," << 1 + i % 3 << "\n";
        std::ofstream s(path("ref.toml"));
        s << "name = \"tiny\"\n[points]\ncsv = \"points.csv\"\n[sampling]\nmethod = \"sampled\"\nsamples = 16384\n";
    }
    const RunResult az0 = cli("bake -q --layout custom --size 16 --roughness 0.4 --azimuth 0 --samples 16384 --out " + path("az0.exr"));
    ASSERT_EQ(az0.exit_code, 0) << az0.output;
    const RunResult mean = cli("bake -q --layout custom --size 16 --roughness 0.4 --samples 16384 --out " + path("mean.exr"));
    ASSERT_EQ(mean.exit_code, 0) << mean.output;
    // A coarse representation that keeps the azimuth (4 texels per axis): a candidate of its own kind.
    const RunResult rep = cli("repr bake -q --kind azimuth-axis --visibility-count 4 --n-dot-l-count 4 --n-dot-v-count 4 "
                              "--azimuth-nodes 3 --samples 1024 --half --out " + path("coarse.exr"));
    ASSERT_EQ(rep.exit_code, 0) << rep.output;
    const std::string base = "design --reference " + path("ref.toml") + " --cache " + path("cache") + " --lut " +
                             path("az0.exr") + " --lut " + path("mean.exr") + " --repr " + path("coarse.exr");
    const RunResult r = cli(base + " --out " + path("out") + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::ifstream csv(path("out/pareto.csv"));
    std::string header, first;
    std::getline(csv, header);
    std::getline(csv, first);
    EXPECT_EQ(first.substr(0, first.find(',')), "az0") << r.output;
    EXPECT_NE(first.find(",1,1,1"), std::string::npos) << "az0 should be on the front, chosen and within budget: " << first;
    EXPECT_TRUE(fs::exists(path("out/chosen-az0.exr")));
    EXPECT_TRUE(fs::exists(path("out/chosen-az0.glsl")));
    EXPECT_TRUE(fs::exists(path("out/design.json")));
    EXPECT_EQ(r.output.find("no candidate stores a texture"), std::string::npos) << r.output;
    // Part 1's formulas alone: the budget of bytes decided nothing, and the answer says so (before, a
    // bare "chosen: pz-analytic" read as the answer to --max-bytes).
    const RunResult formulas = cli("design --reference " + path("ref.toml") + " --cache " + path("cache") + " --max-bytes 256KiB -q");
    ASSERT_EQ(formulas.exit_code, 0) << formulas.output;
    EXPECT_NE(formulas.output.find("note: no candidate stores a texture, so --max-bytes decided nothing"), std::string::npos)
        << formulas.output;

    // The representation and a fitted closed form can be chosen and baked with their shaders; the
    // closed form's JSON is a candidate again (the same errors: the same coefficients).
    const RunResult chosen = cli(base + " --fit-reference " + path("ref.toml") + " --fit-orders 1 --choose closed-form-1 --out " +
                                 path("cf") + " -q");
    ASSERT_EQ(chosen.exit_code, 0) << chosen.output;
    for (const char* ext : {".json", ".glsl", ".hlsl"}) EXPECT_TRUE(fs::exists(path("cf/chosen-closed-form-1") + ext)) << ext;
    const RunResult reread = cli(base + " --no-analytic --closed-form " + path("cf/chosen-closed-form-1.json") + " --choose coarse --out " +
                                 path("rep") + " -q");
    ASSERT_EQ(reread.exit_code, 0) << reread.output;
    for (const char* ext : {".exr", ".glsl", ".hlsl"}) EXPECT_TRUE(fs::exists(path("rep/chosen-coarse") + ext)) << ext;
    auto row_of = [&](const std::string& file, const std::string& name) {
        std::ifstream in(file);
        for (std::string line; std::getline(in, line);)
            if (line.rfind(name + ",", 0) == 0) return line;
        return std::string();
    };
    EXPECT_FALSE(row_of(path("cf/pareto.csv"), "closed-form-1").empty());
    EXPECT_EQ(row_of(path("cf/pareto.csv"), "closed-form-1").substr(0, 60), row_of(path("rep/pareto.csv"), "closed-form-1").substr(0, 60));
    EXPECT_NE(row_of(path("rep/pareto.csv"), "coarse").find("azimuth-axis"), std::string::npos);

    // Bad budgets, files and names: exit status 2, nothing written.
    const std::vector<std::pair<std::string, std::string>> bad = {
        {" --max-bytes -5", "--max-bytes"},
        {" --max-bytes 12XB", "--max-bytes"},
        {" --max-fetches two", "--max-fetches"},
        {" --max-bytes 0 --max-alu 3", "no candidate fits the budget"},
        {" --choose nothing", "no such candidate"},
        {" --lut " + path("missing.exr"), "missing.exr"},
        {" --fit-orders 9", "--fit-orders"},
    };
    for (const auto& [args, message] : bad) {
        const RunResult b = cli(base + args + " --out " + path("bad") + " -q");
        EXPECT_EQ(b.exit_code, 2) << args << "\n" << b.output;
        EXPECT_NE(b.output.find(message), std::string::npos) << args << "\n" << b.output;
        EXPECT_FALSE(fs::exists(path("bad/pareto.csv"))) << args;
    }
    // A bad row of the points CSV names its line and column.
    {
        std::ofstream f(path("points.csv"), std::ios::app);
        f << "1.5,0.5,0.5,0.4,0,1\n";
    }
    const RunResult row = cli(base + " --out " + path("bad") + " -q");
    EXPECT_EQ(row.exit_code, 2) << row.output;
    EXPECT_NE(row.output.find("points.csv:50: column visibility"), std::string::npos) << row.output;
}

}  // namespace
