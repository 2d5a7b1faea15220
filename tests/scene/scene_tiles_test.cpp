// `microshadow scene` in tiles (sampling.tile_pixels) and with neighbour-predicted sample
// counts (sampling.predict_stride). Known answers: with every query started at min_samples, tiles change
// no pixel (each key is sampled at its grid point on the same points whichever tile holds it), only
// the duplicate count; predicted counts keep every pixel's bound within the tolerance.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cli_runner.hpp"
#include "jobs/eval.hpp"
#include "jobs/scene.hpp"
#include "scene/description.hpp"
#include "scene/inputs.hpp"

namespace ms {
namespace {

using testing::ScratchDirTest;

class SceneTilesTest : public ScratchDirTest {
protected:
    SceneTilesTest() : ScratchDirTest("scene_tiles") {}
    // The example scene (256 x 256) at a loose tolerance and a small first pass (a fast test), with the
    // given sampling keys appended.
    scene::SceneResult run(const std::string& sampling) {
        const std::string example = std::string(MICROSHADOW_SOURCE_DIR) + "/examples/scene/";
        std::ifstream in(example + "scene.toml");
        std::string toml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        for (const char* f : {"normal.png", "ao.png", "roughness.png"})
            std::filesystem::copy_file(example + f, path(f), std::filesystem::copy_options::overwrite_existing);
        std::ofstream(path("s.toml")) << toml << "\nmin_samples = 1024\n" << sampling << "\n";
        const scene::SceneInputs inputs = scene::SceneInputs::load(scene::load_scene(path("s.toml")));
        static std::unique_ptr<TermBackend> backend = make_opencl_backend(ocl::select_devices("default"));
        scene::SceneRunOptions options;
        options.bake_seed_luts = false;
        options.tolerance = 0.03;
        return scene::run_scene(inputs, *backend, options);
    }
};

TEST_F(SceneTilesTest, TilesChangeNoPixelAndPredictedCountsKeepTheBound) {
    const auto whole = run("tile_pixels = 0\npredict_stride = 1");
    const auto tiled = run("tile_pixels = 4099\npredict_stride = 1");  // 17 tiles, the last one short
    ASSERT_EQ(whole.lights.size(), 1u);
    const auto& a = whole.lights[0];
    const auto& b = tiled.lights[0];
    ASSERT_EQ(a.reference.size(), b.reference.size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.reference.size(); ++i) differ += a.reference[i] != b.reference[i] || a.std_error[i] != b.std_error[i];
    EXPECT_EQ(differ, 0u);
    EXPECT_EQ(whole.counts.pixel_lights, tiled.counts.pixel_lights);
    EXPECT_EQ(whole.counts.sampled + whole.counts.duplicates, tiled.counts.sampled + tiled.counts.duplicates);
    for (std::size_t k = 0; k < whole.comparators.size(); ++k) {
        EXPECT_EQ(a.stats[k][0].lit_max_abs, b.stats[k][0].lit_max_abs) << whole.comparators[k];
        EXPECT_EQ(a.stats[k][0].lit_p99, b.stats[k][0].lit_p99) << whole.comparators[k];
    }
    // Predicted counts: the stopping rule is unchanged, so every pixel's bound stays within the tolerance.
    const auto predicted = run("predict_stride = 8");
    EXPECT_EQ(predicted.counts.tolerance_missed, 0u);
    EXPECT_LE(predicted.lights[0].max_error_bound, 0.03);
    EXPECT_EQ(predicted.counts.sampled, whole.counts.sampled);
}

}  // namespace
}  // namespace ms
