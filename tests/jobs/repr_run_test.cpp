// The representation bake's job (jobs/repr_run.hpp), which the command and the library share.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

#include <unistd.h>

#include "jobs/repr_run.hpp"
#include "microshadow/lut.hpp"

namespace {

// The file format is chosen by extension in any case (a Windows path written FILE.EXR is an EXR), and
// one message names the formats for every front end.
TEST(ReprRun, TheFileFormatIsChosenByExtensionInAnyCase) {
    EXPECT_EQ(ms::repr::repr_format("a.exr"), ms::repr::ReprFormat::exr);
    EXPECT_EQ(ms::repr::repr_format("a.EXR"), ms::repr::ReprFormat::exr);
    EXPECT_EQ(ms::repr::repr_format("dir/a.Ktx2"), ms::repr::ReprFormat::ktx2);
    EXPECT_EQ(ms::repr::repr_format("a.DDS"), ms::repr::ReprFormat::dds);
    try {
        ms::repr::repr_format("a.png");
        ADD_FAILURE() << "a .png representation was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("written as .exr, .ktx2 or .dds, not a.png"), std::string::npos) << e.what();
    }
}

// The library's bake is the command's job: a custom layout records the domain it was made for (the
// library left it out before), and its checks are the job's, named as the library's.
TEST(ReprRun, TheLibrarysCustomBakeRecordsItsDomainAsTheCommandDoes) {
    microshadow::ReprBakeOptions o;
    o.kind = "azimuth-harmonics";
    o.visibility_count = o.n_dot_l_count = o.n_dot_v_count = 2;
    o.roughness = {0.5, 1.0};
    o.azimuth_nodes = 7;
    o.sampling.backend = microshadow::Backend::oracle;
    const microshadow::LookupFile file = microshadow::repr_bake(o);
    const nlohmann::json meta = nlohmann::json::parse(file.metadata_json());
    ASSERT_TRUE(meta.contains("domain")) << meta.dump();
    EXPECT_EQ(meta.at("domain").at("roughness"), nlohmann::json::array({0.5, 1.0}));
    EXPECT_EQ(meta.at("representation"), "azimuth-harmonics");
    // Saved in upper case, read back the same texels.
    const auto path = std::filesystem::temp_directory_path() / ("microshadow_repr_run_" + std::to_string(::getpid()) + ".EXR");
    file.save(path.string());
    EXPECT_EQ(microshadow::open_file(path.string()).texture(), file.texture());
    std::filesystem::remove(path);

    o.roughness_count = 3;
    try {
        microshadow::repr_bake(o);
        ADD_FAILURE() << "roughness_count above the nodes was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_EQ(std::string(e.what()).rfind("microshadow::repr_bake: ", 0), 0u) << e.what();
        EXPECT_NE(std::string(e.what()).find("between 2 and the number of"), std::string::npos) << e.what();
    }
}

}  // namespace
