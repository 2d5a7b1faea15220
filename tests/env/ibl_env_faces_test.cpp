// Six face files as the environment of `ibl prefilter` / `ibl sh`: faces cut out of a
// horizontal cross give the same prefiltered chain and the same SH as the cross, bit for bit, and the
// checks on the six files (count, square, equal sizes) fail with exit status 2 naming the file.
#include <gtest/gtest.h>

#include <fstream>

#include "cli_runner.hpp"
#include "env/cubemap.hpp"
#include "env/image.hpp"

namespace {

using namespace ms;

class IblEnvFaces : public ms::testing::ScratchDirTest {
protected:
    IblEnvFaces() : ScratchDirTest("ibl_faces") {}

    // A 4n x 3n horizontal cross whose every texel differs (so a face swapped, flipped or rotated shows),
    // and its six faces cut out of the image by the layout docs/ibl.md gives, not through the library.
    void write_cross_and_faces(std::uint32_t n) {
        env::Image cross(4 * n, 3 * n, {"R", "G", "B"});
        for (std::uint32_t y = 0; y < 3 * n; ++y)
            for (std::uint32_t x = 0; x < 4 * n; ++x) {
                cross.at(x, y, 0) = 1.0f + 0.01f * float(x);
                cross.at(x, y, 1) = 1.0f + 0.02f * float(y);
                cross.at(x, y, 2) = 1.0f + float((x * 7 + y * 13) % 17);
            }
        env::write_exr(path("cross.exr"), cross, {{"note", "test"}});
        // +X -X +Y -Y +Z -Z at (column, row) of the cross: (2,1) (0,1) (1,0) (1,2) (1,1) (3,1).
        const std::uint32_t col[6] = {2, 0, 1, 1, 1, 3}, row[6] = {1, 1, 0, 2, 1, 1};
        const char* name[6] = {"px", "nx", "py", "ny", "pz", "nz"};
        for (int f = 0; f < 6; ++f) {
            env::Image face(n, n, {"R", "G", "B"});
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x)
                    for (std::uint32_t c = 0; c < 3; ++c) face.at(x, y, c) = cross.at(col[f] * n + x, row[f] * n + y, c);
            env::write_exr(path(std::string(name[f]) + ".exr"), face, {{"face", name[f]}});
        }
    }
    std::string faces_args() const {
        std::string s = " --faces";
        for (const char* f : {"px", "nx", "py", "ny", "pz", "nz"}) s += " " + path(std::string(f) + ".exr");
        return s;
    }
};

TEST_F(IblEnvFaces, SixFacesCutFromACrossPrefilterLikeTheCross) {
    write_cross_and_faces(16);
    const std::string common = " --samples 64 --irradiance-size 4 --threads 2 --quiet --format exr";
    const std::string cli = std::string(MICROSHADOW_CLI) + " ibl prefilter ";
    auto a = ms::testing::run_shell(cli + path("cross.exr") + " --out " + path("a") + common + " 2>&1");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    auto b = ms::testing::run_shell(cli + "--out " + path("b") + faces_args() + common + " 2>&1");
    ASSERT_EQ(b.exit_code, 0) << b.output;
    for (int m = 0; m < 3; ++m) {
        const std::string file = "/specular_m" + std::to_string(m) + ".exr";
        const env::Image x = env::read_exr_rgb(path("a") + file), y = env::read_exr_rgb(path("b") + file);
        ASSERT_EQ(x.width, y.width);
        ASSERT_EQ(x.height, y.height);
        // The same cubemap in, the same deterministic estimator: the same bits out.
        EXPECT_EQ(x.data, y.data) << file;
    }
    const env::Image ia = env::read_exr_rgb(path("a/irradiance.exr")), ib = env::read_exr_rgb(path("b/irradiance.exr"));
    EXPECT_EQ(ia.data, ib.data);
    nlohmann::json meta;
    std::ifstream(path("b/ibl.json")) >> meta;
    EXPECT_NE(meta.at("specular").at("source").get<std::string>().find("pz.exr"), std::string::npos);
}

TEST_F(IblEnvFaces, ShOfSixFacesEqualsShOfTheCross) {
    write_cross_and_faces(8);
    const std::string cli = std::string(MICROSHADOW_CLI) + " ibl sh ";
    auto a = ms::testing::run_shell(cli + path("cross.exr") + " --out " + path("a.json") + " --quiet 2>&1");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    auto b = ms::testing::run_shell(cli + "--out " + path("b.json") + faces_args() + " --quiet 2>&1");
    ASSERT_EQ(b.exit_code, 0) << b.output;
    nlohmann::json ja, jb;
    std::ifstream(path("a.json")) >> ja;
    std::ifstream(path("b.json")) >> jb;
    EXPECT_EQ(ja.at("radiance_sh"), jb.at("radiance_sh"));
}

TEST_F(IblEnvFaces, BadFaceSetsAreRefusedWithTheFileNamed) {
    write_cross_and_faces(8);
    const std::string cli = std::string(MICROSHADOW_CLI) + " ibl prefilter --out " + path("o") + " --quiet";
    // Five files: CLI11 wants six.
    auto r = ms::testing::run_shell(cli + " --faces " + path("px.exr") + " " + path("nx.exr") + " " + path("py.exr") + " " +
                                    path("ny.exr") + " " + path("pz.exr") + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    // A face of another size.
    env::write_exr(path("small.exr"), env::Image(4, 4, {"R", "G", "B"}), {});
    std::string args = faces_args();
    args.replace(args.find(path("ny.exr")), path("ny.exr").size(), path("small.exr"));
    r = ms::testing::run_shell(cli + args + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("face -Y (" + path("small.exr")), std::string::npos) << r.output;
    // A face that is not square.
    env::write_exr(path("wide.exr"), env::Image(16, 8, {"R", "G", "B"}), {});
    args = faces_args();
    args.replace(args.find(path("pz.exr")), path("pz.exr").size(), path("wide.exr"));
    r = ms::testing::run_shell(cli + args + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("must be square"), std::string::npos) << r.output;
    // A face file that does not exist, and ENV together with --faces.
    args = faces_args();
    args.replace(args.find(path("nz.exr")), path("nz.exr").size(), path("missing.exr"));
    r = ms::testing::run_shell(cli + args + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("missing.exr"), std::string::npos) << r.output;
    r = ms::testing::run_shell(cli + " " + path("cross.exr") + faces_args() + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_FALSE(std::filesystem::exists(path("o/specular_m0.exr")));
}

}  // namespace
