// `microshadow bake --scene`: the scene's domain decides the bake. Known answers: one
// roughness bakes one channel; a constant NdotV touches only the two bracketing slices; the rows baked
// are bit for bit the full bake's; unbaked texels are NaN, recorded, refused by the lookup, and a file
// whose unbaked texel holds a number is refused by read_lut.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "jobs/scene_bake.hpp"
#include "lut/exr_lut.hpp"
#include "lut/lookup.hpp"
#include "scene/description.hpp"
#include "scene/image_io.hpp"
#include "scene/inputs.hpp"

namespace ms {
namespace {

namespace fs = std::filesystem;
using testing::ScratchDirTest;

class SceneBakeTest : public ScratchDirTest {
protected:
    SceneBakeTest() : ScratchDirTest("scene_bake") {}

    // An 8 x 8 scene: AO from 0.3 to 0.9 across, one roughness, a flat normal, one view and one sun,
    // so NdotV and NdotL are constant: NdotV = 0.6, NdotL = 0.8.
    std::vector<scene::LightDomain> flat_scene(double roughness) {
        std::vector<float> ao(64);
        for (int i = 0; i < 64; ++i) ao[std::size_t(i)] = float(0.3 + 0.6 * (i % 8) / 7.0);
        scene::write_exr(path("ao.exr"), 8, 8, {{"ao", ao.data()}});
        std::ofstream(path("s.toml")) << "[normal]\nvalue = [0, 0, 1]\n[visibility]\nfile = \"ao.exr\"\nchannel = \"ao\"\n"
                                         "[roughness]\nvalue = "
                                      << roughness << "\n[view]\ndirection = [0.8, 0, 0.6]\n[[light]]\nname = \"sun\"\n"
                                                      "direction = [0, 0.6, 0.8]\n";
        inputs_ = std::make_unique<scene::SceneInputs>(scene::SceneInputs::load(scene::load_scene(path("s.toml"))));
        return scene::scene_domain(*inputs_, 16);
    }
    std::unique_ptr<scene::SceneInputs> inputs_;
};

TEST_F(SceneBakeTest, DomainHistogramsCountEveryLitPixel) {
    const auto domain = flat_scene(0.5);
    ASSERT_EQ(domain.size(), 1u);
    EXPECT_EQ(domain[0].shaded, 64u);
    ASSERT_EQ(domain[0].lookups.size(), 64u);
    ASSERT_EQ(domain[0].histograms.size(), 5u);
    for (const auto& h : domain[0].histograms) EXPECT_EQ(h.total(), 64u) << h.name;
    // NdotV = 0.6 exactly: bin floor(0.6 x 16) = 9 holds all 64; the azimuth is 90 degrees (V along x, L along y).
    EXPECT_EQ(domain[0].histograms[2].counts[9], 64u);
    EXPECT_NEAR(domain[0].histograms[4].data_min, 90.0, 1e-9);
}

TEST_F(SceneBakeTest, OneRoughnessBakesOneChannelAndConstantAxesOneTexel) {
    const auto domain = flat_scene(0.5);
    const scene::SceneBakePlan plan = scene::plan_scene_bake(domain, default_bake_spec(LutLayout::seed_3d, 8), true);
    ASSERT_EQ(plan.spec.roughness.size(), 1u);
    EXPECT_DOUBLE_EQ(plan.spec.roughness[0], 0.5);
    EXPECT_EQ(plan.spec.n_dot_v.count, 1u);
    EXPECT_EQ(plan.spec.n_dot_l.count, 1u);
    EXPECT_DOUBLE_EQ(plan.spec.n_dot_v.min, 0.6);
    EXPECT_NEAR(plan.spec.visibility.min, 0.3, 1e-7);
    EXPECT_NEAR(plan.spec.visibility.max, 0.9, 1e-7);
    // One channel, one slice, one row: everything the layout has is touched (a full bake).
    EXPECT_EQ(plan.baked_rows, plan.rows);
    EXPECT_TRUE(plan.spec.baked_rows.empty());
}

TEST_F(SceneBakeTest, ConstantNdotVTouchesOnlyTheBracketingSlicesAndChannels) {
    const auto domain = flat_scene(0.5);
    // The seed layout at 8 texels (centres): NdotV 0.6 sits at t = 0.6 x 8 - 0.5 = 4.3, slices 4 and 5;
    // NdotL 0.8 at t = 5.9, rows 5 and 6; roughness 0.5 between the channels 0.4 (1) and 0.7 (2).
    const scene::SceneBakePlan plan = scene::plan_scene_bake(domain, default_bake_spec(LutLayout::seed_3d, 8), false);
    EXPECT_EQ(plan.channels_touched, (std::vector<std::uint32_t>{1, 2}));
    EXPECT_EQ(plan.slices, 32u);
    EXPECT_EQ(plan.baked_slices, 4u);
    EXPECT_EQ(plan.baked_rows, 8u);
    EXPECT_EQ(plan.baked_texels, 64u);
    EXPECT_EQ(plan.texels, 8u * 8u * 8u * 4u);
    for (std::uint32_t z = 0; z < 8; ++z)
        for (std::uint32_t c = 0; c < 4; ++c)
            for (std::uint32_t r = 0; r < 8; ++r)
                EXPECT_EQ(plan.spec.row_baked(z * 4 + c, r), (z == 4 || z == 5) && (c == 1 || c == 2) && (r == 5 || r == 6))
                    << z << " " << c << " " << r;
}

TEST_F(SceneBakeTest, PartialBakeMatchesTheFullBakeAndUnbakedTexelsAreMarkedAndRefused) {
    const auto domain = flat_scene(0.5);
    BakeSpec base = default_bake_spec(LutLayout::seed_3d, 8);
    base.samples = 4096;
    const scene::SceneBakePlan plan = scene::plan_scene_bake(domain, base, false);
    auto backend = make_opencl_backend(ocl::select_devices("default"));
    const BakeResult part = bake_lut(plan.spec, backend->scheduler());
    BakeSpec full_spec = plan.spec;
    full_spec.baked_rows.clear();
    const BakeResult full = bake_lut(full_spec, backend->scheduler());
    ASSERT_EQ(part.value.size(), full.value.size());
    std::uint64_t baked = 0;
    for (std::uint32_t z = 0; z < 8; ++z)
        for (std::uint32_t c = 0; c < 4; ++c)
            for (std::uint32_t r = 0; r < 8; ++r)
                for (std::uint32_t v = 0; v < 8; ++v) {
                    const float a = part.at(c, v, r, z), b = full.at(c, v, r, z);
                    if (plan.spec.row_baked(z * 4 + c, r)) {
                        ++baked;
                        EXPECT_EQ(a, b) << "a baked row differs from the full bake: " << z << " " << c << " " << r << " " << v;
                    } else {
                        EXPECT_TRUE(std::isnan(a)) << "unbaked texel holds " << a;
                    }
                }
    EXPECT_EQ(baked, plan.baked_texels);

    // The file: the coverage record lets read_lut accept exactly these NaN; a lookup inside the scene's
    // footprint answers as the full LUT does, one outside is refused.
    nlohmann::json meta = bake_metadata(plan.spec, part);
    meta["coverage"] = scene::coverage_record(plan);
    const auto channels = bake_channels(plan.spec);
    write_lut(path("part.exr"), {plan.spec.visibility, plan.spec.n_dot_l, plan.spec.n_dot_v}, channels, part.value, meta, false);
    write_lut(path("full.exr"), {plan.spec.visibility, plan.spec.n_dot_l, plan.spec.n_dot_v}, channels, full.value,
              bake_metadata(full_spec, full), false);
    const auto part_lut = LutLookup::open(path("part.exr"));
    const auto full_lut = LutLookup::open(path("full.exr"));
    for (const auto& l : domain[0].lookups)
        EXPECT_EQ(part_lut(l.visibility, l.n_dot_l, l.n_dot_v, l.roughness), full_lut(l.visibility, l.n_dot_l, l.n_dot_v, l.roughness));
    EXPECT_THROW(part_lut(0.5, 0.8, 0.1, 0.5), std::domain_error);   // another NdotV slice
    EXPECT_THROW(part_lut(0.5, 0.8, 0.6, 0.95), std::domain_error);  // another channel
    EXPECT_THROW(part_lut(0.5, 0.2, 0.6, 0.5), std::domain_error);   // another NdotL row

    // A number where the record says unbaked is corruption: refused, named.
    std::vector<float> tampered = part.value;
    for (float& v : tampered)
        if (std::isnan(v)) {
            v = 0.5f;
            break;
        }
    write_lut(path("tampered.exr"), {plan.spec.visibility, plan.spec.n_dot_l, plan.spec.n_dot_v}, channels, tampered, meta, false);
    try {
        read_lut(path("tampered.exr"));
        ADD_FAILURE() << "read_lut accepted a value in an unbaked row";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("coverage record says unbaked"), std::string::npos) << e.what();
    }
    // And NaN without a record is refused as before.
    nlohmann::json no_record = meta;
    no_record.erase("coverage");
    write_lut(path("norecord.exr"), {plan.spec.visibility, plan.spec.n_dot_l, plan.spec.n_dot_v}, channels, part.value, no_record, false);
    EXPECT_THROW(read_lut(path("norecord.exr")), std::runtime_error);
}

TEST_F(SceneBakeTest, AzimuthMeanFloorVanishesWhenTheViewIsAlongTheNormal) {
    // V = N: the relative azimuth of L means nothing (every azimuth is the same query turned about the
    // normal), so the azimuth mean equals the term: the floor is zero within the two error bounds (one
    // distinct query, both bounds at 99.9 %).
    std::vector<float> ao(16, 0.7f);
    scene::write_exr(path("ao.exr"), 4, 4, {{"ao", ao.data()}});
    std::ofstream(path("n.toml")) << "[normal]\nvalue = [0, 0, 1]\n[visibility]\nfile = \"ao.exr\"\nchannel = \"ao\"\n"
                                     "[roughness]\nvalue = 0.6\n[view]\ndirection = [0, 0, 1]\n[[light]]\nname = \"sun\"\n"
                                     "direction = [0.6, 0, 0.8]\n";
    const scene::SceneInputs inputs = scene::SceneInputs::load(scene::load_scene(path("n.toml")));
    const auto domain = scene::scene_domain(inputs, 8);
    BakeSpec base = default_bake_spec(LutLayout::seed_3d, 4);
    base.samples = 4096;
    auto backend = make_opencl_backend(ocl::select_devices("default"));
    scene::SceneBakeOptions options;
    options.error_lookups = 1;  // every lookup is the same query
    const auto r = scene::run_scene_bake(inputs, domain, base, *backend, options);
    ASSERT_EQ(r.errors.size(), 1u);
    const auto& e = r.errors[0];
    ASSERT_EQ(e.azimuth_floor.count, 1u);
    EXPECT_GT(e.azimuth_floor_bound, 0.0);
    EXPECT_LE(e.azimuth_floor.term_max_abs, e.azimuth_floor_bound + e.reference_bound)
        << "floor " << e.azimuth_floor.term_max_abs << ", bounds " << e.azimuth_floor_bound << " + " << e.reference_bound;
}

TEST_F(SceneBakeTest, CommandLineBakesTheExampleSceneWithItsReport) {
    const std::string cli = MICROSHADOW_CLI;
    const std::string example = std::string(MICROSHADOW_SOURCE_DIR) + "/examples/scene/scene.toml";
    // Bad use: exit 2, nothing written.
    auto r = testing::run_shell(cli + " bake --scene " + example + " --out " + path("lut.png") + " --scene-report " + path("rep") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_FALSE(fs::exists(path("rep")));
    r = testing::run_shell(cli + " bake --scene " + example + " --out " + path("lut.exr") + " --scene-report " + path("rep") +
                           " --size 8 --samples 4096 --quiet 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    for (const char* f : {"rep/report.json", "rep/report.md", "rep/histograms.json", "rep/histograms.csv", "rep/histograms_sun.png", "lut.exr"})
        EXPECT_TRUE(fs::exists(path(f))) << f;
    std::ifstream in(path("rep/report.json"));
    const auto j = nlohmann::json::parse(in);
    EXPECT_LE(j["coverage"]["baked_texels"].get<std::uint64_t>(), j["coverage"]["texels"].get<std::uint64_t>());
    EXPECT_TRUE(j["verdict"].contains("default_serves"));
    EXPECT_GT(j["time"]["full_bake_seconds"].get<double>(), 0.0);
    // On the example the azimuth matters (V is 50 degrees off the plane's normal): the floor is far above
    // its error bounds (measured 0.080 against 0.006 + 0.003).
    const auto& errors = j["lights"][0]["errors"];
    EXPECT_GT(errors["azimuth_mean_floor"]["term_max_abs"].get<double>(),
              errors["azimuth_mean_floor_bound"].get<double>() + errors["reference_bound"].get<double>());
    // The LUT reads back (with or without a coverage record) and serves every lookup of the scene.
    EXPECT_NO_THROW(read_lut(path("lut.exr")));

    // A partial LUT serves its own scene as a `scene --lut` comparator, and stops another scene whose
    // lookups reach rows it did not bake (NdotV 0.8: slices 5 and 6, of which only 5 was baked): exit 2,
    // the comparator and the pixel named, nothing written.
    flat_scene(0.5);
    r = testing::run_shell(cli + " bake --scene " + path("s.toml") + " --scene-layout layout --size 8 --samples 4096 --out " +
                           path("partial.exr") + " --scene-report " + path("rep2") + " --no-scene-compare --quiet 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = testing::run_shell(cli + " scene " + path("s.toml") + " --lut " + path("partial.exr") + " --out " + path("own") +
                           " --no-seed-luts --tolerance 0.05 --quiet 2>&1");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::string other;
    {
        std::ifstream in(path("s.toml"));
        other.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    other.replace(other.find("[0.8, 0, 0.6]"), 13, "[0.6, 0, 0.8]");
    std::ofstream(path("other.toml")) << other;
    r = testing::run_shell(cli + " scene " + path("other.toml") + " --lut " + path("partial.exr") + " --out " + path("other") +
                           " --no-seed-luts --tolerance 0.05 --quiet 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("comparator lut-partial at pixel (0, 0)"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("did not bake"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(path("other")));
}

}  // namespace
}  // namespace ms
