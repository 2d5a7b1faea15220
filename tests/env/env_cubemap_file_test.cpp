// env/cubemap_file.hpp: one-file mipped cubemaps (KTX2, DDS + sidecar) read back as the cubemaps the
// IBL jobs compute with; every environment reader and command takes one (its base level); forged files
// are refused with one line naming the file and the reason.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "cli_runner.hpp"
#include "env/cubemap.hpp"
#include "env/cubemap_file.hpp"
#include "env/image.hpp"
#include "lut/formats/texture.hpp"

namespace {

using namespace ms;

class EnvCubemapFile : public ms::testing::ScratchDirTest {
protected:
    EnvCubemapFile() : ScratchDirTest("env_cubemap_file") {}

    // A chain of `levels` cubemaps, base n, every texel distinct (level, face, x, y, channel).
    static lutfmt::TextureData chain(std::uint32_t n, std::uint32_t levels) {
        lutfmt::TextureData t;
        t.width = t.height = n;
        t.faces = 6;
        t.channels = 3;
        t.alpha = 1.0f;
        for (std::uint32_t p = 0; p < levels; ++p) {
            const std::uint32_t s = lutfmt::level_size(n, p);
            std::vector<float> level;
            for (int f = 0; f < 6; ++f)
                for (std::uint32_t y = 0; y < s; ++y)
                    for (std::uint32_t x = 0; x < s; ++x)
                        for (int c = 0; c < 3; ++c) level.push_back(float(p) * 100 + float(f) * 10 + float(x) + float(y) / 16 + float(c) / 64);
            t.levels.push_back(std::move(level));
        }
        t.metadata = {{"file_format", "ktx2-cubemap"}, {"mip_roughness", std::vector<double>(levels, 0.5)}};
        return t;
    }

    std::vector<std::uint8_t> bytes(const std::string& name) const {
        std::ifstream in(path(name), std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    void put(const std::string& name, const std::vector<std::uint8_t>& b) const {
        std::ofstream(path(name), std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
    }
    static void put_u32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
        for (int i = 0; i < 4; ++i) b.at(at + i) = std::uint8_t(v >> (8 * i));
    }
    static void put_u64(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v) {
        for (int i = 0; i < 8; ++i) b.at(at + i) = std::uint8_t(v >> (8 * i));
    }

    // Refused with an EnvironmentError of one line naming the file and holding `reason`.
    void expect_refused(const std::string& name, const std::string& reason) const {
        try {
            env::read_cubemap_file(path(name));
            ADD_FAILURE() << name << " was accepted";
        } catch (const env::EnvironmentError& e) {
            const std::string what = e.what();
            EXPECT_EQ(what.rfind("environment " + path(name) + ": ", 0), 0u) << what;
            EXPECT_NE(what.find(reason), std::string::npos) << name << ": " << what;
            EXPECT_EQ(what.find('\n'), std::string::npos) << what;
        }
    }
};

TEST_F(EnvCubemapFile, Ktx2AndDdsReadBackEveryLevelFaceAndTexel) {
    const lutfmt::TextureData t = chain(8, 4);
    lutfmt::write_ktx2_texture(path("c.ktx2"), t, lutfmt::PixelEncoding::float32);
    lutfmt::write_dds_texture(path("c.dds"), t, lutfmt::PixelEncoding::float16);
    for (const char* name : {"c.ktx2", "c.dds"}) {
        const env::CubemapFile file = env::read_cubemap_file(path(name));
        const bool half = std::string(name) == "c.dds";
        EXPECT_EQ(file.encoding, half ? "float16" : "float32");
        EXPECT_EQ(file.metadata.at("mip_roughness").size(), 4u) << name;
        ASSERT_EQ(file.levels.size(), 4u);
        for (std::uint32_t p = 0; p < 4; ++p) {
            const std::uint32_t s = 8 >> p;
            ASSERT_EQ(file.levels[p].size, s);
            for (int f = 0; f < 6; ++f)
                for (std::uint32_t y = 0; y < s; ++y)
                    for (std::uint32_t x = 0; x < s; ++x)
                        for (int c = 0; c < 3; ++c) {
                            const float want = t.levels[p][((std::size_t(f) * s + y) * s + x) * 3 + c];
                            const float got = file.levels[p].texel(f, x, y)[c];
                            // float32 stores the value; float16 rounds to nearest: 2^-11 relative (no subnormals here).
                            ASSERT_LE(std::abs(got - want), half ? std::abs(want) * std::ldexp(1.0f, -11) : 0.0f)
                                << name << " level " << p << " face " << f << " (" << x << ", " << y << ") " << c;
                        }
        }
    }
}

TEST_F(EnvCubemapFile, EnvironmentReadersTakeTheBaseLevel) {
    const lutfmt::TextureData t = chain(4, 3);
    lutfmt::write_ktx2_texture(path("c.ktx2"), t, lutfmt::PixelEncoding::float32);
    const env::Cubemap base = env::read_cubemap_file(path("c.ktx2")).levels[0];
    const env::Cubemap again = env::cubemap_from_image(env::read_environment_image(path("c.ktx2")));
    ASSERT_EQ(again.size, 4u);
    for (int f = 0; f < 6; ++f) EXPECT_EQ(again.faces[f].data, base.faces[f].data) << "face " << f;
}

TEST_F(EnvCubemapFile, ForgedAndWrongFilesAreRefusedWithOneLine) {
    lutfmt::write_ktx2_texture(path("good.ktx2"), chain(8, 4), lutfmt::PixelEncoding::float32);
    const std::vector<std::uint8_t> good = bytes("good.ktx2");
    auto forged = [&](const std::string& name, auto&& change) {
        std::vector<std::uint8_t> b = good;
        change(b);
        put(name, b);
    };
    // Header fields (KTX 2.0 "File Structure": vkFormat at 12, pixelWidth 20, faceCount 36, levelCount 40;
    // level index from 80: byteOffset, byteLength, uncompressedByteLength per level).
    forged("identifier.ktx2", [](auto& b) { b[5] = '3'; });
    expect_refused("identifier.ktx2", "not a KTX2 file");
    forged("truncated.ktx2", [](auto& b) { b.resize(b.size() - 8); });
    expect_refused("truncated.ktx2", "level");
    forged("faces1.ktx2", [](auto& b) { put_u32(b, 36, 1); });
    expect_refused("faces1.ktx2", "level 0 holds");
    forged("faces5.ktx2", [](auto& b) { put_u32(b, 36, 5); });
    expect_refused("faces5.ktx2", "faceCount 5");
    forged("huge.ktx2", [](auto& b) { put_u32(b, 20, 1u << 20), put_u32(b, 24, 1u << 20); });
    expect_refused("huge.ktx2", "1048576");
    forged("levels.ktx2", [](auto& b) { put_u32(b, 40, 9); });
    expect_refused("levels.ktx2", "mip levels");
    forged("offset.ktx2", [&](auto& b) { put_u64(b, 80, good.size()); });
    expect_refused("offset.ktx2", "level 0");
    forged("length.ktx2", [](auto& b) { put_u64(b, 80 + 24 + 8, 8), put_u64(b, 80 + 24 + 16, 8); });
    expect_refused("length.ktx2", "level 1");
    forged("format.ktx2", [](auto& b) { put_u32(b, 12, 64); });
    expect_refused("format.ktx2", "vkFormat 64");

    // Valid textures that are not radiance cubemaps.
    lutfmt::TextureData flat = chain(8, 1);
    flat.faces = 1;
    flat.levels[0].resize(8 * 8 * 3);
    lutfmt::write_ktx2_texture(path("flat.ktx2"), flat, lutfmt::PixelEncoding::float32);
    expect_refused("flat.ktx2", "not a cubemap (faceCount 6)");
    lutfmt::TextureData bounded = chain(2, 1);
    for (float& v : bounded.levels[0]) v = std::min(v / 100, 1.0f);
    lutfmt::write_ktx2_texture(path("unorm.ktx2"), bounded, lutfmt::PixelEncoding::unorm16);
    expect_refused("unorm.ktx2", "float16 or float32");

    // Values: NaN, infinity, a real negative are named with level, face, texel, channel; filtering's
    // residue (below kNegativeResidue of the largest value) becomes 0 and is counted.
    const struct {
        const char* name;
        float value;
    } bad[] = {{"nan.ktx2", std::numeric_limits<float>::quiet_NaN()}, {"inf.ktx2", std::numeric_limits<float>::infinity()}, {"neg.ktx2", -1.0f}};
    for (const auto& v : bad) {
        lutfmt::TextureData t = chain(4, 3);
        t.levels[1][((std::size_t(3) * 2 + 1) * 2 + 0) * 3 + 2] = v.value;  // level 1, face -Y, (0, 1), B
        lutfmt::write_ktx2_texture(path(v.name), t, lutfmt::PixelEncoding::float32);
        expect_refused(v.name, "level 1 face -Y texel (0, 1) channel B");
    }
    {
        lutfmt::TextureData t = chain(4, 3);
        t.levels[0][5] = -1e-6f;  // largest value 2xx: residue
        lutfmt::write_ktx2_texture(path("residue.ktx2"), t, lutfmt::PixelEncoding::float32);
        const env::CubemapFile f = env::read_cubemap_file(path("residue.ktx2"));
        EXPECT_EQ(f.negative_residue_values, 1u);
        EXPECT_EQ(f.levels[0].texel(0, 1, 0)[2], 0.0f);
    }

    // Not files: refused by stat, without blocking in open() (no writer ever opens the FIFO).
    ASSERT_EQ(::mkfifo(path("pipe.ktx2").c_str(), 0600), 0);
    expect_refused("pipe.ktx2", "is a FIFO (named pipe), not a regular file");
    std::filesystem::create_directory(path("folder.dds"));
    expect_refused("folder.dds", "is a directory, not a regular file");
    expect_refused("missing.ktx2", "cannot open for reading");
    // A DDS's metadata sidecar is optional for radiance (a cube needs no axes); one that is not a file is refused.
    lutfmt::write_dds_texture(path("lonely.dds"), chain(4, 1), lutfmt::PixelEncoding::float16);
    std::filesystem::remove(path("lonely.dds.json"));
    EXPECT_TRUE(env::read_cubemap_file(path("lonely.dds")).metadata.empty());
    std::filesystem::create_directory(path("lonely.dds.json"));
    expect_refused("lonely.dds", "lonely.dds.json: is a directory");
    std::filesystem::copy_file(path("good.ktx2"), path("good.exr"));
    expect_refused("good.exr", ".ktx2 or .dds");
}

// `ibl sh` (like prefilter and irradiance) takes a cubemap file as ENV: the same coefficients as from the
// cross of its base level.
TEST_F(EnvCubemapFile, IblShTakesAKtx2CubeAsItsEnvironment) {
    lutfmt::write_ktx2_texture(path("c.ktx2"), chain(8, 4), lutfmt::PixelEncoding::float32);
    env::write_exr(path("c.exr"), env::cross_image(env::read_cubemap_file(path("c.ktx2")).levels[0]), {});
    const std::string cli = MICROSHADOW_CLI;
    for (const char* in : {"c.ktx2", "c.exr"}) {
        const auto res = ms::testing::run_shell(cli + " ibl sh " + path(in) + " --out " + path(std::string(in) + ".json") + " --quiet 2>&1");
        ASSERT_EQ(res.exit_code, 0) << res.output;
    }
    std::ifstream a(path("c.ktx2.json")), b(path("c.exr.json"));
    const auto ja = nlohmann::json::parse(a), jb = nlohmann::json::parse(b);
    ASSERT_TRUE(ja.contains("radiance_sh")) << ja.dump();
    EXPECT_EQ(ja.at("radiance_sh"), jb.at("radiance_sh"));
    EXPECT_EQ(ja.at("irradiance_sh"), jb.at("irradiance_sh"));
    const auto refused = ms::testing::run_shell(cli + " ibl sh " + path("missing.ktx2") + " --out " + path("m.json") + " --quiet 2>&1");
    EXPECT_EQ(refused.exit_code, 2) << refused.output;
}

// `ibl sh --irradiance F`: the extension picks the format, as for every texture output: a .ktx2 (any case)
// is the cubemap of the .exr cross's texels rounded to float16; an extension no cubemap format has is
// refused before any work, with nothing written.
TEST_F(EnvCubemapFile, IblShWritesItsIrradianceInTheFormatItsExtensionPicks) {
    lutfmt::write_ktx2_texture(path("c.ktx2"), chain(8, 4), lutfmt::PixelEncoding::float32);
    const std::string cli = std::string(MICROSHADOW_CLI) + " ibl sh " + path("c.ktx2") + " --face-size 4 --quiet";
    for (const char* out : {"irr.exr", "irr.KTX2"}) {
        const auto res = ms::testing::run_shell(cli + " --out " + path(std::string(out) + ".json") + " --irradiance " + path(out) + " 2>&1");
        ASSERT_EQ(res.exit_code, 0) << res.output;
    }
    const env::Cubemap cross = env::cubemap_from_image(env::read_exr_rgb(path("irr.exr")));
    const env::CubemapFile cube = env::read_cubemap_file(path("irr.KTX2"));
    ASSERT_EQ(cube.levels.size(), 1u);
    ASSERT_EQ(cube.levels[0].size, 4u);
    EXPECT_EQ(cube.encoding, "float16");
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < 4; ++y)
            for (std::uint32_t x = 0; x < 4; ++x)
                for (int c = 0; c < 3; ++c)
                    EXPECT_EQ(cube.levels[0].texel(f, x, y)[c],
                              lutfmt::half_to_float(lutfmt::float_to_half(cross.texel(f, x, y)[c])))
                        << "face " << f << " (" << x << ", " << y << ") channel " << c;
    const auto refused = ms::testing::run_shell(cli + " --out " + path("p.json") + " --irradiance " + path("irr.png") + " 2>&1");
    EXPECT_EQ(refused.exit_code, 2) << refused.output;
    EXPECT_NE(refused.output.find(".exr, .ktx2 or .dds"), std::string::npos) << refused.output;
    EXPECT_FALSE(std::filesystem::exists(path("p.json")));
    EXPECT_FALSE(std::filesystem::exists(path("irr.png")));
}

}  // namespace
