// The DFG LUT's engine conventions: chosen channels (Filament's bias, E, sheen; two-channel scale,
// bias), RG16F / RG32F and RGBA16F storage, 16-bit PNG, C header with a chosen symbol, C initialiser
// list (.inc), the sqrt(NdotV) parameterization, each file read back here (readers written from the
// KTX 2.0 / DDS / PNG specifications and the C syntax, not from the writers) against the EXR of the
// same bake.
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <Imath/half.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "cli_runner.hpp"
#include "exact/dfg_exact.hpp"
#include "jobs/ibl_dfg.hpp"

namespace {

using namespace ms;

std::vector<std::uint8_t> slurp(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}
std::uint32_t u32(const std::vector<std::uint8_t>& b, std::size_t at) {
    return std::uint32_t(b[at]) | std::uint32_t(b[at + 1]) << 8 | std::uint32_t(b[at + 2]) << 16 | std::uint32_t(b[at + 3]) << 24;
}
std::uint64_t u64(const std::vector<std::uint8_t>& b, std::size_t at) { return u32(b, at) | std::uint64_t(u32(b, at + 4)) << 32; }
float f32(const std::vector<std::uint8_t>& b, std::size_t at) {
    const std::uint32_t v = u32(b, at);
    float f;
    std::memcpy(&f, &v, 4);
    return f;
}
float f16(const std::vector<std::uint8_t>& b, std::size_t at) {
    half h;
    h.setBits(std::uint16_t(b[at] | b[at + 1] << 8));
    return float(h);
}
float half_bits(unsigned bits) {
    half h;
    h.setBits(std::uint16_t(bits));
    return float(h);
}
// Round to nearest half and back: what a float16 file must hold.
float as_half(float v) { return float(half(v)); }

// Every channel of an EXR as floats, with the channel names in file order (R, G, B, A as present).
struct Exr {
    std::uint32_t width = 0, height = 0;
    std::vector<std::string> names;
    std::vector<std::vector<float>> planes;
    float at(std::uint32_t x, std::uint32_t y, std::size_t c) const { return planes[c][std::size_t(y) * width + x]; }
};
Exr read_exr(const std::string& path) {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    Exr e;
    e.width = std::uint32_t(dw.max.x - dw.min.x + 1);
    e.height = std::uint32_t(dw.max.y - dw.min.y + 1);
    for (const char* n : {"R", "G", "B", "A"})
        if (in.header().channels().findChannel(n)) e.names.push_back(n);
    e.planes.assign(e.names.size(), std::vector<float>(std::size_t(e.width) * e.height));
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < e.names.size(); ++c)
        fb.insert(e.names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(e.planes[c].data()), sizeof(float),
                                         sizeof(float) * e.width));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return e;
}

// A KTX2 2D texture's VkFormat, DFD bytesPlane0 and base level bytes (KTX 2.0 "File Structure").
struct Ktx2 {
    std::uint32_t vk_format = 0, width = 0, height = 0, texel_bytes = 0, dfd_samples = 0;
    std::size_t data = 0;
};
Ktx2 read_ktx2(const std::vector<std::uint8_t>& b) {
    Ktx2 k;
    k.vk_format = u32(b, 12), k.width = u32(b, 20), k.height = u32(b, 24);
    const std::uint32_t dfd = u32(b, 48);
    k.texel_bytes = u32(b, dfd + 20) & 0xff;
    // descriptorBlockSize = 24 + 16 * samples (Khronos Data Format 1.3, basic descriptor block).
    k.dfd_samples = ((u32(b, dfd + 8) >> 16) - 24) / 16;
    k.data = std::size_t(u64(b, 80));
    EXPECT_EQ(u64(b, 88), std::uint64_t(k.width) * k.height * k.texel_bytes);
    return k;
}

// The values of a C header's array or an .inc list: after the comment, every float literal or 0x half
// bits, in order.
std::vector<float> read_c_values(const std::string& text, bool after_brace) {
    std::size_t at = text.find("*/");
    EXPECT_NE(at, std::string::npos);
    if (after_brace) at = text.find("= {", at);
    std::vector<float> out;
    const char* p = text.c_str() + at + 2;
    while (*p) {
        if (*p == '/' && p[1] == '*') {  // a comment: skip it
            const char* end = std::strstr(p, "*/");
            p = end ? end + 2 : p + std::strlen(p);
            continue;
        }
        if (p[0] == '0' && p[1] == 'x') {
            char* end;
            out.push_back(half_bits(unsigned(std::strtoul(p, &end, 16))));
            p = end;
        } else if ((*p >= '0' && *p <= '9') || *p == '-' || *p == '.') {
            char* end;
            out.push_back(std::strtof(p, &end));
            p = end;
            if (*p == 'f') ++p;
        } else {
            ++p;
        }
    }
    return out;
}

// A 16-bit PNG's samples and its iTXt "microshadow" text (libpng, no transforms).
struct Png {
    std::uint32_t width = 0, height = 0;
    int channels = 0, bits = 0;
    std::vector<std::uint16_t> samples;
    std::string text;
};
Png read_png16(const std::string& path) {
    Png p;
    std::FILE* f = std::fopen(path.c_str(), "rb");
    EXPECT_NE(f, nullptr);
    if (!f) return p;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        ADD_FAILURE() << "libpng failed on " << path;
        return p;
    }
    png_init_io(png, f);
    png_read_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
    p.width = png_get_image_width(png, info);
    p.height = png_get_image_height(png, info);
    p.channels = png_get_channels(png, info);
    p.bits = png_get_bit_depth(png, info);
    png_bytepp rows = png_get_rows(png, info);
    for (std::uint32_t y = 0; y < p.height; ++y)
        for (std::uint32_t i = 0; i < p.width * std::uint32_t(p.channels); ++i)
            p.samples.push_back(std::uint16_t(rows[y][2 * i] << 8 | rows[y][2 * i + 1]));  // big-endian
    png_textp text = nullptr;
    const int n = png_get_text(png, info, &text, nullptr);
    for (int i = 0; i < n; ++i)
        if (std::string(text[i].key) == "microshadow") p.text = text[i].text;
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    return p;
}

class IblDfgFormats : public ms::testing::ScratchDirTest {
protected:
    IblDfgFormats() : ScratchDirTest("ibl_dfg_formats") {}
    DfgBakeResult bake(const std::string& channels, DfgParameterization parameterization = DfgParameterization::linear) {
        spec_ = DfgBakeSpec{};
        spec_.n_dot_v.count = 6;
        spec_.roughness.count = 5;
        spec_.method = DfgMethod::exact;
        spec_.channels = parse_dfg_channels(channels);
        spec_.parameterization = parameterization;
        return bake_dfg(spec_);
    }
    DfgBakeSpec spec_;
};

// Filament's layout (bias, E, sheen), three channels: EXR RGB, KTX2 RGBA32F with A repeating sheen,
// DDS RGBA16F, C header (floats, and half bits under another symbol), .inc; each equal to the EXR
// (float32 exactly, float16 to its rounding, the header's %.9g floats exactly).
TEST_F(IblDfgFormats, FilamentLayoutInEveryFormatReadsBackEqualToTheExr) {
    const DfgBakeResult r = bake("bias,E,sheen");
    const nlohmann::json meta = dfg_metadata(spec_, r);
    for (const char* name : {"d.exr", "d.ktx2", "d.h", "d.inc"}) write_dfg_lut(path(name), r, meta, false, "cloth_dfg");
    write_dfg_lut(path("h.dds"), r, meta, true);
    write_dfg_lut(path("h.h"), r, meta, true, "dfg_half");
    const Exr exr = read_exr(path("d.exr"));
    ASSERT_EQ(exr.names, (std::vector<std::string>{"R", "G", "B"}));
    ASSERT_EQ(exr.width, 6u);
    ASSERT_EQ(exr.height, 5u);
    for (std::uint32_t y = 0; y < 5; ++y)
        for (std::uint32_t x = 0; x < 6; ++x) {
            EXPECT_EQ(exr.at(x, y, 0), float(r.at(x, y).bias.term));
            EXPECT_EQ(exr.at(x, y, 1), float(r.at(x, y).albedo.term));
            EXPECT_EQ(exr.at(x, y, 2), float(r.at(x, y).sheen.term));
        }
    // Sheen is not trivially zero: grazing views at high roughness exceed 0.1 (the Charlie lobe
    // reflects towards the horizon).
    EXPECT_GT(exr.at(0, 4, 2), 0.1f);

    const auto kb = slurp(path("d.ktx2"));
    const Ktx2 k = read_ktx2(kb);
    EXPECT_EQ(k.vk_format, 109u);  // VK_FORMAT_R32G32B32A32_SFLOAT
    EXPECT_EQ(k.texel_bytes, 16u);
    EXPECT_EQ(k.dfd_samples, 4u);
    for (std::uint32_t y = 0; y < 5; ++y)
        for (std::uint32_t x = 0; x < 6; ++x)
            for (int c = 0; c < 4; ++c)
                EXPECT_EQ(f32(kb, k.data + (std::size_t(y) * 6 + x) * 16 + 4 * c), exr.at(x, y, std::min(c, 2)));

    const auto db = slurp(path("h.dds"));
    EXPECT_EQ(u32(db, 128), 10u);  // DXGI_FORMAT_R16G16B16A16_FLOAT
    for (std::uint32_t y = 0; y < 5; ++y)
        for (std::uint32_t x = 0; x < 6; ++x)
            for (int c = 0; c < 4; ++c)
                EXPECT_EQ(f16(db, 148 + (std::size_t(y) * 6 + x) * 8 + 2 * c), as_half(exr.at(x, y, std::min(c, 2))));

    std::ifstream hf(path("d.h"));
    const std::string header((std::istreambuf_iterator<char>(hf)), std::istreambuf_iterator<char>());
    EXPECT_NE(header.find("static const float cloth_dfg_data[CLOTH_DFG_DEPTH * CLOTH_DFG_HEIGHT * CLOTH_DFG_WIDTH * 3u]"), std::string::npos);
    EXPECT_NE(header.find("#define CLOTH_DFG_COMPONENTS 3u"), std::string::npos);
    const std::vector<float> hv = read_c_values(header, true);
    ASSERT_EQ(hv.size(), 6u * 5 * 3);
    std::ifstream incf(path("d.inc"));
    const std::string inc((std::istreambuf_iterator<char>(incf)), std::istreambuf_iterator<char>());
    EXPECT_EQ(inc.find("static"), std::string::npos);  // an initialiser list, no declaration
    const std::vector<float> iv = read_c_values(inc, false);
    ASSERT_EQ(iv.size(), 6u * 5 * 3);
    std::ifstream hhf(path("h.h"));
    const std::string hh((std::istreambuf_iterator<char>(hhf)), std::istreambuf_iterator<char>());
    EXPECT_NE(hh.find("static const uint16_t dfg_half_data[DFG_HALF_DEPTH * DFG_HALF_HEIGHT * DFG_HALF_WIDTH * 3u]"), std::string::npos);
    const std::vector<float> hhv = read_c_values(hh, true);
    ASSERT_EQ(hhv.size(), 6u * 5 * 3);
    for (std::uint32_t y = 0; y < 5; ++y)
        for (std::uint32_t x = 0; x < 6; ++x)
            for (int c = 0; c < 3; ++c) {
                const std::size_t i = (std::size_t(y) * 6 + x) * 3 + c;
                EXPECT_EQ(hv[i], exr.at(x, y, c));
                EXPECT_EQ(iv[i], exr.at(x, y, c));
                EXPECT_EQ(hhv[i], as_half(exr.at(x, y, c)));
            }
}

// The C source is the one convention of every texture (lut/formats/texture_writer.hpp) and compiles in
// C99 and C++17 even where texels are exactly 0 or 1 (endpoints: roughness 0 at NdotV = 1 has scale 1,
// bias 0); the extension picks the format in any case.
TEST_F(IblDfgFormats, CSourceCompilesWithExactTexelsAndExtensionsAreCaseInsensitive) {
    spec_ = DfgBakeSpec{};
    spec_.n_dot_v.count = 4;
    spec_.roughness.count = 3;
    spec_.n_dot_v.texel = spec_.roughness.texel = TexelConvention::endpoints;
    spec_.method = DfgMethod::exact;
    spec_.channels = parse_dfg_channels("scale,bias");
    const DfgBakeResult r = bake_dfg(spec_);
    ASSERT_EQ(float(r.channel(3, 0, DfgChannel::scale)), 1.0f);
    ASSERT_EQ(float(r.channel(3, 0, DfgChannel::bias)), 0.0f);
    const nlohmann::json meta = dfg_metadata(spec_, r);
    write_dfg_lut(path("dfg.h"), r, meta, false, "my_dfg");
    write_dfg_lut(path("dfg.inc"), r, meta);
    write_dfg_lut(path("DFG.EXR"), r, meta);
    EXPECT_EQ(read_exr(path("DFG.EXR")).names, (std::vector<std::string>{"R", "G"}));
    std::ofstream(path("use.c")) << "#include \"dfg.h\"\nint main(void) { return (int)(my_dfg_data[MY_DFG_COMPONENTS * (MY_DFG_WIDTH - 1)] - 1.0f) + (int)sizeof my_dfg_metadata * 0; }\n";
    std::ofstream(path("use.cpp")) << "static const float dfg[] = {\n#include \"dfg.inc\"\n};\nstatic_assert(sizeof dfg == 4 * 3 * 2 * sizeof(float), \"size\");\n"
                                      "int main() { return static_cast<int>(dfg[6] - 1.0f); }\n";
    for (const std::string cc : {"cc -std=c99 -Wall -Werror -fsyntax-only " + path("use.c"), "c++ -std=c++17 -Wall -Werror -fsyntax-only " + path("use.cpp")}) {
        const auto res = ms::testing::run_shell(cc + " 2>&1");
        EXPECT_EQ(res.exit_code, 0) << cc << "\n" << res.output;
    }
}

// Two channels (scale, bias: the split sum without E, as UE4, three.js and the glTF sampler store it):
// KTX2 RG16F, DDS RG32F, 16-bit PNG (RGB, B = 0), EXR with R and G only.
TEST_F(IblDfgFormats, TwoChannelsAsRg16fRg32fAndPng16) {
    const DfgBakeResult r = bake("scale,bias");
    const nlohmann::json meta = dfg_metadata(spec_, r);
    write_dfg_lut(path("d.exr"), r, meta);
    write_dfg_lut(path("d.ktx2"), r, meta, true);
    write_dfg_lut(path("d.dds"), r, meta, false);
    write_dfg_lut(path("d.png"), r, meta);
    const Exr exr = read_exr(path("d.exr"));
    ASSERT_EQ(exr.names, (std::vector<std::string>{"R", "G"}));

    const auto kb = slurp(path("d.ktx2"));
    const Ktx2 k = read_ktx2(kb);
    EXPECT_EQ(k.vk_format, 83u);  // VK_FORMAT_R16G16_SFLOAT
    EXPECT_EQ(k.texel_bytes, 4u);
    EXPECT_EQ(k.dfd_samples, 2u);
    const auto db = slurp(path("d.dds"));
    EXPECT_EQ(u32(db, 128), 16u);   // DXGI_FORMAT_R32G32_FLOAT
    EXPECT_EQ(u32(db, 20), 6u * 8); // pitch: 8 bytes a texel
    ASSERT_EQ(db.size(), 148u + 6 * 5 * 8);
    const Png png = read_png16(path("d.png"));
    ASSERT_EQ(png.bits, 16);
    ASSERT_EQ(png.channels, 3);
    EXPECT_EQ(nlohmann::json::parse(png.text).at("channel_order"), "scale,bias");
    for (std::uint32_t y = 0; y < 5; ++y)
        for (std::uint32_t x = 0; x < 6; ++x) {
            const std::size_t i = std::size_t(y) * 6 + x;
            for (int c = 0; c < 2; ++c) {
                const float want = exr.at(x, y, c);
                EXPECT_EQ(f16(kb, k.data + i * 4 + 2 * c), as_half(want));
                EXPECT_EQ(f32(db, 148 + i * 8 + 4 * c), want);
                // unorm16: within half a step of the EXR's value.
                EXPECT_LE(std::abs(png.samples[i * 3 + c] / 65535.0 - want), 0.5 / 65535 + 1e-9) << x << " " << y << " " << c;
            }
            EXPECT_EQ(png.samples[i * 3 + 2], 0);
        }
}

// Four channels as RGBA16F, and HDRP's sqrt(NdotV) x axis: texel coordinate a holds NdotV = a^2.
TEST_F(IblDfgFormats, FourChannelsRgba16fAndSqrtParameterization) {
    const DfgBakeResult lin = bake("scale,bias,E,sheen");
    const DfgBakeResult sq = bake("scale,bias,E,sheen", DfgParameterization::sqrt_n_dot_v);
    write_dfg_lut(path("d.ktx2"), sq, dfg_metadata(spec_, sq), true);
    write_dfg_lut(path("d.exr"), sq, dfg_metadata(spec_, sq));
    const Exr exr = read_exr(path("d.exr"));
    ASSERT_EQ(exr.names, (std::vector<std::string>{"R", "G", "B", "A"}));
    const auto kb = slurp(path("d.ktx2"));
    const Ktx2 k = read_ktx2(kb);
    EXPECT_EQ(k.vk_format, 97u);  // VK_FORMAT_R16G16B16A16_SFLOAT
    for (std::uint32_t y = 0; y < 5; ++y)
        for (std::uint32_t x = 0; x < 6; ++x) {
            for (int c = 0; c < 4; ++c) EXPECT_EQ(f16(kb, k.data + (std::size_t(y) * 6 + x) * 8 + 2 * c), as_half(exr.at(x, y, c)));
            // The sqrt texel x holds the value the linear table has at NdotV = a^2.
            const double a = (x + 0.5) / 6, r = (y + 0.5) / 5;
            const exact::DfgExact e = exact::dfg_exact(a * a, r * r);
            EXPECT_NEAR(sq.at(x, y).scale.term, e.scale, 1e-14);
            EXPECT_NEAR(sq.at(x, y).sheen.term, e.sheen, 1e-14);
            const exact::DfgExact l = exact::dfg_exact(a, r * r);
            EXPECT_NEAR(lin.at(x, y).scale.term, l.scale, 1e-14);
        }
    EXPECT_EQ(dfg_metadata(spec_, sq).at("parameterization"), "sqrt-n-dot-v");
}

// Refusals, before any work and with nothing written (exit 2): sheen in a PNG, a bad symbol, an unknown
// channel, sampling options with a deterministic method.
TEST_F(IblDfgFormats, CliRefusesWhatAFormatCannotHold) {
    const std::string cli = std::string(MICROSHADOW_CLI) + " ibl dfg --size 4 -q ";
    struct Case {
        std::string args, says;
    } cases[] = {
        {"--channels bias,E,sheen --out " + path("s.png"), "sheen"},
        {"--symbol 9lives --out " + path("s.h"), "C identifier"},
        {"--channels scale,fresnel --out " + path("s.exr"), "fresnel"},
        {"--method exact --samples 4096 --out " + path("s.exr"), "--method sampled"},
    };
    for (const Case& c : cases) {
        const auto res = ms::testing::run_shell(cli + c.args + " 2>&1");
        EXPECT_EQ(res.exit_code, 2) << c.args << ": " << res.output;
        EXPECT_NE(res.output.find(c.says), std::string::npos) << res.output;
    }
    EXPECT_TRUE(std::filesystem::is_empty(path("")));
}

}  // namespace
