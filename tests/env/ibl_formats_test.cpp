// IBL outputs in KTX2 and DDS: the DFG LUT (`ibl dfg --out *.ktx2|*.dds`) and the
// prefiltered cubemap mip chain (`ibl prefilter --format ktx2|dds`), read back field by field by a reader
// written here from the KTX 2.0 specification ("File Structure", "Level Index", "Mip Level Array",
// "faceCount") and Microsoft's DDS pages (DDS_HEADER, DDS_HEADER_DXT10, cubic environment maps), not
// from the writers' code; texels compared with the EXR files of the same run within half-float rounding.
// Also the texture layer below the LUT writers (lut/formats/texture.hpp) on its own.
#include <gtest/gtest.h>

#include <Imath/half.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>

#include "cli_runner.hpp"
#include "env/cubemap.hpp"
#include "env/cubemap_file.hpp"
#include "env/image.hpp"
#include "lut/formats/texture.hpp"

namespace {

using namespace ms;

std::vector<std::uint8_t> slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Bytes {
    const std::vector<std::uint8_t>& b;
    std::uint32_t u16(std::size_t at) const { return std::uint32_t(b.at(at)) | std::uint32_t(b.at(at + 1)) << 8; }
    std::uint32_t u32(std::size_t at) const { return u16(at) | u16(at + 2) << 16; }
    std::uint64_t u64(std::size_t at) const { return u32(at) | std::uint64_t(u32(at + 4)) << 32; }
    float f32(std::size_t at) const {
        const std::uint32_t x = u32(at);
        float f;
        std::memcpy(&f, &x, 4);
        return f;
    }
    float f16(std::size_t at) const {
        Imath::half h;
        h.setBits(std::uint16_t(u16(at)));
        return float(h);
    }
};

// Half-float rounding (round to nearest): at most 2^-11 relative, plus the smallest subnormal step.
double half_allowed(float v) { return std::abs(v) * std::ldexp(1.0, -11) + std::ldexp(1.0, -25); }

// A KTX2 file read field by field (KTX 2.0 specification, "File Structure").
struct Ktx2 {
    std::uint32_t vk_format = 0, type_size = 0, width = 0, height = 0, depth = 0, layers = 0, faces = 0, levels = 0, scheme = 0;
    struct Level {
        std::uint64_t offset = 0, length = 0, uncompressed = 0;
    };
    std::vector<Level> level;
    std::map<std::string, std::string> kv;
    std::vector<std::string> key_order;
};

Ktx2 read_ktx2(const std::vector<std::uint8_t>& b, std::uint32_t texel_bytes) {
    Bytes r{b};
    Ktx2 k;
    const std::uint8_t id[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    EXPECT_EQ(std::memcmp(b.data(), id, 12), 0);
    k.vk_format = r.u32(12), k.type_size = r.u32(16), k.width = r.u32(20), k.height = r.u32(24), k.depth = r.u32(28);
    k.layers = r.u32(32), k.faces = r.u32(36), k.levels = r.u32(40), k.scheme = r.u32(44);
    const std::uint32_t dfd_off = r.u32(48), dfd_len = r.u32(52), kvd_off = r.u32(56), kvd_len = r.u32(60);
    EXPECT_EQ(r.u64(64), 0u);  // sgdByteOffset
    EXPECT_EQ(r.u64(72), 0u);  // sgdByteLength
    for (std::uint32_t p = 0; p < std::max(1u, k.levels); ++p)
        k.level.push_back({r.u64(80 + 24 * p), r.u64(88 + 24 * p), r.u64(96 + 24 * p)});
    // The DFD follows the level index; dfdTotalSize = dfdByteLength; the KVD follows the DFD.
    EXPECT_EQ(dfd_off, 80 + 24 * std::max(1u, k.levels));
    EXPECT_EQ(r.u32(dfd_off), dfd_len);
    EXPECT_EQ(kvd_off, dfd_off + dfd_len);
    // The DFD's bytesPlane0 is the texel size.
    EXPECT_EQ(r.u32(dfd_off + 20) & 0xFF, texel_bytes);
    for (std::size_t at = kvd_off; at < kvd_off + kvd_len;) {
        const std::uint32_t n = r.u32(at);
        const std::string kv(reinterpret_cast<const char*>(b.data() + at + 4), n);
        const std::size_t nul = kv.find('\0');
        std::string value = kv.substr(nul + 1);
        if (!value.empty() && value.back() == '\0') value.pop_back();
        k.key_order.push_back(kv.substr(0, nul));
        k.kv[kv.substr(0, nul)] = value;
        at += 4 + (n + 3) / 4 * 4;
    }
    EXPECT_TRUE(std::is_sorted(k.key_order.begin(), k.key_order.end()));
    // Mip level array: smallest level first, each level at a multiple of lcm(texel size, 4), the base
    // level last and ending at the end of the file.
    const std::uint64_t align = std::lcm<std::uint64_t>(texel_bytes, 4);
    for (std::size_t p = 0; p < k.level.size(); ++p) {
        EXPECT_EQ(k.level[p].offset % align, 0u) << "level " << p;
        EXPECT_EQ(k.level[p].length, k.level[p].uncompressed) << "level " << p;
        EXPECT_GE(k.level[p].offset, kvd_off + kvd_len);
        if (p + 1 < k.level.size()) EXPECT_LE(k.level[p + 1].offset + k.level[p + 1].length, k.level[p].offset) << "level " << p;
    }
    EXPECT_EQ(k.level[0].offset + k.level[0].length, b.size());
    return k;
}

// DDS header fields (offsets from the start of the file, after the 4-byte magic).
struct Dds {
    std::uint32_t flags, height, width, pitch, depth, mips, pf_flags, fourcc, caps, caps2, dxgi, dimension, misc, array_size, misc2;
};
Dds read_dds(const std::vector<std::uint8_t>& b) {
    Bytes r{b};
    EXPECT_EQ(r.u32(0), 0x20534444u);  // "DDS "
    EXPECT_EQ(r.u32(4), 124u);
    EXPECT_EQ(r.u32(76), 32u);  // DDS_PIXELFORMAT.dwSize
    return {r.u32(8),  r.u32(12), r.u32(16), r.u32(20), r.u32(24), r.u32(28),  r.u32(80), r.u32(84),
            r.u32(108), r.u32(112), r.u32(128), r.u32(132), r.u32(136), r.u32(140), r.u32(144)};
}
constexpr std::size_t kDdsData = 148;

class IblFormats : public ms::testing::ScratchDirTest {
protected:
    IblFormats() : ScratchDirTest("ibl_formats") {}
    static std::string cli() { return std::string(MICROSHADOW_CLI); }
};

TEST_F(IblFormats, TextureLayerWritesA3ChannelTextureWithAlphaFill) {
    // The layer below the LUT writers on its own: 3 x 2, RGB data, A = 1, float32 (exact).
    lutfmt::TextureData t;
    t.width = 3, t.height = 2, t.channels = 3, t.alpha = 1.0f;
    t.levels = {{0.1f, 0.2f, 0.3f, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15}};
    t.metadata = {{"note", "t"}};
    lutfmt::write_ktx2_texture(path("t.ktx2"), t, lutfmt::PixelEncoding::float32);
    const auto b = slurp(path("t.ktx2"));
    const Ktx2 k = read_ktx2(b, 16);
    EXPECT_EQ(k.vk_format, 109u);  // VK_FORMAT_R32G32B32A32_SFLOAT
    EXPECT_EQ(k.width, 3u);
    EXPECT_EQ(k.height, 2u);
    EXPECT_EQ(k.depth, 0u);
    EXPECT_EQ(k.faces, 1u);
    EXPECT_EQ(k.levels, 1u);
    EXPECT_EQ(k.kv.at("KTXorientation"), "rd");
    EXPECT_EQ(nlohmann::json::parse(k.kv.at("microshadow")).at("note"), "t");
    Bytes r{b};
    for (std::size_t i = 0; i < 6; ++i) {
        for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(r.f32(k.level[0].offset + i * 16 + c * 4), t.levels[0][i * 3 + c]);
        EXPECT_EQ(r.f32(k.level[0].offset + i * 16 + 12), 1.0f);
    }
    // Wrong data lengths and shapes are refused, naming the field.
    t.levels[0].pop_back();
    EXPECT_THROW(lutfmt::write_ktx2_texture(path("bad.ktx2"), t, lutfmt::PixelEncoding::float32), std::invalid_argument);
    t.levels[0].push_back(15);
    t.faces = 6;
    EXPECT_THROW(lutfmt::write_dds_texture(path("bad.dds"), t, lutfmt::PixelEncoding::float32), std::invalid_argument);
    EXPECT_FALSE(std::filesystem::exists(path("bad.ktx2")));
    EXPECT_FALSE(std::filesystem::exists(path("bad.dds")));
}

TEST_F(IblFormats, DfgLutKtx2AndDdsReadBackEqualToTheExr) {
    const std::string args = " --method sampled --size 8 --samples 1024 --quiet 2>&1";
    for (const std::string out : {"dfg.exr", "dfg.ktx2"}) {
        const auto res = ms::testing::run_shell(cli() + " ibl dfg --out " + path(out) + args);
        ASSERT_EQ(res.exit_code, 0) << res.output;
    }
    const auto res = ms::testing::run_shell(cli() + " ibl dfg --half --out " + path("dfg.dds") + args);
    ASSERT_EQ(res.exit_code, 0) << res.output;
    nlohmann::json exr_meta;
    const env::Image exr = env::read_exr_rgb(path("dfg.exr"), &exr_meta);
    ASSERT_EQ(exr.width, 8u);
    ASSERT_EQ(exr.height, 8u);

    // KTX2, float32: the EXR's floats exactly; A repeats E.
    const auto kb = slurp(path("dfg.ktx2"));
    const Ktx2 k = read_ktx2(kb, 16);
    EXPECT_EQ(k.vk_format, 109u);
    EXPECT_EQ(k.type_size, 4u);
    EXPECT_EQ(k.width, 8u);
    EXPECT_EQ(k.height, 8u);
    EXPECT_EQ(k.depth, 0u);
    EXPECT_EQ(k.layers, 0u);
    EXPECT_EQ(k.faces, 1u);
    EXPECT_EQ(k.levels, 1u);
    EXPECT_EQ(k.scheme, 0u);
    EXPECT_EQ(k.kv.at("KTXorientation"), "rd");
    const auto meta = nlohmann::json::parse(k.kv.at("microshadow"));
    EXPECT_EQ(meta.at("layout"), "dfg");
    EXPECT_EQ(meta.at("file_format"), "ktx2-2d");
    // float32: the quadrature's doubles rounded to float (half the spacing at the largest value, <= 1).
    EXPECT_GT(meta.at("error_budget").at("quantisation").get<double>(), 0.0);
    EXPECT_LE(meta.at("error_budget").at("quantisation").get<double>(), std::ldexp(1.0, -24));
    EXPECT_GT(meta.at("error_budget").at("sampling").get<double>(), 0.0);
    Bytes kr{kb};
    double worst_ktx2 = 0;
    for (std::uint32_t y = 0; y < 8; ++y)
        for (std::uint32_t x = 0; x < 8; ++x) {
            const std::size_t at = k.level[0].offset + (std::size_t(y) * 8 + x) * 16;
            for (int c = 0; c < 3; ++c) worst_ktx2 = std::max(worst_ktx2, double(std::abs(kr.f32(at + 4 * c) - exr.at(x, y, c))));
            EXPECT_EQ(kr.f32(at + 12), exr.at(x, y, 2));
        }
    EXPECT_EQ(worst_ktx2, 0.0);

    // DDS, float16 (--half): within half rounding of the float EXR.
    const auto db = slurp(path("dfg.dds"));
    const Dds d = read_dds(db);
    EXPECT_EQ(d.width, 8u);
    EXPECT_EQ(d.height, 8u);
    EXPECT_EQ(d.pitch, 8u * 8);
    EXPECT_EQ(d.mips, 1u);
    EXPECT_EQ(d.fourcc, 0x30315844u);  // "DX10"
    EXPECT_EQ(d.caps2, 0u);
    EXPECT_EQ(d.dxgi, 10u);  // DXGI_FORMAT_R16G16B16A16_FLOAT
    EXPECT_EQ(d.dimension, 3u);
    EXPECT_EQ(d.misc, 0u);
    EXPECT_EQ(d.array_size, 1u);
    ASSERT_EQ(db.size(), kDdsData + 8 * 8 * 8);
    Bytes dr{db};
    double worst_dds = 0;
    for (std::uint32_t y = 0; y < 8; ++y)
        for (std::uint32_t x = 0; x < 8; ++x)
            for (int c = 0; c < 4; ++c) {
                const float want = exr.at(x, y, std::min(c, 2));
                const float got = dr.f16(kDdsData + (std::size_t(y) * 8 + x) * 8 + 2 * c);
                EXPECT_LE(std::abs(got - want), half_allowed(want)) << x << " " << y << " " << c;
                worst_dds = std::max(worst_dds, double(std::abs(got - want)));
            }
    std::ifstream side(path("dfg.dds.json"));
    const auto dmeta = nlohmann::json::parse(side);
    EXPECT_EQ(dmeta.at("file_format"), "dds-2d");
    EXPECT_EQ(dmeta.at("encoding"), "float16");
    // The half rounding measured, plus the float32 rounding before it (<= 2^-24 for values <= 1).
    EXPECT_GE(dmeta.at("error_budget").at("quantisation").get<double>(), worst_dds);
    EXPECT_NEAR(dmeta.at("error_budget").at("quantisation").get<double>(), worst_dds, std::ldexp(1.0, -24));
    std::printf("[ibl formats] DFG 8x8: KTX2 float32 max |diff| %.3g, DDS float16 max |diff| %.3g\n", worst_ktx2, worst_dds);
    RecordProperty("dfg_dds_half_max_abs", std::to_string(worst_dds));
}

// The sky of the cubemap test: every face and orientation distinguishable (R, G, B follow x, y, z).
std::array<double, 3> sky(const env::Dir& d) { return {2 + d.x, 2 + 1.5 * d.y, 2 + 0.5 * d.z + 0.25 * d.x * d.y}; }

TEST_F(IblFormats, PrefilteredCubemapKtx2AndDdsReadBackEqualToTheExrFaces) {
    const std::uint32_t n = 16, levels = 3;
    env::Cubemap cube(n);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const auto v = sky(env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1));
                for (int c = 0; c < 3; ++c) cube.texel(f, x, y)[c] = float(v[c]);
            }
    env::write_exr(path("sky.exr"), env::cross_image(cube), {{"note", "test"}});
    const std::string args = " --levels 3 --samples 64 --irradiance-size 4 --threads 2 --quiet 2>&1";
    for (const char* format : {"exr", "ktx2", "dds"}) {
        const auto res = ms::testing::run_shell(cli() + " ibl prefilter " + path("sky.exr") + " --out " + path(std::string("out_") + format) +
                                                " --format " + format + (std::string(format) == "exr" ? "" : " --dfg-size 4") + args);
        ASSERT_EQ(res.exit_code, 0) << res.output;
    }
    // The EXR crosses: face f of mip m at its offset in the cross.
    std::vector<env::Image> crosses;
    for (std::uint32_t m = 0; m < levels; ++m) crosses.push_back(env::read_exr_rgb(path("out_exr/specular_m" + std::to_string(m) + ".exr")));
    auto exr_texel = [&](std::uint32_t m, int f, std::uint32_t x, std::uint32_t y, int c) {
        std::uint32_t ox, oy;
        env::cross_face_offset(f, n >> m, ox, oy);
        return crosses[m].at(ox + x, oy + y, c);
    };
    EXPECT_FALSE(std::filesystem::exists(path("out_ktx2/specular_m0.exr")));
    EXPECT_TRUE(std::filesystem::exists(path("out_ktx2/dfg.ktx2")));  // --dfg-size follows --format
    EXPECT_TRUE(std::filesystem::exists(path("out_dds/dfg.dds")));
    // The SH irradiance follows --format too: one RGBA16F cubemap level whose faces are the EXR run's cross.
    EXPECT_FALSE(std::filesystem::exists(path("out_ktx2/irradiance.exr")));
    EXPECT_TRUE(std::filesystem::exists(path("out_dds/irradiance.dds")));
    {
        const env::Image irr = env::read_exr_rgb(path("out_exr/irradiance.exr"));
        const std::uint32_t s = irr.width / 4;
        const auto ib = slurp(path("out_ktx2/irradiance.ktx2"));
        const Ktx2 ik = read_ktx2(ib, 8);
        EXPECT_EQ(ik.vk_format, 97u);
        EXPECT_EQ(ik.faces, 6u);
        EXPECT_EQ(ik.levels, 1u);
        EXPECT_EQ(ik.width, s);
        Bytes ir{ib};
        for (int f = 0; f < 6; ++f) {
            std::uint32_t ox, oy;
            env::cross_face_offset(f, s, ox, oy);
            for (std::uint32_t y = 0; y < s; ++y)
                for (std::uint32_t x = 0; x < s; ++x)
                    for (int c = 0; c < 3; ++c) {
                        const float want = irr.at(ox + x, oy + y, c);
                        const float got = ir.f16(ik.level[0].offset + ((std::size_t(f) * s + y) * s + x) * 8 + 2 * c);
                        ASSERT_LE(std::abs(got - want), half_allowed(want)) << "face " << f << " (" << x << ", " << y << ") " << c;
                    }
        }
    }

    // KTX2 cubemap (KTX 2.0: faceCount 6, pixelDepth 0, layerCount 0, levelCount = mips, every mip in the
    // level index; each level's faces +X -X +Y -Y +Z -Z, rows top first).
    const auto kb = slurp(path("out_ktx2/specular.ktx2"));
    const Ktx2 k = read_ktx2(kb, 8);
    EXPECT_EQ(k.vk_format, 97u);  // VK_FORMAT_R16G16B16A16_SFLOAT
    EXPECT_EQ(k.type_size, 2u);
    EXPECT_EQ(k.width, n);
    EXPECT_EQ(k.height, n);
    EXPECT_EQ(k.depth, 0u);
    EXPECT_EQ(k.layers, 0u);
    EXPECT_EQ(k.faces, 6u);
    EXPECT_EQ(k.levels, levels);
    EXPECT_EQ(k.scheme, 0u);
    ASSERT_EQ(k.level.size(), levels);
    EXPECT_EQ(k.kv.at("KTXorientation"), "rd");
    const auto meta = nlohmann::json::parse(k.kv.at("microshadow"));
    EXPECT_EQ(meta.at("file_format"), "ktx2-cubemap");
    EXPECT_EQ(meta.at("mip_roughness").size(), levels);
    Bytes kr{kb};
    double worst_abs = 0, worst_rel = 0;
    for (std::uint32_t m = 0; m < levels; ++m) {
        const std::uint32_t s = n >> m;
        EXPECT_EQ(k.level[m].length, 6ull * s * s * 8) << "level " << m;
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < s; ++y)
                for (std::uint32_t x = 0; x < s; ++x) {
                    const std::size_t at = k.level[m].offset + ((std::size_t(f) * s + y) * s + x) * 8;
                    for (int c = 0; c < 3; ++c) {
                        const float want = exr_texel(m, f, x, y, c), got = kr.f16(at + 2 * c);
                        ASSERT_LE(std::abs(got - want), half_allowed(want)) << "mip " << m << " face " << f << " (" << x << ", " << y << ") " << c;
                        worst_abs = std::max(worst_abs, double(std::abs(got - want)));
                        worst_rel = std::max(worst_rel, double(std::abs(got - want)) / std::abs(want));
                    }
                    ASSERT_EQ(kr.f16(at + 6), 1.0f);
                }
    }
    EXPECT_NEAR(meta.at("quantisation").at("max_abs").get<double>(), worst_abs, 1e-12);
    // The project's own reader (env/cubemap_file.hpp), as the IBL commands read a cube: the same texels.
    for (const char* name : {"out_ktx2/specular.ktx2", "out_dds/specular.dds"}) {
        const env::CubemapFile file = env::read_cubemap_file(path(name));
        EXPECT_EQ(file.encoding, "float16");
        EXPECT_EQ(file.metadata.at("mip_roughness"), meta.at("mip_roughness")) << name;
        ASSERT_EQ(file.levels.size(), levels) << name;
        for (std::uint32_t m = 0; m < levels; ++m)
            for (int f = 0; f < 6; ++f)
                for (std::uint32_t y = 0; y < (n >> m); ++y)
                    for (std::uint32_t x = 0; x < (n >> m); ++x)
                        for (int c = 0; c < 3; ++c) {
                            const float want = exr_texel(m, f, x, y, c), got = file.levels[m].texel(f, x, y)[c];
                            ASSERT_LE(std::abs(got - want), half_allowed(want)) << name << " mip " << m << " face " << f << " (" << x << ", " << y << ") " << c;
                        }
    }

    // DDS cubemap: DDSCAPS2_CUBEMAP | ALLFACES, DX10 TEXTURE2D with miscFlag TEXTURECUBE, arraySize 1;
    // the data face by face, each face's mips base first.
    const auto db = slurp(path("out_dds/specular.dds"));
    const Dds d = read_dds(db);
    EXPECT_NE(d.flags & 0x20000u, 0u);  // DDSD_MIPMAPCOUNT
    EXPECT_EQ(d.width, n);
    EXPECT_EQ(d.height, n);
    EXPECT_EQ(d.depth, 0u);
    EXPECT_EQ(d.mips, levels);
    EXPECT_EQ(d.pf_flags, 0x4u);  // DDPF_FOURCC
    EXPECT_EQ(d.fourcc, 0x30315844u);
    EXPECT_EQ(d.caps, 0x1000u | 0x8u | 0x400000u);  // TEXTURE | COMPLEX | MIPMAP
    EXPECT_EQ(d.caps2, 0x200u | 0xFC00u);           // CUBEMAP | all six faces
    EXPECT_EQ(d.dxgi, 10u);
    EXPECT_EQ(d.dimension, 3u);
    EXPECT_EQ(d.misc, 0x4u);
    EXPECT_EQ(d.array_size, 1u);
    Bytes dr{db};
    std::size_t at = kDdsData;
    double worst_dds = 0;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t m = 0; m < levels; ++m) {
            const std::uint32_t s = n >> m;
            for (std::uint32_t y = 0; y < s; ++y)
                for (std::uint32_t x = 0; x < s; ++x, at += 8) {
                    for (int c = 0; c < 3; ++c) {
                        const float want = exr_texel(m, f, x, y, c), got = dr.f16(at + 2 * c);
                        ASSERT_LE(std::abs(got - want), half_allowed(want)) << "face " << f << " mip " << m << " (" << x << ", " << y << ") " << c;
                        worst_dds = std::max(worst_dds, double(std::abs(got - want)));
                    }
                    ASSERT_EQ(dr.f16(at + 6), 1.0f);
                }
        }
    EXPECT_EQ(at, db.size());
    std::ifstream side(path("out_dds/specular.dds.json"));
    EXPECT_EQ(nlohmann::json::parse(side).at("file_format"), "dds-cubemap");
    std::printf("[ibl formats] cubemap 16^2 x 3 mips, float16: KTX2 max |diff| %.3g (relative %.3g), DDS max |diff| %.3g\n", worst_abs,
                worst_rel, worst_dds);
    RecordProperty("cubemap_half_max_abs", std::to_string(worst_abs));
    RecordProperty("cubemap_half_max_relative", std::to_string(worst_rel));
}

// The direct-convolution irradiance cubemap (ibl irradiance --format ktx2 --encoding float32): one level, faceCount 6,
// its texels equal to the EXR cross's faces bit for bit, A = 1; DDS (float16) within half rounding.
TEST_F(IblFormats, IrradianceCubemapKtx2AndDdsReadBackEqualToTheExrCross) {
    const std::uint32_t n = 16, out = 4;
    env::Cubemap cube(n);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const auto v = sky(env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1));
                for (int c = 0; c < 3; ++c) cube.texel(f, x, y)[c] = float(v[c]);
            }
    env::write_exr(path("sky.exr"), env::cross_image(cube), {{"note", "test"}});
    for (const char* format : {"exr", "ktx2", "dds"}) {
        const auto res = ms::testing::run_shell(cli() + " ibl irradiance " + path("sky.exr") + " --out " + path(std::string("i_") + format) +
                                                " --format " + format + " --face-size 4 --source-size 8 --quiet" +
                                                (std::string(format) == "ktx2" ? " --encoding float32" : "") + " 2>&1");
        ASSERT_EQ(res.exit_code, 0) << res.output;
    }
    const env::Image cross = env::read_exr_rgb(path("i_exr/irradiance.exr"));
    auto want = [&](int f, std::uint32_t x, std::uint32_t y, int c) {
        std::uint32_t ox, oy;
        env::cross_face_offset(f, out, ox, oy);
        return cross.at(ox + x, oy + y, c);
    };
    const auto kb = slurp(path("i_ktx2/irradiance.ktx2"));
    const Ktx2 k = read_ktx2(kb, 16);
    EXPECT_EQ(k.vk_format, 109u);  // VK_FORMAT_R32G32B32A32_SFLOAT
    EXPECT_EQ(k.width, out);
    EXPECT_EQ(k.faces, 6u);
    EXPECT_EQ(k.levels, 1u);
    EXPECT_EQ(nlohmann::json::parse(k.kv.at("microshadow")).at("file_format"), "ktx2-cubemap");
    Bytes kr{kb};
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < out; ++y)
            for (std::uint32_t x = 0; x < out; ++x) {
                const std::size_t at = k.level[0].offset + ((std::size_t(f) * out + y) * out + x) * 16;
                for (int c = 0; c < 3; ++c) ASSERT_EQ(kr.f32(at + 4 * c), want(f, x, y, c)) << f << " " << x << " " << y << " " << c;
                ASSERT_EQ(kr.f32(at + 12), 1.0f);
            }
    const auto db = slurp(path("i_dds/irradiance.dds"));
    const Dds d = read_dds(db);
    EXPECT_EQ(d.width, out);
    EXPECT_EQ(d.dxgi, 10u);  // DXGI_FORMAT_R16G16B16A16_FLOAT
    Bytes dr{db};
    for (int f = 0; f < 6; ++f)  // one level: the faces one after the other
        for (std::uint32_t y = 0; y < out; ++y)
            for (std::uint32_t x = 0; x < out; ++x)
                for (int c = 0; c < 3; ++c) {
                    const std::size_t at = kDdsData + ((std::size_t(f) * out + y) * out + x) * 8 + 2 * c;
                    ASSERT_LE(std::abs(dr.f16(at) - want(f, x, y, c)), half_allowed(want(f, x, y, c)));
                }
}

TEST_F(IblFormats, UnknownExtensionsAndEncodingsAreRefused) {
    const auto png = ms::testing::run_shell(cli() + " ibl dfg --out " + path("dfg.tga") + " --size 4 --samples 1024 --quiet 2>&1");
    EXPECT_NE(png.exit_code, 0);
    EXPECT_NE(png.output.find(".ktx2"), std::string::npos) << png.output;
    EXPECT_FALSE(std::filesystem::exists(path("dfg.tga")));
    // unorm would clip radiance above 1: the cubemap takes float16 or float32 only.
    const auto enc = ms::testing::run_shell(cli() + " ibl prefilter " + path("none.exr") + " --out " + path("o") +
                                            " --format ktx2 --encoding unorm8 --quiet 2>&1");
    EXPECT_NE(enc.exit_code, 0);
    EXPECT_NE(enc.output.find("--encoding"), std::string::npos) << enc.output;
}

}  // namespace
