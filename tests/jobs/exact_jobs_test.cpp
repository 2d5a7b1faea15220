// The exact method in the jobs that integrate the term: sweeps, design reference sets, representation
// bakes and bake verification. For each: the exact run lies within the sampled run's error bars
// (Bonferroni-corrected two-sided Student-t bounds, the whole family wrong by chance with probability
// <= 0.001), its provenance names the method, and what one method cached or left to resume is never
// reused by the other.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "core/estimate.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "jobs/reference_set.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "jobs/verify.hpp"
#include "lut/exr_lut.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/representation.hpp"
#include "test_files.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;

constexpr double kFamilyRisk = 0.001;
constexpr std::uint32_t kReplicates = 8;

using ms::testing::slurp_file;

// The two-sided bound one of `n` comparisons may reach: Bonferroni over the family.
double family_t(std::size_t n) { return student_t_quantile(1.0 - kFamilyRisk / double(n), int(kReplicates) - 1); }

// Exact against sampled: |exact - sampled| <= t * se_sampled + the exact value's estimated error, and
// where the sampled value is exact (a provable 0 or 1, std error 0) the exact one equals it.
void expect_within_bars(const std::vector<Estimate>& exact, const std::vector<Estimate>& sampled, const std::string& what,
                        double claimed_error = 1e-9) {
    ASSERT_EQ(exact.size(), sampled.size()) << what;
    const double t = family_t(exact.size());
    std::size_t compared = 0;
    for (std::size_t i = 0; i < exact.size(); ++i) {
        // The exact method's error estimate is what it claims for each value: at most its tolerance.
        EXPECT_LE(exact[i].std_error, claimed_error) << what << " value " << i;
        const double bound = t * sampled[i].std_error + exact[i].std_error + 1e-12;
        EXPECT_LE(std::abs(exact[i].term - sampled[i].term), bound)
            << what << " value " << i << ": exact " << exact[i].term << ", sampled " << sampled[i].term << " +- "
            << sampled[i].std_error;
        compared += sampled[i].std_error > 0;
    }
    EXPECT_GT(compared, exact.size() / 3) << what << ": most values should be sampled, not trivially exact";
}

SamplingPlan sampled_plan(std::uint64_t samples = 4096) {
    SamplingPlan p;
    p.samples = samples;
    p.replicates = kReplicates;
    p.seed = 3;
    return p;
}

SamplingPlan exact_plan(double tolerance = 1e-10) {
    SamplingPlan p;
    p.method = Method::exact;
    p.tolerance = tolerance;
    return p;
}

class ExactJobsTest : public ms::testing::ScratchDirTest {
protected:
    ExactJobsTest() : ScratchDirTest("exact_jobs") {}
    TermBackend& oracle() {
        static auto b = make_oracle_backend(2);
        return *b;
    }
};

// ---------------------------------------------------------------------------------------------------
// Sweeps

const char* const kSweepSpec =
    "[sweep]\nname = \"exact\"\nchunk_size = 16\n"
    "[parameters]\nvisibility = [0.3, 0.6, 0.9]\nn_dot_l = [0.2, 0.5, 0.9]\nn_dot_v = [0.4, 1.0]\n"
    "roughness = [0.3, 0.7]\ndelta_phi = [0, 120]\n"
    "[comparators]\nanalytic = [\"reference-step\"]\n";

// The term and std_error columns of a sweep.csv.
std::vector<Estimate> sweep_values(const fs::path& csv) {
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);
    std::vector<std::string> header;
    {
        std::stringstream h(line);
        for (std::string f; std::getline(h, f, ',');) header.push_back(f);
    }
    const auto term = std::find(header.begin(), header.end(), "term") - header.begin();
    const auto se = std::find(header.begin(), header.end(), "std_error") - header.begin();
    std::vector<Estimate> out;
    while (std::getline(in, line)) {
        std::vector<std::string> f;
        std::stringstream r(line);
        for (std::string x; std::getline(r, x, ',');) f.push_back(x);
        out.push_back({std::stod(f[std::size_t(term)]), std::stod(f[std::size_t(se)])});
    }
    return out;
}

sweep::RunConfig sweep_config(const std::string& dir, const SamplingPlan& plan, TermBackend& backend) {
    sweep::RunConfig c;
    c.out_dir = dir;
    c.plan = plan;
    c.backend = &backend;
    return c;
}

TEST_F(ExactJobsTest, SweepExactAgreesWithSampledAndRecordsItsMethod) {
    const sweep::Spec spec = sweep::parse_spec(kSweepSpec, "s.toml");
    const sweep::RunResult e = sweep::run_sweep(spec, sweep_config(path("exact"), exact_plan(), oracle()));
    const sweep::RunResult s = sweep::run_sweep(spec, sweep_config(path("sampled"), sampled_plan(), oracle()));
    ASSERT_TRUE(e.assembled && s.assembled);
    EXPECT_EQ(e.points, 72u);
    expect_within_bars(sweep_values(path("exact") + "/sweep.csv"), sweep_values(path("sampled") + "/sweep.csv"), "sweep");

    const auto provenance = nlohmann::json::parse(slurp_file(path("exact") + "/sweep.json"));
    EXPECT_EQ(provenance.at("sampling").at("method"), "exact");
    EXPECT_EQ(provenance.at("sampling").at("tolerance"), 1e-10);
    EXPECT_NE(provenance.at("sampling").at("rule").get<std::string>().find("Gauss-Legendre"), std::string::npos);
    EXPECT_FALSE(provenance.at("sampling").contains("samples"));
    const auto sampled = nlohmann::json::parse(slurp_file(path("sampled") + "/sweep.json"));
    EXPECT_EQ(sampled.at("sampling").at("method"), "sampled");
    EXPECT_EQ(sampled.at("sampling").at("samples"), 4096);
}

TEST_F(ExactJobsTest, SweepOfOneMethodIsNeverResumedByTheOther) {
    const sweep::Spec spec = sweep::parse_spec(kSweepSpec, "s.toml");
    // Half of an exact sweep on disk (5 chunks of 16 points): a sampled run must not take its chunks, nor
    // an exact run of another tolerance; the same exact run resumes them.
    sweep::RunConfig exact = sweep_config(path("out"), exact_plan(), oracle());
    exact.max_chunks = 2;
    const sweep::RunResult part = sweep::run_sweep(spec, exact);
    ASSERT_FALSE(part.complete);
    EXPECT_THROW(sweep::run_sweep(spec, sweep_config(path("out"), sampled_plan(), oracle())), std::invalid_argument);
    EXPECT_THROW(sweep::run_sweep(spec, sweep_config(path("out"), exact_plan(1e-8), oracle())), std::invalid_argument);
    exact.max_chunks = 0;
    const sweep::RunResult rest = sweep::run_sweep(spec, exact);
    EXPECT_EQ(rest.skipped, 2u);
    EXPECT_TRUE(rest.assembled);
    // And the reverse: a finished sampled sweep is not answered for an exact run.
    const sweep::RunResult s = sweep::run_sweep(spec, sweep_config(path("s"), sampled_plan(), oracle()));
    ASSERT_TRUE(s.assembled);
    EXPECT_NE(s.spec_hash, rest.spec_hash);
    EXPECT_THROW(sweep::run_sweep(spec, sweep_config(path("s"), exact_plan(), oracle())), std::invalid_argument);
    // --restart (RunConfig::restart) recomputes it with the exact method.
    sweep::RunConfig again = sweep_config(path("s"), exact_plan(), oracle());
    again.restart = true;
    const sweep::RunResult redone = sweep::run_sweep(spec, again);
    EXPECT_EQ(redone.skipped, 0u);
    EXPECT_EQ(slurp_file(path("s") + "/sweep.csv"), slurp_file(path("out") + "/sweep.csv"));
}

TEST_F(ExactJobsTest, SweepSpecMethodKeys) {
    const std::string base = "[parameters]\nvisibility = 0.5\nn_dot_l = 0.5\nroughness = 0.5\n";
    const sweep::Spec none = sweep::parse_spec(base, "s.toml");
    EXPECT_FALSE(none.method.has_value());
    const sweep::Spec exact = sweep::parse_spec("[sampling]\nmethod = \"exact\"\ntolerance = 1e-9\n" + base, "s.toml");
    EXPECT_EQ(exact.method, Method::exact);
    EXPECT_EQ(exact.tolerance, 1e-9);
    EXPECT_EQ(sweep::parse_spec("[sampling]\nmethod = \"sampled\"\n" + base, "s.toml").method, Method::sampled);
    for (const char* bad : {"method = \"quadrature\"", "method = 1", "tolerance = 0", "tolerance = 1.0", "tolerance = \"small\""}) {
        try {
            sweep::parse_spec(std::string("[sampling]\n") + bad + "\n" + base, "s.toml");
            ADD_FAILURE() << bad << " was accepted";
        } catch (const sweep::SpecError& e) {
            const std::string key = std::string(bad).substr(0, std::string(bad).find(' '));
            EXPECT_NE(std::string(e.what()).find("s.toml"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("sampling." + key), std::string::npos) << e.what();
        }
    }
}

TEST_F(ExactJobsTest, SweepCommandDefaultsToExactAndRefusesATolerancedSampledSweep) {
    {
        std::ofstream(path("s.toml")) << "[sweep]\nchunk_size = 8\n[parameters]\nvisibility = [0.5, 0.8]\nn_dot_l = [0.3, 0.7]\n"
                                         "roughness = [0.5]\n";
    }
    const std::string cli = std::string("cd '") + dir_.string() + "' && '" + MICROSHADOW_CLI + "' ";
    const auto ok = ms::testing::run_shell(cli + "sweep s.toml --out e --backend oracle -q");
    ASSERT_EQ(ok.exit_code, 0) << ok.output;
    EXPECT_EQ(nlohmann::json::parse(slurp_file(path("e/sweep.json"))).at("sampling").at("method"), "exact");
    const auto s = ms::testing::run_shell(cli + "sweep s.toml --out s --backend oracle --method sampled --samples 1024 -q");
    ASSERT_EQ(s.exit_code, 0) << s.output;
    EXPECT_EQ(nlohmann::json::parse(slurp_file(path("s/sweep.json"))).at("sampling").at("method"), "sampled");
    // The spec's key is the default; the command line wins over it.
    {
        std::ofstream(path("k.toml")) << "[sampling]\nmethod = \"sampled\"\nsamples = 1024\n[sweep]\nchunk_size = 8\n"
                                         "[parameters]\nvisibility = [0.5, 0.8]\nn_dot_l = [0.3, 0.7]\nroughness = [0.5]\n";
    }
    ASSERT_EQ(ms::testing::run_shell(cli + "sweep k.toml --out k --backend oracle -q").exit_code, 0);
    EXPECT_EQ(nlohmann::json::parse(slurp_file(path("k/sweep.json"))).at("sampling").at("method"), "sampled");
    ASSERT_EQ(ms::testing::run_shell(cli + "sweep k.toml --out k2 --backend oracle --method exact -q").exit_code, 0);
    EXPECT_EQ(nlohmann::json::parse(slurp_file(path("k2/sweep.json"))).at("sampling").at("method"), "exact");
    const auto bad = ms::testing::run_shell(cli + "sweep s.toml --out t --backend oracle --method sampled --tolerance 1e-3 -q 2>&1");
    EXPECT_EQ(bad.exit_code, 2) << bad.output;
    EXPECT_NE(bad.output.find("--tolerance"), std::string::npos) << bad.output;
    EXPECT_FALSE(fs::exists(path("t")));
}

// ---------------------------------------------------------------------------------------------------
// Design reference sets

design::ReferenceDefinition small_reference(const SamplingPlan& plan) {
    design::ReferenceDefinition d;
    d.name = "small";
    d.count = 40;
    d.plan = plan;
    d.backend_label = "oracle";
    return d;
}

TEST_F(ExactJobsTest, ReferenceSetExactAgreesWithSampledAndIsAnotherCache) {
    design::CacheConfig config;
    config.dir = path("cache");
    config.backend = &oracle();
    config.chunk_points = 16;
    const design::ReferenceDefinition exact_def = small_reference(exact_plan());
    const design::ReferenceDefinition sampled_def = small_reference(sampled_plan());
    EXPECT_NE(exact_def.hash(), sampled_def.hash());
    EXPECT_NE(exact_def.hash(), small_reference(exact_plan(1e-8)).hash());
    design::CacheReport first, second;
    const design::ReferenceSet exact = design::load_or_compute(exact_def, config, &first);
    EXPECT_FALSE(first.from_cache);
    // The exact set cached, the sampled definition is computed, not answered by it.
    const design::ReferenceSet sampled = design::load_or_compute(sampled_def, config, &second);
    EXPECT_FALSE(second.from_cache);
    EXPECT_NE(exact.file, sampled.file);
    expect_within_bars(exact.values, sampled.values, "reference set");
    EXPECT_LE(exact.max_std_error, 1e-9);

    const auto meta = nlohmann::json::parse(slurp_file(fs::path(exact.file).replace_extension(".json")));
    EXPECT_EQ(meta.at("method"), "exact");
    EXPECT_EQ(meta.at("exact").at("tolerance"), 1e-10);
    EXPECT_NE(meta.at("definition").get<std::string>().find("\"plan.method\":\"exact\""), std::string::npos);
    EXPECT_EQ(nlohmann::json::parse(slurp_file(fs::path(sampled.file).replace_extension(".json"))).at("method"), "sampled");
    // Loaded again, each from its own file, bit for bit.
    design::CacheReport third;
    const design::ReferenceSet again = design::load_or_compute(exact_def, config, &third);
    EXPECT_TRUE(third.from_cache);
    for (std::size_t i = 0; i < again.values.size(); ++i) EXPECT_EQ(again.values[i].term, exact.values[i].term);
}

TEST_F(ExactJobsTest, ReferenceSpecDefaultsToExactAndReadsItsMethod) {
    const std::string points = "[points]\ncount = 8\n";
    const design::ReferenceDefinition plain = design::parse_reference_spec(points, "r.toml", ".");
    EXPECT_EQ(plain.plan.method, Method::exact);
    EXPECT_NO_THROW(design::check_plan(plain));
    const auto sampled = design::parse_reference_spec(points + "[sampling]\nmethod = \"sampled\"\nsamples = 1024\n", "r.toml", ".");
    EXPECT_EQ(sampled.plan.method, Method::sampled);
    EXPECT_EQ(sampled.plan.samples, 1024u);
    const auto tight = design::parse_reference_spec(points + "[sampling]\ntolerance = 1e-12\n", "r.toml", ".");
    EXPECT_EQ(tight.plan.tolerance, 1e-12);
    EXPECT_NE(tight.hash(), plain.hash());
    for (const char* bad : {"method = \"mc\"", "tolerance = 0.5", "method = \"sampled\"\ntolerance = 1e-3"}) {
        try {
            design::parse_reference_spec(points + "[sampling]\n" + bad + "\n", "r.toml", ".");
            ADD_FAILURE() << bad << " was accepted";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("r.toml"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("sampling."), std::string::npos) << e.what();
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// Representation bakes

repr::AzimuthBakeSpec small_repr(const SamplingPlan& plan) {
    repr::AzimuthBakeSpec spec;
    spec.grid.visibility = 4, spec.grid.n_dot_l = 3, spec.grid.n_dot_v = 2, spec.grid.roughness = {0.4, 0.8};
    spec.azimuth_nodes = 3;
    spec.plan = plan;
    return spec;
}

TEST_F(ExactJobsTest, ReprBakeExactAgreesWithSampledAndRecordsItsMethod) {
    const repr::AzimuthBake exact = repr::bake_azimuth(small_repr(exact_plan()), oracle());
    const repr::AzimuthBake sampled = repr::bake_azimuth(small_repr(sampled_plan()), oracle());
    ASSERT_EQ(exact.value.size(), 144u);  // 2 roughness x 3 nodes x 4 x 3 x 2 texels
    std::vector<Estimate> e, s;
    for (std::size_t i = 0; i < exact.value.size(); ++i) {
        // Stored as float: the exact value is rounded by half an ulp, which its error now includes.
        EXPECT_LE(exact.std_error[i], 1e-9f) << i;
        e.push_back({exact.value[i], double(exact.std_error[i]) + 6e-8});
        s.push_back({sampled.value[i], sampled.std_error[i]});
    }
    expect_within_bars(e, s, "repr bake", 1e-7);
    EXPECT_EQ(exact.metadata.at("method"), "exact");
    EXPECT_EQ(exact.metadata.at("exact").at("method"), "exact");
    EXPECT_FALSE(exact.metadata.contains("samples"));
    EXPECT_EQ(sampled.metadata.at("method"), "sampled");
    EXPECT_EQ(sampled.metadata.at("samples"), 4096);
}

TEST_F(ExactJobsTest, ReprBakeCommandWritesTheMethodIntoTheFile) {
    const std::string cli = std::string("cd '") + dir_.string() + "' && '" + MICROSHADOW_CLI + "' ";
    const std::string grid = " --kind azimuth-axis --visibility-count 3 --n-dot-l-count 3 --n-dot-v-count 2 --roughness 0.5 --azimuth-nodes 3 "
                             "--backend oracle -q --out ";
    const auto e = ms::testing::run_shell(cli + "repr bake" + grid + "e.exr && '" + MICROSHADOW_CLI + "' repr info e.exr --json 2>&1");
    ASSERT_EQ(e.exit_code, 0) << e.output;
    EXPECT_NE(e.output.find("\"method\": \"exact\""), std::string::npos) << e.output;
    const auto s = ms::testing::run_shell(cli + "repr bake" + grid + "s.exr --method sampled --samples 1024 && '" + MICROSHADOW_CLI +
                                      "' repr info s.exr --json 2>&1");
    ASSERT_EQ(s.exit_code, 0) << s.output;
    EXPECT_NE(s.output.find("\"method\": \"sampled\""), std::string::npos) << s.output;
}

// ---------------------------------------------------------------------------------------------------
// Bake verification

BakeSpec small_bake(std::uint32_t azimuth_intervals) {
    BakeSpec s = default_bake_spec(LutLayout::custom, 4);
    s.visibility.count = 6;
    s.n_dot_l.count = 5;
    s.n_dot_v.count = 3;
    s.roughness = {0.4, 0.8};
    s.samples = 4096;
    s.replicates = kReplicates;
    s.azimuth_intervals = azimuth_intervals;
    s.seed = 13;
    s.backend.kind = schedule::Backend::Kind::oracle;
    s.backend.threads = 2;
    return s;
}

TEST_F(ExactJobsTest, VerifyAgainstTheExactMethodPassesARightBakeAndFailsAShiftedOne) {
    for (std::uint32_t intervals : {2u, 0u}) {  // a fixed K, and the adaptive default (rows at several K)
        const BakeSpec spec = small_bake(intervals);
        const BakeResult result = bake_lut(spec);
        const BakeVerification exact = verify_bake(spec, result, 16, 0, 2, Method::exact);
        EXPECT_EQ(exact.reference, Method::exact);
        EXPECT_EQ(exact.checked, 16u);
        EXPECT_EQ(exact.failed, 0u) << "intervals " << intervals << ": " << exact.worst_texel;
        EXPECT_LE(exact.max_reference_error, 1e-9);
        // The sampled verification is still there and agrees.
        const BakeVerification sampled = verify_bake(spec, result, 16, 0, 2, Method::sampled);
        EXPECT_EQ(sampled.reference, Method::sampled);
        EXPECT_EQ(sampled.failed, 0u) << sampled.worst_texel;

        // Every sampled texel moved by 3 t of its own error bar: the bake's own error is within t of them
        // (family risk 0.001), so each is now at least 2 t away from the exact value and must fail.
        BakeResult shifted = result;
        for (std::size_t i = 0; i < shifted.value.size(); ++i)
            if (shifted.std_error[i] > 0) {
                const double move = 3 * exact.threshold * shifted.std_error[i];
                shifted.value[i] += float(shifted.value[i] > 0.5 ? -move : move);
            }
        const BakeVerification caught = verify_bake(spec, shifted, 16, 0, 2, Method::exact);
        EXPECT_EQ(caught.failed, caught.checked) << "intervals " << intervals;
    }
}

TEST_F(ExactJobsTest, BakeCommandRecordsTheVerificationMethod) {
    const std::string cli = std::string("cd '") + dir_.string() + "' && '" + MICROSHADOW_CLI + "' ";
    const auto r = ms::testing::run_shell(cli + "bake --layout custom --size 4 --roughness 0.5 --samples 4096 --verify 8 -q "
                                            "--out b.exr && '" + MICROSHADOW_CLI + "' bake --layout custom --size 4 "
                                            "--roughness 0.5 --samples 4096 --verify 8 --verify-method sampled -q --out s.exr");
    if (r.exit_code != 0 && r.output.find("OpenCL") != std::string::npos) GTEST_SKIP() << "no OpenCL device: " << r.output;
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const LutFile exact = read_lut(path("b.exr")), sampled = read_lut(path("s.exr"));
    EXPECT_EQ(exact.metadata.at("verify").at("method"), "exact");
    EXPECT_EQ(exact.metadata.at("verify").at("failed"), 0);
    EXPECT_EQ(exact.metadata.at("verify").at("texels"), 8);
    EXPECT_EQ(sampled.metadata.at("verify").at("method"), "sampled");
}

}  // namespace
