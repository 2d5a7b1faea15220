// The guard rails of a comparator's domain (core/lookup_domain.hpp): every LUT and representation file
// records the ranges it was made for; eval --compare, sweeps and design count the lookups outside them
// and report them per comparator, and --strict-domain refuses them (exit status 2, nothing written).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "core/lookup_domain.hpp"
#include "io/exr_file.hpp"
#include "jobs/compare.hpp"
#include "jobs/design.hpp"
#include "jobs/eval.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "lut/exr_lut.hpp"
#include "lut/lookup.hpp"
#include "repr/representation.hpp"
#include "repr/texture_repr.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

RunResult run(const std::string& args) { return run_shell(std::string(MICROSHADOW_CLI) + " " + args + " 2>&1"); }

// A small LUT over roughness 0.3..0.7 (its content does not matter here), written without a domain:
// write_lut records the one of its axes and channels.
fs::path write_small_lut(const fs::path& dir) {
    const auto texel = ms::TexelConvention::centres;
    std::vector<ms::LutAxis> axes = {{"visibility", 0, 1, 3, texel}, {"n_dot_l", 0, 1, 3, texel}, {"n_dot_v", 0, 1, 2, texel}};
    std::vector<ms::LutChannel> ch = {{"R", 0.3, 0.09, 0.09}, {"G", 0.7, 0.49, 0.49}};
    std::vector<float> data(3 * 3 * 2 * 2, 0.5f);
    nlohmann::json meta = {{"layout", "custom"}, {"azimuth", "mean"}, {"form", "height-correlated"},
                           {"ao_weighting", "cosine"}, {"sequence", "sobol"}, {"seed", 0}, {"samples", 16},
                           {"max_error", 0}, {"device", "test"}};
    const fs::path p = dir / "small.exr";
    ms::write_lut(p.string(), axes, ch, data, meta, false);
    return p;
}

TEST(LookupDomain, ContainsDescribesAndRoundTrips) {
    ms::LookupDomain d;
    d.roughness_min = 0.3, d.roughness_max = 0.9, d.visibility_min = 0.5, d.n_dot_v_min = 0.2;
    EXPECT_TRUE(d.contains(0.5, 0.1, 0.2, 0.3));
    EXPECT_TRUE(d.contains(1.0, -1.0, 1.0, 0.9));
    EXPECT_FALSE(d.contains(0.49, 0.5, 0.5, 0.5));
    EXPECT_FALSE(d.contains(0.7, 0.5, 0.1, 0.5));
    EXPECT_FALSE(d.contains(0.7, 0.5, 0.5, 0.95));
    EXPECT_FALSE(d.contains(0.7, 0.5, 0.5, std::nan("")));
    EXPECT_EQ(d.first_outside(0.7, 0.5, 0.5, 0.25), "roughness 0.25 outside [0.3, 0.9]");
    EXPECT_EQ(d.first_outside(0.7, 0.5, 0.5, 0.5), "");
    EXPECT_EQ(d.describe(), "roughness [0.3, 0.9], visibility [0.5, 1], NdotV [0.2, 1]");
    const ms::LookupDomain back = ms::LookupDomain::from_json(d.to_json("why"), "t");
    EXPECT_EQ(back.describe(), d.describe());
    EXPECT_FALSE(back.refuse_outside);
    // Without "outside" (the scene-fitted LUTs' format): refused.
    nlohmann::json old = d.to_json();
    old.erase("outside");
    EXPECT_TRUE(ms::LookupDomain::from_json(old, "t").refuse_outside);
    nlohmann::json bad = d.to_json();
    bad["roughness"] = {0.9, 0.3};
    EXPECT_THROW(ms::LookupDomain::from_json(bad, "t"), std::runtime_error);
    bad = d.to_json();
    bad["outside"] = "ignored";
    EXPECT_THROW(ms::LookupDomain::from_json(bad, "t"), std::runtime_error);
}

class DomainTest : public ScratchDirTest {
protected:
    DomainTest() : ScratchDirTest("domain") {}
};

TEST_F(DomainTest, LutFilesRecordTheirDomainAndLookupsOutsideAreAnsweredNotRefused) {
    const fs::path lut = write_small_lut(dir_);
    const auto file = ms::read_lut(lut.string());
    ASSERT_TRUE(file.metadata.contains("domain")) << file.metadata.dump();
    EXPECT_EQ(file.metadata["domain"]["roughness"], nlohmann::json({0.3, 0.7}));
    EXPECT_EQ(file.metadata["domain"]["outside"], "counted");
    const ms::LutLookup lookup(file);
    EXPECT_EQ(lookup.domain().describe(), "roughness [0.3, 0.7], visibility [0, 1], NdotV [0, 1]");
    EXPECT_NO_THROW(lookup(0.5, 0.5, 0.5, 0.1));  // clamped, as before; counted by the commands
}

TEST_F(DomainTest, EvalCountsQueriesOutsideEachComparatorsDomainAndStrictRefusesThem) {
    const fs::path lut = write_small_lut(dir_);
    // Query 1 at roughness 0.2 (alpha 0.04), outside [0.3, 0.7]; query 2 at roughness 0.5 inside.
    std::ofstream(path("q.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n"
                                    "0.6,0.04,0.04,0.6,0,0.8,0,0.6,0.8\n0.6,0.25,0.25,0.6,0,0.8,0,0.6,0.8\n";
    const auto r = run("eval --in " + path("q.csv") + " --out " + path("r.csv") + " --backend oracle --compare " + lut.string() +
                       " --compare naughty-dog");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("small: 1 of 2 queries outside its domain (roughness [0.3, 0.7]"), std::string::npos) << r.output;
    std::ifstream js(path("r.csv.json"));
    const auto meta = nlohmann::json::parse(js);
    EXPECT_EQ(meta["comparators"][0]["outside_domain"], 1);
    EXPECT_EQ(meta["comparators"][0]["lookups"], 2);
    EXPECT_EQ(meta["comparators"][0]["domain"]["roughness"], nlohmann::json({0.3, 0.7}));
    // Part 1's formulas have no domain: nothing counted.
    EXPECT_TRUE(meta["comparators"][1]["domain"].is_null());
    EXPECT_EQ(meta["comparators"][1]["outside_domain"], 0);

    const auto strict = run("eval --strict-domain --in " + path("q.csv") + " --out " + path("s.csv") + " --backend oracle --compare " +
                            lut.string());
    EXPECT_EQ(strict.exit_code, 2) << strict.output;
    EXPECT_NE(strict.output.find("--strict-domain: comparator small: 1 of 2 lookups outside its domain"), std::string::npos)
        << strict.output;
    EXPECT_NE(strict.output.find("query 1: roughness 0.2 outside [0.3, 0.7]"), std::string::npos) << strict.output;
    EXPECT_FALSE(fs::exists(path("s.csv")));
    EXPECT_FALSE(fs::exists(path("s.csv.json")));
    // Inside the domain, --strict-domain changes nothing.
    std::ofstream(path("in.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0.6,0.25,0.25,0.6,0,0.8,0,0.6,0.8\n";
    const auto ok = run("eval -q --strict-domain --in " + path("in.csv") + " --out " + path("ok.csv") + " --backend oracle --compare " +
                        lut.string());
    EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

TEST_F(DomainTest, SweepsReportPointsOutsideAComparatorFilesDomainAndStrictRefusesBeforeWriting) {
    write_small_lut(dir_);
    const std::string spec_text =
        "[sweep]\nchunk_size = 64\n[parameters]\nvisibility = [0.6]\nn_dot_l = [0.5, 0.9]\nn_dot_v = [0.8]\n"
        "roughness = [0.2, 0.5]\ndelta_phi = [0]\n[comparators]\n[[comparators.lut]]\nname = \"small\"\n"
        "file = \"small.exr\"\n";
    const ms::sweep::Spec spec = ms::sweep::parse_spec(spec_text, path("t.toml"), dir_.string());
    auto backend = ms::make_oracle_backend(1);
    ms::sweep::RunConfig config;
    config.plan.method = ms::Method::exact;
    config.backend = backend.get();
    config.out_dir = path("strict");
    config.strict_domain = true;
    try {
        ms::sweep::run_sweep(spec, config);
        ADD_FAILURE() << "a strict sweep outside the domain ran";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("comparator small: 2 of 4 lookups outside its domain"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(path("strict"))) << "nothing written";

    config.out_dir = path("counted");
    config.strict_domain = false;
    const auto result = ms::sweep::run_sweep(spec, config);
    ASSERT_TRUE(result.assembled);
    ASSERT_EQ(result.warnings_outside_domain.size(), 1u);
    EXPECT_NE(result.warnings_outside_domain[0].find("small: 2 of 4 points outside its domain"), std::string::npos);
    std::ifstream md(path("counted/summary.md"));
    const std::string summary{std::istreambuf_iterator<char>(md), std::istreambuf_iterator<char>()};
    EXPECT_NE(summary.find("| small | roughness [0.3, 0.7], visibility [0, 1], NdotV [0, 1] | 2 | 4 |"), std::string::npos) << summary;
    std::ifstream js(path("counted/sweep.json"));
    const auto meta = nlohmann::json::parse(js);
    EXPECT_EQ(meta["comparator_files"][0]["outside_domain"], 2);
}

TEST(DesignDomain, CandidatesCountReferencePointsOutsideTheirDomain) {
    ms::design::Candidate c;
    c.name = "c";
    c.value = [](const ms::approx::Inputs&) { return 0.5; };
    ms::design::ReferenceSet set;
    for (double r : {0.1, 0.35, 0.5, 0.95}) {
        ms::design::ReferencePoint p;
        p.roughness = r;
        p.visibility = 0.7, p.n_dot_l = 0.5, p.n_dot_v = 0.5;
        set.points.push_back(p);
    }
    EXPECT_EQ(ms::design::count_outside_domain(c, set).tally.lookups, 0u) << "no domain: nothing counted";
    ms::LookupDomain d;
    d.roughness_min = 0.3, d.roughness_max = 0.9;
    c.domain = d;
    const auto n = ms::design::count_outside_domain(c, set);
    EXPECT_EQ(n.tally.lookups, 4u);
    EXPECT_EQ(n.tally.outside, 2u);
    EXPECT_EQ(n.first_outside, "reference point 1: roughness 0.1 outside [0.3, 0.9]");
}

TEST_F(DomainTest, RepresentationFilesRecordTheirDomainAndEvalCountsIt) {
    const auto bake = run("repr bake -q --kind azimuth-harmonics --visibility-count 2 --n-dot-l-count 2 --n-dot-v-count 2"
                          " --azimuth-nodes 7 --roughness 0.4,0.8 --domain-visibility 0.5,1 --out " + path("h.exr"));
    ASSERT_EQ(bake.exit_code, 0) << bake.output;
    const auto rep = ms::repr::open_representation(path("h.exr"));
    ASSERT_TRUE(rep->domain().has_value());
    EXPECT_EQ(rep->domain()->describe(), "roughness [0.4, 0.8], visibility [0.5, 1], NdotV [0, 1]");
    // Visibility 0.3 is outside, roughness 0.6 inside.
    std::ofstream(path("q.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n"
                                    "0.3,0.36,0.36,0.6,0,0.8,0,0.6,0.8\n0.7,0.36,0.36,0.6,0,0.8,0,0.6,0.8\n";
    const auto strict = run("eval --strict-domain --in " + path("q.csv") + " --out " + path("r.csv") + " --backend oracle --compare " +
                            path("h.exr"));
    EXPECT_EQ(strict.exit_code, 2) << strict.output;
    EXPECT_NE(strict.output.find("query 1: visibility 0.3 outside [0.5, 1]"), std::string::npos) << strict.output;
    EXPECT_FALSE(fs::exists(path("r.csv")));
    const auto bad = run("repr bake -q --kind azimuth-harmonics --visibility-count 2 --n-dot-l-count 2 --n-dot-v-count 2"
                         " --azimuth-nodes 7 --roughness 0.4,0.8 --domain-visibility 0.8,0.5 --out " + path("b.exr"));
    EXPECT_EQ(bad.exit_code, 2) << bad.output;
    EXPECT_NE(bad.output.find("--domain-visibility must be LO,HI"), std::string::npos) << bad.output;
    EXPECT_FALSE(fs::exists(path("b.exr")));
}

}  // namespace

namespace {

class PresetTest : public ScratchDirTest {
protected:
    PresetTest() : ScratchDirTest("preset") {}
};

// `repr bake` with no options bakes the full-range preset (its file records the preset and its domain);
// a preset's name is a comparator for eval (baked in memory); layout options beside --preset are refused.
TEST_F(PresetTest, BakeWithoutOptionsIsFullRangeAndPresetNamesAreComparators) {
    const auto bake = run_shell("cd " + dir_.string() + " && " + MICROSHADOW_CLI + " repr bake -q 2>&1");
    ASSERT_EQ(bake.exit_code, 0) << bake.output;
    const auto rep = ms::repr::open_representation(path("full-range.exr"));
    const auto* tex = dynamic_cast<const ms::repr::TextureRepresentation*>(rep.get());
    ASSERT_NE(tex, nullptr);
    EXPECT_EQ(tex->metadata().at("preset"), "full-range");
    EXPECT_EQ(rep->domain()->describe(), "roughness [0.05, 1], visibility [0.02, 1], NdotV [0.02, 1]");
    EXPECT_EQ(rep->cost().bytes, 512u * 1024u);
    EXPECT_EQ(rep->cost().fetches_per_light, 2u);
    EXPECT_EQ(rep->grid().warps.n_dot_l, ms::repr::NdotLWarp::edge_roughness);

    // Roughness 0.2 is inside full-range's domain and outside realistic's (0.3-0.9).
    std::ofstream(path("q.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0.6,0.04,0.04,0.6,0,0.8,0,0.6,0.8\n";
    const auto e = run("eval -q --in " + path("q.csv") + " --out " + path("r.csv") + " --backend oracle --compare " + path("full-range.exr") +
                       " --compare realistic");
    ASSERT_EQ(e.exit_code, 0) << e.output;
    std::ifstream js(path("r.csv.json"));
    const auto meta = nlohmann::json::parse(js);
    EXPECT_EQ(meta["comparators"][0]["outside_domain"], 0);
    EXPECT_EQ(meta["comparators"][1]["name"], "realistic");
    EXPECT_EQ(meta["comparators"][1]["preset"], "realistic");
    EXPECT_EQ(meta["comparators"][1]["outside_domain"], 1);
    EXPECT_EQ(meta["comparators"][1]["cost"]["bytes"], 256 * 1024);

    const auto bad = run("repr bake -q --preset realistic --visibility-count 8 --out " + path("b.exr"));
    EXPECT_EQ(bad.exit_code, 2) << bad.output;
    EXPECT_NE(bad.output.find("--visibility-count conflicts with --preset realistic"), std::string::npos) << bad.output;
    EXPECT_FALSE(fs::exists(path("b.exr")));
    const auto unknown = run("eval -q --in " + path("q.csv") + " --out " + path("u.csv") + " --compare full-rnage");
    EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
    EXPECT_NE(unknown.output.find("presets: realistic, full-range"), std::string::npos) << unknown.output;
}

TEST(PresetSpec, SweepsNameAPresetInsteadOfAFileAndRefuseBoth) {
    const std::string head = "[parameters]\nvisibility = [0.6]\nn_dot_l = [0.5]\nn_dot_v = [0.8]\nroughness = [0.5]\n"
                             "delta_phi = [0]\n[comparators]\n[[comparators.lut]]\nname = \"p\"\n";
    const auto spec = ms::sweep::parse_spec(head + "preset = \"full-range\"\n", "t.toml", ".");
    ASSERT_EQ(spec.luts.size(), 1u);
    EXPECT_EQ(spec.luts[0].preset, "full-range");
    EXPECT_TRUE(spec.luts[0].file.empty());
    EXPECT_THROW(ms::sweep::parse_spec(head + "preset = \"full-range\"\nfile = \"x.exr\"\n", "t.toml", "."), std::invalid_argument);
    EXPECT_THROW(ms::sweep::parse_spec(head, "t.toml", "."), std::invalid_argument);
}

}  // namespace
