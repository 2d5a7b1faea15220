// The one cache key of every resumable job (schedule/cache_key.hpp): for bake, scene, repr bake,
// sweep and the design reference set, every option that decides a bit moves the key, and the key
// holds no option this test does not change (so an option added to a key without a test, or a test
// of an option the key dropped, fails here). The options a key leaves out are listed by the job with
// the reason. And a sweep resumed with --double-kernels is refused instead of mixing two precisions.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>

#include "cli_runner.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "jobs/reference_set.hpp"
#include "jobs/repr_bake.hpp"
#include "jobs/scene.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "scene/description.hpp"
#include "scene/image_io.hpp"
#include "scene/inputs.hpp"
#include "platform/process.hpp"
#include "schedule/cache_key.hpp"
#include "schedule/source_fingerprint.hpp"

namespace ms {
namespace {

using testing::ScratchDirTest;

// A change of one option: its name is "KEY-NAME" or "KEY-NAME/detail" (several changes of one key entry:
// the fields of an axis, say), and `apply` makes it on a copy of the options.
template <class Options>
using Changes = std::map<std::string, std::function<void(Options&)>>;

// Every change moves the key away from the base and from every other change, and the base key's
// options are exactly those the changes name.
template <class Options>
void expect_every_option_moves_the_key(const std::string& job, const Options& base,
                                       const std::function<schedule::CacheKey(const Options&)>& key_of,
                                       const Changes<Options>& changes) {
    const schedule::CacheKey base_key = key_of(base);
    EXPECT_EQ(base_key.job(), job);
    std::map<std::string, std::string> seen{{base_key.hash(), "(none)"}};
    std::set<std::string> changed;
    for (const auto& [name, apply] : changes) {
        Options changed_options = base;
        apply(changed_options);
        const std::string hash = key_of(changed_options).hash();
        const auto [it, fresh] = seen.emplace(hash, name);
        EXPECT_TRUE(fresh) << job << ": changing " << name << " gives the key of " << it->second;
        changed.insert(name.substr(0, name.find('/')));
    }
    for (const std::string& option : base_key.names())
        EXPECT_TRUE(changed.count(option)) << job << ": the key holds '" << option << "', which no change here moves";
}

ocl::BuildConfig doubled() {
    ocl::BuildConfig b;
    b.double_precision = true;
    return b;
}

// A backend of the oracle whose kernels' build differs (the oracle ignores the build, the key does not:
// it stands for a device backend built with --fast-math, --double-kernels or -D).
std::unique_ptr<TermBackend> oracle_with(const ocl::BuildConfig& build) {
    term::RoutineConfig config;
    config.build = build;
    return std::make_unique<TermBackend>(schedule::Backend::oracle(1), config);
}

// The options every key takes from a backend: its kernels' build and its kind of place.
template <class Options>
void add_backend_changes(Changes<Options>& changes, std::unique_ptr<TermBackend>& backend) {
    auto with = [&backend](ocl::BuildConfig build) {
        return [&backend, build](Options&) { backend = oracle_with(build); };
    };
    ocl::BuildConfig fast, defined;
    fast.fast_math = true;
    defined.defines["MS_TEST"] = "1";
    changes["build.fast_math"] = with(fast);
    changes["build.double_precision"] = with(doubled());
    changes["build.defines"] = with(defined);
    changes["results"] = [&backend](Options&) {
        backend = std::make_unique<TermBackend>(schedule::Backend::opencl(ocl::select_devices("default")));
    };
}

TEST(CacheKey, RefusesAnOptionAddedTwiceAndDigestsFilesByTheirBytes) {
    schedule::CacheKey key("job");
    key.add("a", 1);
    EXPECT_THROW(key.add("a", 2), std::logic_error);
    EXPECT_EQ(key.names(), std::vector<std::string>{"a"});
    // Values that differ in the last bit are two keys.
    EXPECT_NE(schedule::CacheKey("job").add("x", 0.1).hash(), schedule::CacheKey("job").add("x", std::nextafter(0.1, 1.0)).hash());
    EXPECT_NE(schedule::CacheKey("job").hash(), schedule::CacheKey("other").hash());
    EXPECT_THROW(schedule::CacheKey("job").add_file("f", "/nonexistent/microshadow/file"), std::runtime_error);
}

// Every key holds the version and the fingerprint of the sources (16 hex digits), so that a store
// begun by other code under the same version number is not resumed.
TEST(CacheKey, HoldsTheVersionAndTheSourcesFingerprint) {
    const std::string fingerprint = schedule::source_fingerprint();
    ASSERT_EQ(fingerprint.size(), 16u);
    EXPECT_EQ(fingerprint.find_first_not_of("0123456789abcdef"), std::string::npos) << fingerprint;
    const std::string text = schedule::CacheKey("job").canonical_text();
    EXPECT_NE(text.find(std::string(MICROSHADOW_VERSION) + "+" + fingerprint), std::string::npos) << text;
}

// Kernels read from $MICROSHADOW_KERNEL_DIR (the development switch) are not the build's: their bytes
// enter the key, so an edited kernel moves it; without the switch the key holds no such field.
class CacheKeyKernelDir : public ScratchDirTest {
protected:
    CacheKeyKernelDir() : ScratchDirTest("cache_key_kernel_dir") {}
    void TearDown() override {
        platform::set_environment("MICROSHADOW_KERNEL_DIR", "");
        ScratchDirTest::TearDown();
    }
};

TEST_F(CacheKeyKernelDir, KernelsFromAFolderEnterTheKeyByTheirBytes) {
    if (const char* set = std::getenv("MICROSHADOW_KERNEL_DIR"); set && *set)
        GTEST_SKIP() << "MICROSHADOW_KERNEL_DIR is set for this run; the test needs the embedded kernels";
    const std::string embedded = schedule::CacheKey("job").hash();
    EXPECT_EQ(schedule::CacheKey("job").canonical_text().find("$kernels"), std::string::npos);
    platform::set_environment("MICROSHADOW_KERNEL_DIR", dir_.string());
    const std::string empty_folder = schedule::CacheKey("job").hash();
    EXPECT_NE(empty_folder, embedded);
    std::filesystem::create_directories(dir_ / "exact");
    std::ofstream(path("exact/exact_term.cl")) << "/* an edited kernel */\n";
    const std::string edited = schedule::CacheKey("job").hash();
    EXPECT_NE(edited, empty_folder);
    EXPECT_EQ(schedule::CacheKey("job").hash(), edited);  // the same bytes, the same key
    platform::set_environment("MICROSHADOW_KERNEL_DIR", "");
    EXPECT_EQ(schedule::CacheKey("job").hash(), embedded);
}

TEST(CacheKey, BakeMovesWithEveryOptionThatDecidesASlice) {
    auto backend = oracle_with({});
    const BakeSpec base = default_bake_spec(LutLayout::seed_3d, 8);
    Changes<BakeSpec> c;
    for (const char* axis : {"visibility", "n_dot_l", "n_dot_v"}) {
        auto of = [axis](BakeSpec& s) -> Axis& {
            return std::string(axis) == "visibility" ? s.visibility : std::string(axis) == "n_dot_l" ? s.n_dot_l : s.n_dot_v;
        };
        const std::string name = std::string("axis.") + axis;
        c[name + "/min"] = [of](BakeSpec& s) { of(s).min = 0.25; };
        c[name + "/max"] = [of](BakeSpec& s) { of(s).max = 0.75; };
        c[name + "/count"] = [of](BakeSpec& s) { of(s).count = 9; };
        c[name + "/texel"] = [of](BakeSpec& s) { of(s).texel = TexelConvention::endpoints; };
        c[name + "/spacing"] = [of](BakeSpec& s) { of(s).spacing = Spacing::log; };
    }
    c["layout"] = [](BakeSpec& s) { s.layout = LutLayout::custom; };
    c["roughness"] = [](BakeSpec& s) { s.roughness = {0.5}; };
    c["azimuth_mean"] = [](BakeSpec& s) { s.azimuth_mean = false; };
    c["azimuth_degrees"] = [](BakeSpec& s) { s.azimuth_degrees = 30; };
    c["azimuth_intervals"] = [](BakeSpec& s) { s.azimuth_intervals = 8; };
    c["azimuth_min_intervals"] = [](BakeSpec& s) { s.azimuth_min_intervals = 2; };
    c["azimuth_max_intervals"] = [](BakeSpec& s) { s.azimuth_max_intervals = 64; };
    c["azimuth_refine_threshold"] = [](BakeSpec& s) { s.azimuth_refine_threshold = 2e-4; };
    c["azimuth_refine_z"] = [](BakeSpec& s) { s.azimuth_refine_z = 2; };
    c["azimuth_quadrature"] = [](BakeSpec& s) { s.azimuth_quadrature = AzimuthQuadrature::stratified; };
    c["azimuth_cells"] = [](BakeSpec& s) { s.azimuth_cells = 16; };
    c["sequence"] = [](BakeSpec& s) { s.sequence = Sequence::random; };
    c["replicates"] = [](BakeSpec& s) { s.replicates = 4; };
    c["samples"] = [](BakeSpec& s) { s.samples = 4096; };
    c["seed"] = [](BakeSpec& s) { s.seed = 7; };
    c["tolerance"] = [](BakeSpec& s) { s.tolerance = 1e-3; };
    c["max_batches"] = [](BakeSpec& s) { s.max_batches = 8; };
    c["method"] = [](BakeSpec& s) { s.method = Method::exact; };
    c["exact_single_precision"] = [](BakeSpec& s) { s.exact_single_precision = true; };
    c["exact_kernel_on_cpu"] = [](BakeSpec& s) { s.exact_kernel_on_cpu = true; };
    c["baked_rows/count"] = [](BakeSpec& s) { s.baked_rows.assign(std::size_t(s.n_dot_l.count) * 8 * 4, 1); };
    c["baked_rows/flags"] = [](BakeSpec& s) {
        s.baked_rows.assign(std::size_t(s.n_dot_l.count) * 8 * 4, 1);
        s.baked_rows[3] = 0;
    };
    c["oracle"] = [](BakeSpec& s) { s.backend.kind = schedule::Backend::Kind::oracle; };
    c["term.form"] = [](BakeSpec& s) { s.term.form = Form::uncorrelated; };
    c["term.ao_weighting"] = [](BakeSpec& s) { s.term.ao_weighting = AoWeighting::uniform; };
    c["build.fast_math"] = [](BakeSpec& s) { s.build.fast_math = true; };
    c["build.double_precision"] = [](BakeSpec& s) { s.build.double_precision = true; };
    c["build.defines"] = [](BakeSpec& s) { s.build.defines["MS_TEST"] = "1"; };
    std::unique_ptr<TermBackend> opencl;
    c["results"] = [&opencl](BakeSpec&) {
        opencl = std::make_unique<TermBackend>(schedule::Backend::opencl(ocl::select_devices("default")));
    };
    expect_every_option_moves_the_key<BakeSpec>(
        "bake", base,
        [&](const BakeSpec& s) {
            schedule::CacheKey key = bake_cache_key(s, (opencl ? *opencl : *backend).scheduler());
            opencl.reset();
            return key;
        },
        c);
    // Where it runs and what the command line was leave the key as it is (bake_cache_key_exclusions).
    BakeSpec elsewhere = base;
    elsewhere.backend.device = "all";
    elsewhere.backend.threads = 3;
    elsewhere.command_line = "microshadow bake --size 8";
    EXPECT_EQ(bake_cache_key(elsewhere, backend->scheduler()).hash(), bake_cache_key(base, backend->scheduler()).hash());
    EXPECT_EQ(bake_cache_key_exclusions().size(), 3u);
}

// The sampling plan and term options every plan-driven key (repr, sweep, reference set) takes.
template <class Options>
void add_plan_changes(Changes<Options>& c, const std::function<SamplingPlan&(Options&)>& plan,
                      const std::function<TermOptions&(Options&)>& term) {
    c["plan.method"] = [plan](Options& o) { plan(o).method = plan(o).method == Method::exact ? Method::sampled : Method::exact; };
    c["plan.samples"] = [plan](Options& o) { plan(o).samples *= 2; };
    c["plan.replicates"] = [plan](Options& o) { plan(o).replicates = 4; };
    c["plan.seed"] = [plan](Options& o) { plan(o).seed = 11; };
    c["plan.sequence"] = [plan](Options& o) { plan(o).sequence = Sequence::random; };
    c["plan.tolerance"] = [plan](Options& o) { plan(o).tolerance = 1e-7; };
    // The exact rule a tolerance selects (a coarser one at 1e-4 than at the default 1e-10).
    c["plan.exact_rule/with the tolerance"] = [plan](Options& o) { plan(o).tolerance = 1e-4; };
    // The azimuth means' pair (8 Gauss nodes from 1e-8 up, 12 below).
    c["plan.exact_azimuth_rule/with the tolerance"] = [plan](Options& o) { plan(o).tolerance = 1e-8; };
    c["plan.single_precision"] = [plan](Options& o) { plan(o).single_precision = true; };
    c["plan.kernel_on_cpu_devices"] = [plan](Options& o) { plan(o).kernel_on_cpu_devices = true; };
    c["term.form"] = [term](Options& o) { term(o).form = Form::uncorrelated; };
    c["term.ao_weighting"] = [term](Options& o) { term(o).ao_weighting = AoWeighting::uniform; };
}

SamplingPlan exact_plan() {
    SamplingPlan p;
    p.method = Method::exact;
    return p;
}

TEST(CacheKey, ReprBakeMovesWithEveryOptionThatDecidesATexel) {
    std::unique_ptr<TermBackend> backend = oracle_with({});
    repr::AzimuthBakeSpec base;
    base.plan = exact_plan();
    Changes<repr::AzimuthBakeSpec> c;
    using S = repr::AzimuthBakeSpec;
    c["grid.visibility"] = [](S& s) { s.grid.visibility = 8; };
    c["grid.n_dot_l"] = [](S& s) { s.grid.n_dot_l = 8; };
    c["grid.n_dot_v"] = [](S& s) { s.grid.n_dot_v = 8; };
    c["grid.roughness"] = [](S& s) { s.grid.roughness = {0.5}; };
    c["grid.warps/n_dot_v"] = [](S& s) { s.grid.warps.n_dot_v = repr::parse_n_dot_v_warp("sqrt"); };
    c["grid.warps/n_dot_l"] = [](S& s) { s.grid.warps.n_dot_l = repr::NdotLWarp::shadow_edge; };
    c["grid.warps/visibility"] = [](S& s) { s.grid.warps.visibility = repr::VisibilityWarp::sqrt_top; };
    c["grid.weighting"] = [](S& s) { s.grid.weighting = AoWeighting::uniform; };
    c["grid.edge_width"] = [](S& s) { s.grid.edge_width = 3; };
    c["grid.placement"] = [](S& s) { s.grid.placement = repr::TexelPlacement::ends; };
    c["grid.n_dot_v_start"] = [](S& s) { s.grid.n_dot_v_start = 0.1; };
    c["grid.azimuth_warp"] = [](S& s) { s.grid.azimuth_warp = 0.5; };
    c["grid.visibility_start"] = [](S& s) { s.grid.visibility_start = 0.2; };
    c["grid.visibility_edge_share"] = [](S& s) { s.grid.visibility_edge_share = 0.3; };
    c["grid.visibility_edge_width"] = [](S& s) { s.grid.visibility_edge_width = 0.6; };
    c["grid.visibility_edge_view"] = [](S& s) { s.grid.visibility_edge_view = 0.3; };
    c["grid.n_dot_l_edge_view"] = [](S& s) { s.grid.n_dot_l_edge_view = 0.2; };
    c["azimuth_nodes"] = [](S& s) { s.azimuth_nodes = 7; };
    add_plan_changes<S>(c, [](S& s) -> SamplingPlan& { return s.plan; }, [](S& s) -> TermOptions& { return s.term; });
    add_backend_changes(c, backend);
    expect_every_option_moves_the_key<S>(
        "repr-bake", base,
        [&](const S& s) {
            schedule::CacheKey key = repr::repr_cache_key(s, *backend);
            backend = oracle_with({});
            return key;
        },
        c);
    S described = base;
    described.command_line = "microshadow repr bake";
    EXPECT_EQ(repr::repr_cache_key(described, *backend).hash(), repr::repr_cache_key(base, *backend).hash());
    EXPECT_EQ(repr::repr_cache_key_exclusions().size(), 1u);
}

class SweepCacheKey : public ScratchDirTest {
protected:
    SweepCacheKey() : ScratchDirTest("sweep_cache_key") {}
};

// The sweep's options: its spec and its run (the backend set per key, see below).
struct SweepOptions {
    sweep::Spec spec;
    sweep::RunConfig run;
};

TEST_F(SweepCacheKey, MovesWithEveryOptionThatDecidesAPoint) {
    std::ofstream(path("a.exr")) << "bytes of a LUT";
    std::ofstream(path("b.exr")) << "bytes of another LUT";
    std::unique_ptr<TermBackend> backend = oracle_with({});
    SweepOptions base;
    base.spec = sweep::parse_spec("[parameters]\nvisibility = [0.5]\nn_dot_l = [0.5]\nroughness = [0.5]\n[comparators]\nanalytic = [\"pz-analytic\"]\n"
                                  "[[comparators.lut]]\nname = \"a\"\nfile = \"a.exr\"\n",
                                  "s.toml", dir_.string());
    base.run.plan = exact_plan();
    using O = SweepOptions;
    Changes<O> c;
    c["visibility"] = [](O& o) { o.spec.visibility = {0.25}; };
    c["n_dot_l"] = [](O& o) { o.spec.n_dot_l = {0.25}; };
    c["n_dot_v"] = [](O& o) { o.spec.n_dot_v = {0.25}; };
    c["by_roughness"] = [](O& o) { o.spec.by_roughness = false; };
    c["roughness"] = [](O& o) { o.spec.roughness = {0.25}; };
    c["alpha_x"] = [](O& o) { o.spec.alpha_x = {0.25}; };
    c["alpha_y"] = [](O& o) { o.spec.alpha_y = {0.25}; };
    c["phi_i"] = [](O& o) { o.spec.phi_i = {10}; };
    c["relative_azimuth"] = [](O& o) { o.spec.relative_azimuth = false; };
    c["phi_o_or_delta"] = [](O& o) { o.spec.phi_o_or_delta = {10}; };
    c["forms"] = [](O& o) { o.spec.forms = {Form::uncorrelated}; };
    c["weightings"] = [](O& o) { o.spec.weightings = {AoWeighting::uniform}; };
    c["analytic"] = [](O& o) { o.spec.analytic = {analytic::parse_analytic_term("naughty-dog")}; };
    c["luts.0.name"] = [](O& o) { o.spec.luts[0].name = "renamed"; };
    c["luts.0.file"] = [this](O& o) { o.spec.luts[0].file = path("b.exr"); };
    c["luts.0.preset/instead of a file"] = [](O& o) {
        o.spec.luts[0].file.clear();
        o.spec.luts[0].preset = "full-range";
    };
    c["luts.1/a second"] = [](O& o) { o.spec.luts.push_back({"again", o.spec.luts[0].file, ""}); };
    c["chunk_size"] = [](O& o) { o.spec.chunk_size = 16; };
    add_plan_changes<O>(c, [](O& o) -> SamplingPlan& { return o.run.plan; }, [](O& o) -> TermOptions& { return o.run.defaults; });
    add_backend_changes(c, backend);
    expect_every_option_moves_the_key<O>(
        "sweep", base,
        [&](const O& o) {
            sweep::RunConfig run = o.run;
            run.backend = backend.get();
            schedule::CacheKey key = sweep::sweep_cache_key(o.spec, run);
            backend = oracle_with({});
            return key;
        },
        c);
    // The options the key leaves out (sweep_cache_key_exclusions) leave it as it is.
    O other = base;
    other.spec.name = "renamed study";
    other.spec.source = "elsewhere.toml";
    other.spec.max_points = 7;
    other.spec.samples = 99;
    other.run.out_dir = path("elsewhere");
    other.run.command_line = "microshadow sweep";
    other.run.shard = {1, 2};
    other.run.max_chunks = 3;
    other.run.restart = true;
    other.run.strict_domain = true;
    base.run.backend = other.run.backend = backend.get();
    EXPECT_EQ(sweep::sweep_cache_key(other.spec, other.run).hash(), sweep::sweep_cache_key(base.spec, base.run).hash());
}

TEST_F(SweepCacheKey, AResumeWithDoubleKernelsIsRefusedNotMixed) {
    // Half of a sweep on disk computed with float kernels; the same command with --double-kernels would
    // append chunks of the other precision. It is refused (bad input, nothing written), and with restart
    // it starts over.
    const sweep::Spec spec = sweep::parse_spec("[sweep]\nchunk_size = 2\n[parameters]\nvisibility = [0.3, 0.6]\n"
                                               "n_dot_l = [0.4, 0.8]\nroughness = [0.5]\n",
                                               "s.toml");
    auto single = oracle_with({}), twice = oracle_with(doubled());
    sweep::RunConfig run;
    run.out_dir = path("out");
    run.plan = exact_plan();
    run.backend = single.get();
    run.max_chunks = 1;
    const sweep::RunResult part = sweep::run_sweep(spec, run);
    ASSERT_FALSE(part.complete);
    run.max_chunks = 0;
    run.backend = twice.get();
    EXPECT_THROW(sweep::run_sweep(spec, run), std::invalid_argument);
    run.restart = true;
    const sweep::RunResult redone = sweep::run_sweep(spec, run);
    EXPECT_EQ(redone.skipped, 0u);
    EXPECT_TRUE(redone.assembled);
    EXPECT_NE(redone.spec_hash, part.spec_hash);
}

TEST(CacheKey, ReferenceSetMovesWithEveryOptionThatDecidesAValue) {
    using D = design::ReferenceDefinition;
    D base;
    base.plan = exact_plan();
    Changes<D> c;
    c["visibility/lo"] = [](D& d) { d.visibility.lo = 0.4; };
    c["visibility/hi"] = [](D& d) { d.visibility.hi = 0.9; };
    c["roughness"] = [](D& d) { d.roughness.lo = 0.4; };
    c["n_dot_v"] = [](D& d) { d.n_dot_v.hi = 0.9; };
    c["n_dot_l"] = [](D& d) { d.n_dot_l.lo = 0.1; };
    c["azimuth_deg"] = [](D& d) { d.azimuth_deg.hi = 90; };
    c["count"] = [](D& d) { d.count = 100; };
    c["point_seed"] = [](D& d) { d.point_seed = 2; };
    c["csv_points/count"] = [](D& d) { d.csv_points.push_back({0.5, 0.5, 0.5, 0.5, 0, 1}); };
    c["csv_points/values"] = [](D& d) { d.csv_points.push_back({0.5, 0.5, 0.5, 0.5, 1, 1}); };
    c["results"] = [](D& d) { d.backend_label = "oracle"; };
    c["build.fast_math"] = [](D& d) { d.build.fast_math = true; };
    c["build.double_precision"] = [](D& d) { d.build.double_precision = true; };
    c["build.defines"] = [](D& d) { d.build.defines["MS_TEST"] = "1"; };
    add_plan_changes<D>(c, [](D& d) -> SamplingPlan& { return d.plan; }, [](D& d) -> TermOptions& { return d.options; });
    expect_every_option_moves_the_key<D>("design-reference", base, [](const D& d) { return d.cache_key(); }, c);
    D renamed = base;
    renamed.name = "other";
    renamed.points_csv = "points.csv";
    EXPECT_EQ(renamed.hash(), base.hash());
    EXPECT_EQ(D::cache_key_exclusions().size(), 2u);
}

class SceneCacheKey : public ScratchDirTest {
protected:
    SceneCacheKey() : ScratchDirTest("scene_cache_key") {}
};

TEST_F(SceneCacheKey, MovesWithEveryOptionThatDecidesAnItem) {
    std::vector<float> ao(16, 0.5f);
    scene::write_exr(path("ao.exr"), 4, 4, {{"ao", ao.data()}});
    std::ofstream(path("x.exr")) << "bytes of a LUT";
    std::ofstream(path("y.exr")) << "bytes of another LUT";
    const std::string scene_text = "[normal]\nvalue = [0, 0, 1]\n[visibility]\nfile = \"ao.exr\"\nchannel = \"ao\"\n"
                                   "[roughness]\nvalue = 0.5\n[view]\ndirection = [0.8, 0, 0.6]\n[[light]]\nname = \"sun\"\n"
                                   "direction = [0, 0.6, 0.8]\n";
    std::ofstream(path("s.toml")) << scene_text;
    std::ofstream(path("t.toml")) << scene_text << "[comparators]\nluts = [\"x.exr\"]\n";
    std::unique_ptr<TermBackend> backend = oracle_with({});
    // The scene's options and which description it reads.
    struct O {
        std::string description;
        scene::SceneRunOptions run;
    };
    O base{path("s.toml"), {}};
    Changes<O> c;
    c["description/other bytes"] = [this](O& o) { o.description = path("t.toml"); };
    // The same description's bytes over other pixels.
    std::filesystem::create_directories(path("other"));
    std::vector<float> other_ao(16, 0.75f);
    scene::write_exr(path("other/ao.exr"), 4, 4, {{"ao", other_ao.data()}});
    std::ofstream(path("other/s.toml")) << scene_text;
    c["pixels"] = [this](O& o) { o.description = path("other/s.toml"); };
    c["skip"] = [](O& o) { o.run.skip = false; };
    c["tolerance"] = [](O& o) { o.run.tolerance = 1e-3; };
    c["method_given"] = [](O& o) { o.run.method_given = true; };
    c["method"] = [](O& o) { o.run.method = Method::sampled; };
    c["bake_seed_luts"] = [](O& o) { o.run.bake_seed_luts = false; };
    c["luts.0/a LUT"] = [this](O& o) { o.run.luts = {path("x.exr")}; };
    c["luts.0/another LUT"] = [this](O& o) { o.run.luts = {path("y.exr")}; };
    add_backend_changes(c, backend);
    expect_every_option_moves_the_key<O>(
        "scene", base,
        [&](const O& o) {
            const scene::SceneInputs inputs = scene::SceneInputs::load(scene::load_scene(o.description));
            schedule::CacheKey key = scene::scene_cache_key(inputs, o.run, *backend);
            backend = oracle_with({});
            return key;
        },
        c);
    // The description's LUT files by their bytes: the same description over an edited LUT is another key.
    const scene::SceneInputs with_lut = scene::SceneInputs::load(scene::load_scene(path("t.toml")));
    const std::string before = scene::scene_cache_key(with_lut, {}, *backend).hash();
    std::ofstream(path("x.exr")) << "bytes of a LUT, baked again";
    EXPECT_NE(scene::scene_cache_key(with_lut, {}, *backend).hash(), before);
    // What the key leaves out (scene_cache_key_exclusions) leaves it as it is.
    const scene::SceneInputs inputs = scene::SceneInputs::load(scene::load_scene(path("s.toml")));
    scene::SceneRunOptions other;
    other.strict_domain = true;
    other.memory_limit = 1;
    other.progress = [](const std::string&, std::size_t, std::size_t) {};
    EXPECT_EQ(scene::scene_cache_key(inputs, other, *backend).hash(), scene::scene_cache_key(inputs, {}, *backend).hash());
}

}  // namespace
}  // namespace ms
