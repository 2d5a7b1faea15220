// Parameter sweeps: spec validation, ranges, point enumeration, comparator wiring, LUT lookups,
// resume after an interruption, shard + merge, and an anisotropic sweep end to end.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analytic/part1_terms.hpp"
#include "core/cancel.hpp"
#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "lut/exr_lut.hpp"
#include "device/runtime.hpp"
#include "lut/lookup.hpp"
#include "jobs/sweep/points.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "test_files.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;
using namespace ms::sweep;

using ms::testing::slurp_file;

fs::path fresh_dir(const std::string& name) {
    const fs::path d = fs::temp_directory_path() / ("microshadow_sweep_test_" + std::to_string(::getpid())) / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

// Expects parse_spec to throw a SpecError whose message contains `needle` (the key it names).
void expect_spec_error(const std::string& toml, const std::string& needle) {
    try {
        parse_spec(toml, "t.toml");
        ADD_FAILURE() << "no error for:\n" << toml;
    } catch (const SpecError& e) {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what() << "\nexpected: " << needle;
    }
}

const std::string kMinimal = "[parameters]\nvisibility = [0.5]\nn_dot_l = [0.5]\nroughness = [0.5]\n";

TEST(SweepSpec, ErrorsNameTheKey) {
    expect_spec_error("[parameters]\nn_dot_l = [0.5]\nroughness = [0.5]\n", "parameters.visibility: required");
    expect_spec_error(kMinimal + "bogus = 1\n", "parameters.bogus: unknown key");
    expect_spec_error("[sweeep]\n" + kMinimal, "sweeep: unknown key");
    expect_spec_error("[parameters]\nvisibility = \"half\"\nn_dot_l = [0.5]\nroughness = [0.5]\n", "parameters.visibility: must be");
    expect_spec_error("[parameters]\nvisibility = [0.5, \"x\"]\nn_dot_l = [0.5]\nroughness = [0.5]\n",
                      "parameters.visibility[1]: must be a number");
    expect_spec_error("[parameters]\nvisibility = {start = 0, stop = 1, count = -3}\nn_dot_l = [0.5]\nroughness = [0.5]\n",
                      "parameters.visibility.count: must be positive");
    expect_spec_error("[parameters]\nvisibility = {start = 0.5, stop = 0.5, count = 4}\nn_dot_l = [0.5]\nroughness = [0.5]\n",
                      "zero-length range");
    expect_spec_error("[parameters]\nvisibility = {start = 0, stop = 1, count = 4, scale = \"log\"}\nn_dot_l = [0.5]\nroughness = [0.5]\n",
                      "log range needs start > 0");
    expect_spec_error("[parameters]\nvisibility = [1.5]\nn_dot_l = [0.5]\nroughness = [0.5]\n", "parameters.visibility: value 1.5 outside");
    expect_spec_error("[parameters]\nvisibility = [0.5]\nn_dot_l = [0.5]\nn_dot_v = [0]\nroughness = [0.5]\n", "parameters.n_dot_v");
    expect_spec_error("[parameters]\nvisibility = [0.5]\nn_dot_l = [0.5]\nroughness = [0.5]\nalpha_x = [0.1]\n",
                      "either roughness or alpha_x");
    expect_spec_error("[parameters]\nvisibility = [0.5]\nn_dot_l = [0.5]\nalpha_x = [0.1]\n", "parameters.alpha_y: required");
    expect_spec_error(kMinimal + "phi_o = [0]\ndelta_phi = [0]\n", "either phi_o or delta_phi");
    expect_spec_error(kMinimal + "form = [\"correlated-ish\"]\n", "parameters.form");
    expect_spec_error(kMinimal + "[comparators]\nanalytic = [\"naughty-cat\"]\n", "comparators.analytic");
    expect_spec_error(kMinimal + "[comparators]\nanalytic = [\"naughty-dog\", \"naughty-dog\"]\n", "duplicate");
    expect_spec_error(kMinimal + "[[comparators.lut]]\nname = \"term\"\nfile = \"x.exr\"\n", "reserved column name 'term'");
    expect_spec_error(kMinimal + "[[comparators.lut]]\nfile = \"x.exr\"\n", "comparators.lut[0].name: required");
    expect_spec_error("[sweep]\nchunk_size = 0\n" + kMinimal, "sweep.chunk_size: must be positive");
    expect_spec_error("[sampling]\nreplicates = 1\n" + kMinimal, "sampling.replicates");
    expect_spec_error("[parameters]\nvisibility = [0.5\n", "t.toml:");  // TOML syntax, with position
    // 10^9 points need an explicit limit; with one they pass validation (nothing is evaluated here).
    const std::string huge =
        "[parameters]\nvisibility = {start = 0, stop = 1, count = 1000}\nn_dot_l = {start = 0, stop = 1, count = 1000}\n"
        "roughness = {start = 0.1, stop = 1, count = 1000}\n";
    expect_spec_error(huge, "1000000000 points, more than the limit of 20000000");
    EXPECT_NO_THROW(parse_spec("[sweep]\nmax_points = 1000000000\n" + huge, "t.toml"));
}

TEST(SweepSpec, DefaultsAndAlphaPairs) {
    const Spec s = parse_spec("[parameters]\nvisibility = 0.5\nn_dot_l = [0.25, 1]\nalpha_x = [0.1]\nalpha_y = [0.4, 0.9]\n"
                              "phi_o = [30]\nao_weighting = \"uniform\"\n",
                              "t.toml");
    EXPECT_FALSE(s.by_roughness);
    EXPECT_FALSE(s.relative_azimuth);
    EXPECT_EQ(s.n_dot_v, std::vector<double>{1.0});
    EXPECT_EQ(s.phi_i, std::vector<double>{0.0});
    ASSERT_EQ(s.weightings.size(), 1u);
    EXPECT_EQ(s.weightings[0], AoWeighting::uniform);
    EXPECT_TRUE(s.forms.empty());
}

TEST(SweepRange, LinearAndLog) {
    const auto lin = generate_range({0.1, 0.9, 5, Scale::linear});
    ASSERT_EQ(lin.size(), 5u);
    EXPECT_EQ(lin.front(), 0.1);
    EXPECT_EQ(lin.back(), 0.9);
    for (std::size_t i = 1; i < lin.size(); ++i) EXPECT_NEAR(lin[i] - lin[i - 1], 0.2, 1e-15);
    const auto lg = generate_range({0.01, 1.0, 5, Scale::log});
    EXPECT_EQ(lg.front(), 0.01);
    EXPECT_EQ(lg.back(), 1.0);
    // Constant ratio 10^(2/4) between neighbours.
    for (std::size_t i = 1; i < lg.size(); ++i) EXPECT_NEAR(lg[i] / lg[i - 1], std::sqrt(10.0), 1e-13);
    EXPECT_EQ(generate_range({0.3, 0.3, 1, Scale::linear}), std::vector<double>{0.3});
    EXPECT_THROW(generate_range({0, 1, 0, Scale::linear}), SpecError);
}

TEST(SweepPoints, MixedRadixOrderAndGeometry) {
    const Spec s = parse_spec("[parameters]\nvisibility = [0.2, 0.4, 0.6]\nn_dot_l = [0.5, 1]\nn_dot_v = [0.6]\n"
                              "alpha_x = [0.1, 0.2]\nalpha_y = [0.3]\nphi_i = [90]\ndelta_phi = [0, 180]\n",
                              "t.toml");
    const PointGrid g(s, Form::uncorrelated, AoWeighting::cosine);
    ASSERT_EQ(g.size(), 3u * 2 * 2 * 2);
    // Visibility fastest, then n_dot_l, then delta_phi, ... alpha_x slowest of the numeric axes.
    const Point p = g.at(1 + 3 * 1 + 6 * 1 + 12 * 1);
    EXPECT_EQ(p.visibility, 0.4);
    EXPECT_EQ(p.n_dot_l, 1.0);
    EXPECT_EQ(p.delta_phi, 180.0);
    EXPECT_EQ(p.phi_o, 270.0);
    EXPECT_EQ(p.alpha_x, 0.2);
    EXPECT_EQ(p.alpha_y, 0.3);
    EXPECT_EQ(p.form, Form::uncorrelated);
    EXPECT_DOUBLE_EQ(p.roughness, std::pow(0.2 * 0.3, 0.25));
    const Query q = to_query(g.at(3));  // visibility 0.2, n_dot_l 1, phi_i 90
    EXPECT_NEAR(q.wi.x, 0, 1e-15);      // phi_i = 90 degrees: wi in the y-z plane
    EXPECT_NEAR(q.wi.y, 0.8, 1e-15);
    EXPECT_EQ(q.wi.z, 0.6);
    EXPECT_EQ(q.wo.z, 1.0);
    EXPECT_THROW(g.at(g.size()), std::out_of_range);
}

// A LUT whose texels hold f(v, l, z) = (v + 2 l + 4 z + 8 r) / 16 exactly at their texel parameters
// (scaled into [0, 1]: read_lut refuses texels outside it). Linear filtering reproduces a function that
// is linear in each parameter, so any interior lookup must return f up to float rounding of the stored
// texels (16 f <= 15, float eps 6e-8 -> 1e-5 on 16 f is 10x that).
constexpr double kLinearScale = 16;
fs::path write_linear_lut(const fs::path& dir, TexelConvention texel, std::uint32_t nz) {
    std::vector<LutAxis> axes = {{"visibility", 0, 1, 5, texel}, {"n_dot_l", 0, 1, 4, texel}, {"n_dot_v", 0, 1, nz, texel}};
    std::vector<LutChannel> ch = {{"R", 0.1, 0.01, 0.01}, {"G", 0.4, 0.16, 0.16}, {"B", 0.7, 0.49, 0.49}};
    std::vector<float> data;
    for (std::uint32_t k = 0; k < nz; ++k)
        for (std::uint32_t j = 0; j < 4; ++j)
            for (std::uint32_t i = 0; i < 5; ++i)
                for (const auto& c : ch)
                    data.push_back(float((axes[0].value(i) + 2 * axes[1].value(j) + 4 * (nz > 1 ? axes[2].value(k) : 1.0) +
                                          8 * c.roughness) / kLinearScale));
    nlohmann::json meta = {{"layout", "custom"}, {"azimuth", "mean"}, {"form", "height-correlated"},
                           {"ao_weighting", "cosine"}, {"sequence", "sobol"}, {"seed", 0}, {"samples", 16},
                           {"max_error", 0}, {"device", "test"}, {"version", "test"}, {"command_line", "test"}};
    const fs::path p = dir / ("lin-" + to_string(texel) + "-" + std::to_string(nz) + ".exr");
    write_lut(p.string(), axes, ch, data, meta, false);
    return p;
}

TEST(SweepLut, TrilinearBilinearAndRoughnessBlend) {
    const fs::path dir = fresh_dir("lut");
    for (auto texel : {TexelConvention::centres, TexelConvention::endpoints}) {
        const LutLookup lut3 = LutLookup::open(write_linear_lut(dir, texel, 3).string());
        // Interior of the texel-centre range on every axis, and roughness between channels; in the zero
        // region (2 v + NdotL <= 1) the lookup answers 0 before reading a texel, as the shader does.
        for (double v : {0.13, 0.5, 0.77})
            for (double l : {0.2, 0.61})
                for (double z : {0.35, 0.64})
                    for (double r : {0.1, 0.25, 0.55, 0.7})
                        EXPECT_NEAR(kLinearScale * lut3(v, l, z, r), 2 * v + l <= 1 ? 0.0 : v + 2 * l + 4 * z + 8 * r, 1e-5)
                            << v << " " << l << " " << z << " " << r;
        // Clamp-to-edge: below the first texel centre a lookup returns the edge value; roughness clamps too.
        const LutAxis vis{"visibility", 0, 1, 5, texel}, ndl{"n_dot_l", 0, 1, 4, texel};
        // (v = 0.05 with NdotL 1, outside the zero region: the first texel's value at texel centres, v itself
        // between the endpoints texels 0 and 0.25.)
        EXPECT_NEAR(kLinearScale * lut3(0.05, 1.0, 0.5, 0.05), std::max(0.05, vis.value(0)) + 2 * ndl.value(3) + 2 + 8 * 0.1, 1e-5);
        EXPECT_NEAR(kLinearScale * lut3(0.5, 0.5, 0.5, 1.0), 0.5 + 1 + 2 + 8 * 0.7, 1e-5);
        // 2D LUT: one slice (stored for NdotV = 1) whatever NdotV is asked.
        const LutLookup lut2 = LutLookup::open(write_linear_lut(dir, texel, 1).string());
        EXPECT_NEAR(kLinearScale * lut2(0.5, 0.5, 0.2, 0.4), 0.5 + 1 + 4 + 3.2, 1e-5);
        EXPECT_NEAR(kLinearScale * lut2(0.5, 0.5, 1.0, 0.4), 0.5 + 1 + 4 + 3.2, 1e-5);
    }
    EXPECT_THROW(LutLookup::open((dir / "missing.exr").string()), std::runtime_error);
}

RunConfig oracle_config(const fs::path& out, TermBackend& backend) {
    RunConfig c;
    c.out_dir = out.string();
    c.plan.samples = 256;
    c.plan.replicates = 4;
    c.plan.seed = 11;
    c.backend = &backend;
    return c;
}

// Small anisotropic sweep (both azimuths, alpha_x != alpha_y) with analytic comparators, 20 chunks of 24 (every chunk costs two fsyncs).
std::string small_spec_text() {
    return "[sweep]\nchunk_size = 24\n[parameters]\nvisibility = {start = 0.1, stop = 0.9, count = 5}\n"
           "n_dot_l = {start = 0.1, stop = 1, count = 4}\nn_dot_v = [0.4]\nalpha_x = [0.1, 0.5]\nalpha_y = [0.3]\n"
           "phi_i = [0, 60]\ndelta_phi = {start = 0, stop = 180, count = 3}\nform = [\"height-correlated\", \"uncorrelated\"]\n"
           "[comparators]\nanalytic = [\"reference-step\", \"naughty-dog\", \"naughty-dog-ao-fresnel\", \"activision\", "
           "\"activision-adjusted\", \"pz-analytic\"]\n";
}

TEST(SweepRun, ComparatorColumnsAreTheAnalyticTerms) {
    const fs::path dir = fresh_dir("wiring");
    const Spec spec = parse_spec(small_spec_text(), "t.toml");
    auto backend = make_oracle_backend(1);
    const RunResult r = run_sweep(spec, oracle_config(dir, *backend));
    ASSERT_TRUE(r.assembled);
    EXPECT_EQ(r.points, 5u * 4 * 2 * 2 * 3 * 2);
    std::ifstream in(dir / "sweep.csv");
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, csv_header(spec));
    const PointGrid grid(spec, Form::height_correlated, AoWeighting::cosine);
    std::size_t rows = 0;
    while (std::getline(in, line)) {
        std::vector<double> f;
        std::stringstream ss(line);
        std::string cell;
        for (int k = 0; std::getline(ss, cell, ','); ++k) f.push_back(k == 1 || k == 2 ? 0 : std::stod(cell));
        const Point p = grid.at(std::uint64_t(f[0]));
        analytic::AnalyticInputs a{p.visibility, p.n_dot_l, p.n_dot_v,
                                   analytic::activision_roughness_from_alpha(p.roughness * p.roughness),
                                   AoWeighting::cosine};
        // Columns 14.. are the comparators in spec order; the CSV holds shortest round-trip text.
        for (std::size_t k = 0; k < spec.analytic.size(); ++k)
            EXPECT_EQ(f[14 + k], analytic::evaluate(spec.analytic[k], a)) << line;
        EXPECT_EQ(f[3], p.roughness);
        ++rows;
    }
    EXPECT_EQ(rows, r.points);
    // The summary counts every point once overall and once in its roughness group.
    std::ifstream csv(dir / "sweep.csv");
    const Summary s = summarise(csv, "sweep.csv");
    ASSERT_EQ(s.comparators.size(), 6u);
    EXPECT_EQ(s.errors.at(0, 0).count(), r.points);
    ASSERT_EQ(s.roughness_groups.size(), 2u);
    EXPECT_EQ(s.errors.groups(), 3u);  // all points, then each roughness
    std::uint64_t in_groups = 0;
    for (const auto& [roughness, group] : s.roughness_groups) in_groups += s.errors.at(0, group).count();
    EXPECT_EQ(in_groups, r.points);
}

TEST(SweepRun, ResumeAfterInterruptionSkipsFinishedChunksAndMatchesACleanRun) {
    const Spec spec = parse_spec(small_spec_text(), "t.toml");
    auto backend = make_oracle_backend(1);
    const fs::path clean = fresh_dir("clean"), resumed = fresh_dir("resumed");
    ASSERT_TRUE(run_sweep(spec, oracle_config(clean, *backend)).assembled);

    // First attempt: stopped by the --max-chunks hook after 5 chunks.
    RunConfig c = oracle_config(resumed, *backend);
    c.max_chunks = 5;
    RunResult r = run_sweep(spec, c);
    EXPECT_FALSE(r.complete);
    EXPECT_EQ(r.computed, 5u);
    EXPECT_FALSE(fs::exists(resumed / "sweep.csv"));
    // Second attempt: interrupted like Ctrl-C (the cancel flag) once at least 9 chunks are finished. The
    // scheduler polls the flag between items, so a few more may finish before it stops.
    c.max_chunks = 0;
    c.progress = [](std::uint64_t done, std::uint64_t) {
        if (done >= 5 + 4) cancel_requested() = true;
    };
    EXPECT_THROW(run_sweep(spec, c), Cancelled);
    cancel_requested() = false;
    EXPECT_FALSE(fs::exists(resumed / "sweep.csv"));
    // Third: finishes without recomputing the finished chunks.
    c.progress = {};
    r = run_sweep(spec, c);
    EXPECT_GE(r.skipped, 9u);
    EXPECT_EQ(r.computed, r.chunks - r.skipped);
    ASSERT_TRUE(r.assembled);
    EXPECT_EQ(slurp_file(clean / "sweep.csv"), slurp_file(resumed / "sweep.csv"));
    // A finished sweep reruns without computing anything.
    r = run_sweep(spec, c);
    EXPECT_EQ(r.computed, 0u);
    // Another seed is another sweep: refused in the same directory unless --restart.
    c.plan.seed = 12;
    EXPECT_THROW(run_sweep(spec, c), std::invalid_argument);
}

TEST(SweepRun, ShardsMergeToTheUnsplitFile) {
    const Spec spec = parse_spec(small_spec_text(), "t.toml");
    auto backend = make_oracle_backend(1);
    const fs::path whole = fresh_dir("whole"), merged = fresh_dir("merged");
    ASSERT_TRUE(run_sweep(spec, oracle_config(whole, *backend)).assembled);
    std::vector<std::string> dirs;
    for (std::uint32_t i = 0; i < 3; ++i) {
        const fs::path d = fresh_dir("shard" + std::to_string(i));
        RunConfig c = oracle_config(d, *backend);
        c.shard = {i, 3};
        const RunResult r = run_sweep(spec, c);
        EXPECT_TRUE(r.complete);
        EXPECT_FALSE(r.assembled);
        dirs.push_back(d.string());
    }
    EXPECT_THROW(merge_shards({dirs[0], dirs[2]}, merged.string(), "test"), std::invalid_argument);  // shard 1 missing
    merge_shards(dirs, merged.string(), "test");
    EXPECT_EQ(slurp_file(whole / "sweep.csv"), slurp_file(merged / "sweep.csv"));
    EXPECT_EQ(slurp_file(whole / "summary.csv"), slurp_file(merged / "summary.csv"));
    EXPECT_THROW(parse_shard("3/3"), std::invalid_argument);
    EXPECT_THROW(parse_shard("1"), std::invalid_argument);
}

// End to end through the CLI on the default OpenCL device: an anisotropic sweep over both azimuths.
// Each row's term is checked against the scalar oracle on the same plan: the two estimates use the
// same points, so their difference is bounded by the Student-t quantile times the combined std error.
TEST(SweepCli, AnisotropicSweepMatchesTheOracle) {
    const fs::path dir = fresh_dir("cli");
    const std::string spec_text =
        "[sweep]\nchunk_size = 16\n[sampling]\nmethod = \"sampled\"\nsamples = 1024\nreplicates = 8\nseed = 5\n[parameters]\n"
        "visibility = [0.3, 0.6, 0.9]\nn_dot_l = [0.4, 0.9]\nn_dot_v = [0.3, 0.8]\nalpha_x = [0.08]\nalpha_y = [0.6]\n"
        "phi_i = [0, 75]\nphi_o = [20, 200]\n[comparators]\nanalytic = [\"naughty-dog\"]\n";
    std::ofstream(dir / "aniso.toml") << spec_text;
    const std::string cmd = std::string(MICROSHADOW_CLI) + " sweep '" + (dir / "aniso.toml").string() + "' --out '" +
                            (dir / "out").string() + "' -q > /dev/null 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    const Spec spec = parse_spec(spec_text, "aniso.toml");
    const PointGrid grid(spec, Form::height_correlated, AoWeighting::cosine);
    std::vector<Query> queries;
    for (std::uint64_t i = 0; i < grid.size(); ++i) queries.push_back(to_query(grid.at(i)));
    SamplingPlan plan;
    plan.samples = 1024;
    plan.replicates = 8;
    plan.seed = 5;
    auto oracle = make_oracle_backend(1);
    const auto ref = evaluate(*oracle, queries, {}, plan);
    const double t = student_t_quantile(0.9999, int(plan.replicates) - 1);
    std::ifstream in(dir / "out" / "sweep.csv");
    std::string line;
    std::getline(in, line);
    std::size_t rows = 0;
    std::vector<Estimate> got(grid.size());
    while (std::getline(in, line)) {
        std::vector<std::string> f;
        std::stringstream ss(line);
        for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
        const std::size_t i = std::stoul(f[0]);
        ASSERT_LT(i, got.size());
        got[i] = {std::stod(f[12]), std::stod(f[13])};
        EXPECT_LE(std::abs(got[i].term - ref[i].term), t * std::hypot(got[i].std_error, ref[i].std_error) + 1e-6) << line;
        ++rows;
    }
    EXPECT_EQ(rows, grid.size());
    // Points 0..5 (phi_i 0, NdotV 0.3, phi_o 20) and 6..11 (phi_o 200) differ only in the light's
    // azimuth; the anisotropic term must tell them apart beyond its error bars somewhere.
    bool azimuth_matters = false;
    for (std::size_t j = 0; j < 6; ++j)
        azimuth_matters |= std::abs(got[j].term - got[j + 6].term) > t * std::hypot(got[j].std_error, got[j + 6].std_error);
    EXPECT_TRUE(azimuth_matters);
}

}  // namespace
