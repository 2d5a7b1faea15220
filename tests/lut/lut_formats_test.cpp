// LUT file formats: KTX2, DDS, C header, PNG atlas written by `microshadow bake` read back
// equal to the bake's OpenEXR within each format's quantisation; KTX2 checked field by field against
// the KTX 2.0 specification's tables by a reader written here (not the writer's code); DDS through
// OpenImageIO where it can read the format, and field by field against Microsoft's header layout;
// half-float rounding against Imath; the EXR's named roughness channels survive an OpenImageIO
// conversion (no division by alpha); hostile LUT metadata and texels are refused with the field named.
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <Imath/half.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <sstream>
#include <tuple>

#include "cli_runner.hpp"
#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/lut_formats.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;
using namespace ms::lutfmt;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

// Enum values from the Vulkan and DXGI headers' documentation, written here independently of the writers.
constexpr std::uint32_t kVkR8G8B8A8Unorm = 37, kVkR16G16B16A16Unorm = 91, kVkR16G16B16A16Sfloat = 97,
                        kVkR32G32B32A32Sfloat = 109;
constexpr std::uint32_t kDxgiR32G32B32A32Float = 2, kDxgiR16G16B16A16Float = 10, kDxgiR16G16B16A16Unorm = 11,
                        kDxgiR8G8B8A8Unorm = 28;
std::uint32_t vk_format(PixelEncoding e) {
    return e == PixelEncoding::float32 ? kVkR32G32B32A32Sfloat : e == PixelEncoding::float16 ? kVkR16G16B16A16Sfloat
         : e == PixelEncoding::unorm8  ? kVkR8G8B8A8Unorm : kVkR16G16B16A16Unorm;
}
std::uint32_t dxgi_format(PixelEncoding e) {
    return e == PixelEncoding::float32 ? kDxgiR32G32B32A32Float : e == PixelEncoding::float16 ? kDxgiR16G16B16A16Float
         : e == PixelEncoding::unorm8  ? kDxgiR8G8B8A8Unorm : kDxgiR16G16B16A16Unorm;
}

using ms::testing::cli;

std::vector<std::uint8_t> slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Reader {
    const std::vector<std::uint8_t>& b;
    std::uint32_t u32(std::size_t at) const {
        if (at + 4 > b.size()) throw std::out_of_range("read past the end");
        return std::uint32_t(b[at]) | std::uint32_t(b[at + 1]) << 8 | std::uint32_t(b[at + 2]) << 16 | std::uint32_t(b[at + 3]) << 24;
    }
    std::uint64_t u64(std::size_t at) const { return u32(at) | std::uint64_t(u32(at + 4)) << 32; }
    std::uint32_t u16(std::size_t at) const { return std::uint32_t(b.at(at)) | std::uint32_t(b.at(at + 1)) << 8; }
};

// Decodes one stored component (independently of the writer: Imath for half).
float decode(const std::vector<std::uint8_t>& b, std::size_t at, PixelEncoding e) {
    Reader r{b};
    switch (e) {
        case PixelEncoding::float32: {
            const std::uint32_t x = r.u32(at);
            float f;
            std::memcpy(&f, &x, 4);
            return f;
        }
        case PixelEncoding::float16: {
            Imath::half h;
            h.setBits(std::uint16_t(r.u16(at)));
            return float(h);
        }
        case PixelEncoding::unorm8: return float(b.at(at)) / 255.0f;
        case PixelEncoding::unorm16: return float(r.u16(at)) / 65535.0f;
    }
    return NAN;
}

// The largest |stored - baked| a format may show: 0 for float32, the half rounding (at most 2^-11
// relative to the value, and exactly the recorded measured figure), half a step for unorm.
double allowed(PixelEncoding e, float v) {
    switch (e) {
        case PixelEncoding::float32: return 0.0;
        case PixelEncoding::float16: return std::abs(v) * std::ldexp(1.0, -11) + std::ldexp(1.0, -25);
        case PixelEncoding::unorm8: return 0.5 / 255.0 + 1e-7;  // + float rounding of q / 255 in the decode
        case PixelEncoding::unorm16: return 0.5 / 65535.0 + 1e-7;
    }
    return 0.0;
}

void expect_error_budget(const nlohmann::json& meta, const LutFile& exr, PixelEncoding e) {
    const auto& b = meta.at("error_budget");
    EXPECT_DOUBLE_EQ(b.at("sampling").get<double>(), exr.metadata.at("max_error").get<double>());
    EXPECT_DOUBLE_EQ(b.at("azimuth_quadrature").get<double>(), exr.metadata.value("azimuth_quadrature_error", 0.0));
    const double q = b.at("quantisation").get<double>();
    // Every encoding's rounding adds the baked doubles' rounding to float32: half the float spacing at
    // the largest value, 2^-25 for values in [0.5, 1) (the spacing 2^-24 above 1 - 2^-24 once one is 1).
    double max_value = 0;
    for (float v : exr.data) max_value = std::max(max_value, double(v));
    const double float32 = max_value >= 1 ? std::ldexp(1.0, -24) : max_value >= 0.5 ? std::ldexp(1.0, -25) : 0.0;
    if (max_value >= 0.5) EXPECT_DOUBLE_EQ(ms::lutfmt::float32_rounding_bound(exr.data), float32);
    if (e == PixelEncoding::unorm8) EXPECT_DOUBLE_EQ(q, 0.5 / 255 + float32);
    if (e == PixelEncoding::unorm16) EXPECT_DOUBLE_EQ(q, 0.5 / 65535 + float32);
    if (e == PixelEncoding::float32) {
        EXPECT_DOUBLE_EQ(q, float32);
        EXPECT_GT(q, 0.0);
    }
    if (e == PixelEncoding::float16) {  // measured: recompute with Imath's conversion
        double worst = 0;
        for (float v : exr.data) worst = std::max(worst, std::abs(double(float(Imath::half(v))) - v));
        EXPECT_DOUBLE_EQ(q, worst + float32);
        EXPECT_GT(q, 0.0);
        EXPECT_LE(q, std::ldexp(1.0, -12) + float32);  // values <= 1: half a half-ulp of [0.5, 1)
    }
    EXPECT_NEAR(b.at("total").get<double>(), b.at("sampling").get<double>() + b.at("azimuth_quadrature").get<double>() + q, 1e-15);
    EXPECT_EQ(meta.at("max_total_error").get<double>(), b.at("total").get<double>());
}

// Compares decoded RGBA texels (4 per texel, x fastest, then y, then z) with the EXR's.
void expect_texels(const std::vector<std::uint8_t>& b, std::size_t at, PixelEncoding e, const LutFile& exr,
                   double recorded_quantisation, const std::string& what) {
    const std::size_t nc = exr.channels.size(), texels = std::size_t(exr.width) * exr.height;
    const std::size_t comp = bytes_per_component(e);
    ASSERT_LE(at + texels * 4 * comp, b.size()) << what;
    double worst = 0;
    for (std::size_t i = 0; i < texels; ++i)
        for (std::size_t c = 0; c < 4; ++c) {
            const float v = exr.data[i * nc + std::min(c, nc - 1)];  // padding repeats the last channel
            const float got = decode(b, at + (i * 4 + c) * comp, e);
            const double d = std::abs(double(got) - v);
            worst = std::max(worst, d);
            ASSERT_LE(d, allowed(e, v)) << what << " texel " << i << " channel " << c;
        }
    EXPECT_LE(worst, recorded_quantisation + 1e-7) << what;
    std::cout << "[ figures  ] " << what << ": max |stored - exr| = " << worst << "\n";
}

// --- KTX 2.0: a reader that checks the specification's tables ---------------------------------------
struct Ktx2Expect {
    std::uint32_t vk_format, type_size, width, height, depth;
    PixelEncoding encoding;
    std::string orientation;
};

nlohmann::json check_ktx2(const std::string& path, const Ktx2Expect& x, const LutFile& exr) {
    SCOPED_TRACE(path);
    const std::vector<std::uint8_t> b = slurp(path);
    Reader r{b};
    // Section 3.1: identifier.
    const std::uint8_t id[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    EXPECT_EQ(std::memcmp(b.data(), id, 12), 0);
    // Section 3: header fields.
    EXPECT_EQ(r.u32(12), x.vk_format);
    EXPECT_EQ(r.u32(16), x.type_size);
    EXPECT_EQ(r.u32(20), x.width);
    EXPECT_EQ(r.u32(24), x.height);
    EXPECT_EQ(r.u32(28), x.depth);  // 0 for a 2D texture
    EXPECT_EQ(r.u32(32), 0u);       // layerCount: not an array
    EXPECT_EQ(r.u32(36), 1u);       // faceCount
    EXPECT_EQ(r.u32(40), 1u);       // levelCount
    EXPECT_EQ(r.u32(44), 0u);       // supercompressionScheme
    const std::uint32_t dfd_off = r.u32(48), dfd_len = r.u32(52), kvd_off = r.u32(56), kvd_len = r.u32(60);
    EXPECT_EQ(r.u64(64), 0u);  // sgdByteOffset
    EXPECT_EQ(r.u64(72), 0u);  // sgdByteLength
    // Level index (one level) follows the 80-byte header; the DFD follows the level index.
    const std::uint64_t lvl_off = r.u64(80), lvl_len = r.u64(88), lvl_unc = r.u64(96);
    EXPECT_EQ(dfd_off, 104u);
    const std::uint32_t texel = 4 * x.type_size;
    EXPECT_EQ(lvl_off % std::lcm<std::uint64_t>(texel, 4), 0u) << "mipPadding: level data aligned to lcm(texel size, 4)";
    EXPECT_EQ(lvl_len, std::uint64_t(x.width) * x.height * std::max(1u, x.depth) * texel);
    EXPECT_EQ(lvl_unc, lvl_len);
    EXPECT_EQ(lvl_off + lvl_len, b.size()) << "the level is the last thing in the file";
    // DFD (Khronos Data Format Specification 1.3, basic descriptor block).
    EXPECT_EQ(r.u32(dfd_off), dfd_len) << "dfdTotalSize = dfdByteLength";
    const std::size_t blk = dfd_off + 4;
    EXPECT_EQ(r.u32(blk) & 0x1FFFFu, 0u) << "vendorId KHR";
    EXPECT_EQ(r.u32(blk) >> 17, 0u) << "descriptorType BASICFORMAT";
    EXPECT_EQ(r.u32(blk + 4) & 0xFFFFu, 2u) << "versionNumber 1.3";
    const std::uint32_t block_size = r.u32(blk + 4) >> 16;
    EXPECT_EQ(block_size, 24u + 16u * 4u);
    EXPECT_EQ(dfd_len, 4u + block_size);
    EXPECT_EQ(b.at(blk + 8), 1u) << "colorModel RGBSDA";
    EXPECT_EQ(b.at(blk + 9), 1u) << "colorPrimaries BT709";
    EXPECT_EQ(b.at(blk + 10), 1u) << "transferFunction LINEAR";
    EXPECT_EQ(b.at(blk + 11), 0u) << "flags ALPHA_STRAIGHT";
    EXPECT_EQ(r.u32(blk + 12), 0u) << "texelBlockDimension 1x1x1x1";
    EXPECT_EQ(b.at(blk + 16), texel) << "bytesPlane0";
    for (int p = 1; p < 8; ++p) EXPECT_EQ(b.at(blk + 16 + p), 0u) << "bytesPlane" << p;
    const bool is_float = x.encoding == PixelEncoding::float32 || x.encoding == PixelEncoding::float16;
    const std::uint32_t bits = x.type_size * 8, ids[4] = {0, 1, 2, 15};
    for (std::uint32_t s = 0; s < 4; ++s) {
        const std::size_t at = blk + 24 + 16 * s;
        EXPECT_EQ(r.u32(at) & 0xFFFFu, s * bits) << "sample " << s << " bitOffset";
        EXPECT_EQ((r.u32(at) >> 16) & 0xFFu, bits - 1) << "sample " << s << " bitLength";
        const std::uint32_t type = r.u32(at) >> 24;
        EXPECT_EQ(type & 0x0Fu, ids[s]) << "sample " << s << " channelId";
        EXPECT_EQ(type & 0x80u, is_float ? 0x80u : 0u) << "FLOAT qualifier";
        EXPECT_EQ(type & 0x40u, is_float ? 0x40u : 0u) << "SIGNED qualifier (SFLOAT is signed, UNORM is not)";
        EXPECT_EQ(type & 0x30u, 0u) << "no LINEAR/EXPONENT qualifiers (transfer is already LINEAR)";
        EXPECT_EQ(r.u32(at + 4), 0u) << "samplePosition";
        EXPECT_EQ(r.u32(at + 8), is_float ? 0xBF800000u : 0u) << "sampleLower";
        EXPECT_EQ(r.u32(at + 12), is_float ? 0x3F800000u : std::uint32_t((std::uint64_t(1) << bits) - 1)) << "sampleUpper";
    }
    // Key/value data: right after the DFD, entries 4-aligned, sorted by key, lengths add up.
    EXPECT_EQ(kvd_off, dfd_off + dfd_len);
    std::map<std::string, std::string> kv;
    std::string previous;
    std::size_t at = kvd_off;
    while (at < kvd_off + kvd_len) {
        EXPECT_EQ(at % 4, 0u);
        const std::uint32_t n = r.u32(at);
        const std::string entry(b.begin() + at + 4, b.begin() + at + 4 + n);
        const auto nul = entry.find('\0');
        EXPECT_NE(nul, std::string::npos) << "key must be NUL-terminated";
        const std::string key = entry.substr(0, nul), value = entry.substr(nul + 1);
        EXPECT_LT(previous, key) << "keys sorted, unique";
        previous = key;
        kv[key] = value;
        at += 4 + n;
        while (at % 4) EXPECT_EQ(b.at(at++), 0u) << "valuePadding is zero";
    }
    EXPECT_EQ(at, std::size_t(kvd_off) + kvd_len) << "kvdByteLength covers the entries and their padding";
    EXPECT_EQ(kv["KTXorientation"], x.orientation + std::string(1, '\0'));
    EXPECT_EQ(kv["KTXwriter"].substr(0, 11), "microshadow");
    std::string json = kv["microshadow"];
    EXPECT_EQ(json.back(), '\0');
    json.pop_back();
    const nlohmann::json meta = nlohmann::json::parse(json);
    expect_error_budget(meta, exr, x.encoding);
    expect_texels(b, lvl_off, x.encoding, exr, meta.at("error_budget").at("quantisation").get<double>(), "ktx2 " + to_string(x.encoding));
    return meta;
}

// --- DDS: Microsoft's DDS_HEADER / DDS_HEADER_DXT10 layout ---------------------------------------
void check_dds(const std::string& path, std::uint32_t dxgi, PixelEncoding e, const LutFile& exr, bool volume) {
    SCOPED_TRACE(path);
    const std::vector<std::uint8_t> b = slurp(path);
    Reader r{b};
    EXPECT_EQ(r.u32(0), 0x20534444u) << "magic 'DDS '";
    EXPECT_EQ(r.u32(4), 124u) << "dwSize";
    const std::uint32_t flags = r.u32(8);
    for (std::uint32_t f : {0x1u, 0x2u, 0x4u, 0x1000u}) EXPECT_TRUE(flags & f) << "required flag " << f;
    EXPECT_EQ(bool(flags & 0x800000u), volume) << "DDSD_DEPTH";
    EXPECT_EQ(r.u32(12), exr.n_dot_l().count) << "dwHeight";
    EXPECT_EQ(r.u32(16), exr.visibility().count) << "dwWidth";
    const std::uint32_t texel = 4 * bytes_per_component(e);
    EXPECT_EQ(r.u32(20), exr.visibility().count * texel) << "dwPitchOrLinearSize";
    EXPECT_EQ(r.u32(24), volume ? exr.n_dot_v().count : 0u) << "dwDepth";
    EXPECT_EQ(r.u32(76), 32u) << "ddspf.dwSize";
    EXPECT_EQ(r.u32(80), 0x4u) << "DDPF_FOURCC";
    EXPECT_EQ(r.u32(84), 0x30315844u) << "'DX10'";
    EXPECT_TRUE(r.u32(108) & 0x1000u) << "DDSCAPS_TEXTURE";
    EXPECT_EQ(bool(r.u32(112) & 0x200000u), volume) << "DDSCAPS2_VOLUME";
    EXPECT_EQ(r.u32(128), dxgi) << "dxgiFormat";
    EXPECT_EQ(r.u32(132), volume ? 4u : 3u) << "resourceDimension";
    EXPECT_EQ(r.u32(140), 1u) << "arraySize";
    EXPECT_EQ(r.u32(144), 4u) << "DDS_ALPHA_MODE_CUSTOM";
    EXPECT_EQ(b.size(), 148u + std::size_t(exr.width) * exr.height * texel);
    std::ifstream side(path + ".json");
    ASSERT_TRUE(side) << "sidecar metadata";
    const nlohmann::json meta = nlohmann::json::parse(side);
    expect_error_budget(meta, exr, e);
    expect_texels(b, 148, e, exr, meta.at("error_budget").at("quantisation").get<double>(), "dds " + to_string(e));
}

// OpenImageIO with DX10 DDS support (3.x; Debian 12's 2.4 has none): scripts/install-deps.sh puts
// its Python wheel in /opt/microshadow-py. Empty when unavailable.
std::string oiio_python() {
    const char* env = std::getenv("MICROSHADOW_OIIO_PYTHON");
    for (const char* p : {env, static_cast<const char*>("/opt/microshadow-py/bin/python3")}) {
        if (!p || !*p) continue;
        if (run_shell(std::string(p) + " -c 'import OpenImageIO' 2>/dev/null").exit_code == 0) return p;
    }
    return "";
}

// --- PNG: libpng reads it back ----------------------------------------------------------------------
struct Png {
    std::uint32_t width = 0, height = 0;
    int bits = 0, channels = 0;
    std::vector<std::uint32_t> values;
    std::string text;  // the "microshadow" iTXt
};

Png read_png(const std::string& path) {
    Png out;
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw std::runtime_error("cannot open " + path);
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::fclose(f);
        throw std::runtime_error("libpng failed reading " + path);
    }
    png_init_io(png, f);
    png_read_info(png, info);
    out.width = png_get_image_width(png, info);
    out.height = png_get_image_height(png, info);
    out.bits = png_get_bit_depth(png, info);
    out.channels = png_get_channels(png, info);
    std::vector<png_byte> row(png_get_rowbytes(png, info));
    for (std::uint32_t y = 0; y < out.height; ++y) {
        png_read_row(png, row.data(), nullptr);
        for (std::size_t i = 0; i < std::size_t(out.width) * out.channels; ++i)
            out.values.push_back(out.bits == 16 ? (std::uint32_t(row[2 * i]) << 8 | row[2 * i + 1]) : row[i]);
    }
    png_read_end(png, info);
    png_textp text = nullptr;
    int n = 0;
    png_get_text(png, info, &text, &n);
    for (int i = 0; i < n; ++i)
        if (std::string(text[i].key) == "microshadow") out.text = text[i].text;
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    return out;
}

class LutFormatsTest : public ScratchDirTest {
protected:
    LutFormatsTest() : ScratchDirTest("lutfmt") {}
    // One bake per output: the same seed gives bit-identical data in every run (README), so each file
    // is compared with the EXR of the same bake.
    void bake(const std::string& out, const std::string& extra = "") {
        const RunResult r = cli("bake -q --layout custom --size-visibility 7 --size-n-dot-l 6 --size-n-dot-v 5 --roughness 0.2,0.5,0.9 "
                                "--samples 4096 --azimuth-intervals 2 --seed 5 " + extra + " --out " + path(out));
        ASSERT_EQ(r.exit_code, 0) << r.output;
    }
};

TEST(LutEncoding, HalfConversionRoundsToNearestEvenLikeImath) {
    // Every half value, every midpoint between neighbours (the ties), and points just either side.
    for (std::uint32_t h = 0; h < 0x7bffu; ++h) {  // every finite half but the largest, whose neighbour is infinity
        Imath::half a;
        a.setBits(std::uint16_t(h));
        const float v = float(a);
        ASSERT_EQ(float_to_half(v), h) << v;
        ASSERT_EQ(half_to_float(std::uint16_t(h)), v);
        ASSERT_EQ(float_to_half(-v), h | 0x8000u);
        Imath::half next;
        next.setBits(std::uint16_t(h + 1));
        const float mid = 0.5f * (v + float(next));  // exact in float: halves have 11 significant bits
        const std::uint16_t even = (h & 1u) ? std::uint16_t(h + 1) : std::uint16_t(h);
        ASSERT_EQ(float_to_half(mid), even) << "tie at " << mid;
        ASSERT_EQ(float_to_half(std::nextafter(mid, 0.0f)), h) << mid;
        ASSERT_EQ(float_to_half(std::nextafter(mid, 1e9f)), h + 1) << mid;
    }
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 100000; ++i) {
        const float v = u(rng);
        ASSERT_EQ(float_to_half(v), Imath::half(v).bits()) << v;
    }
    EXPECT_EQ(float_to_half(65520.0f), 0x7c00u);  // rounds to infinity (tie, odd neighbour)
    EXPECT_EQ(float_to_half(65519.0f), 0x7bffu);
    EXPECT_TRUE(std::isnan(half_to_float(float_to_half(NAN))));
    EXPECT_EQ(to_unorm(0.5f / 255.0f, 8), 1u);  // round to nearest, not truncation
    EXPECT_EQ(to_unorm(0.49f / 255.0f, 8), 0u);
    EXPECT_EQ(to_unorm(1.0f, 16), 65535u);
}

TEST_F(LutFormatsTest, ChoosesTheFormatByExtensionAndRefusesMismatches) {
    EXPECT_EQ(resolve_lut_output("a.ktx2", "", "", false).format, LutFormat::ktx2);
    EXPECT_EQ(resolve_lut_output("a.PNG", "", "", false).encoding, PixelEncoding::unorm8);
    EXPECT_EQ(resolve_lut_output("a.exr", "", "", true).encoding, PixelEncoding::float16);
    EXPECT_EQ(resolve_lut_output("a.h", "header", "unorm16", false).encoding, PixelEncoding::unorm16);
    EXPECT_THROW(resolve_lut_output("a.jpg", "", "", false), std::invalid_argument);
    EXPECT_THROW(resolve_lut_output("a.exr", "ktx2", "", false), std::invalid_argument);
    EXPECT_THROW(resolve_lut_output("a.png", "", "float32", false), std::invalid_argument);
    EXPECT_THROW(resolve_lut_output("a.exr", "", "unorm8", false), std::invalid_argument);
    EXPECT_THROW(resolve_lut_output("a.dds", "", "unorm8", true), std::invalid_argument);
    // The CLI refuses before baking, writes nothing, exits 2.
    for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
             {"--out " + path("l.ktx") , "unknown LUT file extension"},
             {"--out " + path("l.exr") + " --format ktx2", "does not match the file extension"},
             {"--out " + path("l.png") + " --encoding float32", "cannot store float32"},
             {"--out " + path("l.exr") + " --preview " + path("p.jpg"), "give a .png file"},
             {"--out " + path("l.png") + " --preview " + path("l.png"), "is the --out file"},
             {"--out " + path("l.exr") + " --shader-glsl " + path("l.exr"), "expected a .glsl file"},
             {"--out " + path("l.exr") + " --shader-glsl " + path("s.glsl") + " --preview " + path("s.glsl"), "give a .png"}}) {
        const RunResult r = cli("bake -q --size 2 --samples 1024 " + args);
        EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(message), std::string::npos) << args << "\n" << r.output;
    }
    EXPECT_TRUE(fs::is_empty(dir_)) << "nothing written";
}

TEST_F(LutFormatsTest, Ktx2DdsHeaderAndPngFromBakeReadBackEqualToTheExr) {
    bake("lut.exr");
    bake("lut.ktx2");
    bake("lut.dds");
    bake("lut.h");
    bake("lut8.png");
    const LutFile exr = read_lut(path("lut.exr"));
    ASSERT_EQ(exr.channels.size(), 3u);  // exercises the RGBA padding

    const nlohmann::json kmeta =
        check_ktx2(path("lut.ktx2"), {kVkR32G32B32A32Sfloat, 4, 7, 6, 5, PixelEncoding::float32, "rdi"}, exr);
    EXPECT_EQ(kmeta.at("padded_channels"), nlohmann::json::array({"A"}));
    EXPECT_EQ(kmeta.at("command_line").get<std::string>().find("lut.ktx2") != std::string::npos, true);
    check_dds(path("lut.dds"), kDxgiR32G32B32A32Float, PixelEncoding::float32, exr, true);

    // C header: the values parse back exactly and the file compiles as C99 and C++.
    {
        std::ifstream in(path("lut.h"));
        std::stringstream ss;
        ss << in.rdbuf();
        const std::string text = ss.str();
        const auto open = text.find("lut_data[");
        ASSERT_NE(open, std::string::npos);
        std::size_t at = text.find('{', open) + 1;
        const std::size_t close = text.find('}', at);
        std::vector<float> values;
        while (at < close) {
            char* end = nullptr;
            const float v = std::strtof(text.c_str() + at, &end);
            if (end == text.c_str() + at) { ++at; continue; }
            values.push_back(v);
            at = std::size_t(end - text.c_str());
        }
        ASSERT_EQ(values.size(), std::size_t(exr.width) * exr.height * 4);
        for (std::size_t i = 0; i < values.size(); ++i) ASSERT_EQ(values[i], exr.data[(i / 4) * 3 + std::min<std::size_t>(i % 4, 2)]) << i;
        EXPECT_NE(text.find("#define LUT_WIDTH 7u"), std::string::npos);
        EXPECT_NE(text.find("#define LUT_DEPTH 5u"), std::string::npos);
        EXPECT_NE(text.find("#define LUT_ROUGHNESS_B 0.9"), std::string::npos);
        std::ofstream(path("use.c")) << "#include \"lut.h\"\nint main(void) { return (int)(lut_data[0] * 0.0f) + (int)sizeof lut_metadata * 0; }\n";
        std::ofstream(path("use.cpp")) << "#include \"lut.h\"\nint main() { return static_cast<int>(lut_data[LUT_WIDTH] * 0.0f); }\n";
        for (const std::string cc : {"cc -std=c99", "c++ -std=c++17"}) {
            const RunResult r = run_shell(cc + " -Wall -Werror -fsyntax-only " + path(cc[0] == 'c' && cc[1] == 'c' ? "use.c" : "use.cpp") + " 2>&1");
            EXPECT_EQ(r.exit_code, 0) << cc << "\n" << r.output;
        }
    }

    // .inc: only the values, to #include inside an initialiser; unorm8 here (uint8_t values).
    write_lut_output(path("lut8.inc"), exr, {LutFormat::inc, PixelEncoding::unorm8});
    {
        std::ofstream(path("inc.cpp")) << "#include <cstdint>\nstatic const std::uint8_t lut[] = {\n#include \"lut8.inc\"\n};\n"
                                          "static_assert(sizeof lut == " << exr.width * exr.height * 4 << ", \"size\");\n"
                                          "int main() { return lut[0] * 0; }\n";
        const RunResult r = run_shell("c++ -std=c++17 -Wall -Werror -fsyntax-only " + path("inc.cpp") + " 2>&1");
        EXPECT_EQ(r.exit_code, 0) << r.output;
        std::ifstream in(path("lut8.inc"));
        std::string line, body;
        while (std::getline(in, line))
            if (line.rfind("/*", 0) != 0 && line.rfind(" *", 0) != 0) body += line + "\n";
        std::istringstream values(body);
        std::vector<int> v;
        for (std::string tok; std::getline(values, tok, ',');) v.push_back(std::stoi(tok));
        ASSERT_EQ(v.size(), std::size_t(exr.width) * exr.height * 4);
        for (std::size_t i = 0; i < v.size(); ++i)
            ASSERT_EQ(v[i], std::lround(exr.data[(i / 4) * 3 + std::min<std::size_t>(i % 4, 2)] * 255.0)) << i;
    }

    // PNG atlas, 8-bit (from bake) and 16-bit (bake with --encoding unorm16).
    bake("lut16.png", "--encoding unorm16");
    for (const auto& [name, bits] : std::vector<std::pair<std::string, int>>{{"lut8.png", 8}, {"lut16.png", 16}}) {
        const Png p = read_png(path(name));
        EXPECT_EQ(p.width, exr.width);
        EXPECT_EQ(p.height, exr.height);
        EXPECT_EQ(p.bits, bits);
        ASSERT_EQ(p.channels, 4);
        const double scale = bits == 8 ? 255.0 : 65535.0;
        double worst = 0;
        for (std::size_t i = 0; i < p.values.size(); ++i) {
            const float v = exr.data[(i / 4) * 3 + std::min<std::size_t>(i % 4, 2)];
            worst = std::max(worst, std::abs(p.values[i] / scale - v));
            ASSERT_EQ(p.values[i], std::uint32_t(std::lround(v * scale))) << name << " " << i;
        }
        EXPECT_LE(worst, 0.5 / scale + 1e-9);
        const nlohmann::json meta = nlohmann::json::parse(p.text);
        expect_error_budget(meta, exr, bits == 8 ? PixelEncoding::unorm8 : PixelEncoding::unorm16);
        std::cout << "[ figures  ] png" << bits << ": max |stored - exr| = " << worst << "\n";
    }
}

TEST_F(LutFormatsTest, EveryKtx2AndDdsEncodingAnd2DLayout) {
    bake("lut.exr");
    LutFile exr = read_lut(path("lut.exr"));
    for (PixelEncoding e : {PixelEncoding::float16, PixelEncoding::unorm8, PixelEncoding::unorm16}) {
        write_lut_output(path("e.ktx2"), exr, {LutFormat::ktx2, e});
        check_ktx2(path("e.ktx2"), {vk_format(e), bytes_per_component(e), 7, 6, 5, e, "rdi"}, exr);
        write_lut_output(path("e.dds"), exr, {LutFormat::dds, e});
        check_dds(path("e.dds"), dxgi_format(e), e, exr, true);
    }
    // seed-2d from the CLI: a 2D KTX2 (pixelDepth 0, orientation "rd") and a 2D DDS.
    const RunResult r2 = cli("bake -q --layout seed-2d --size 6 --samples 4096 --out " + path("b2d.exr"));
    ASSERT_EQ(r2.exit_code, 0) << r2.output;
    ASSERT_EQ(cli("bake -q --layout seed-2d --size 6 --samples 4096 --half --out " + path("b2d.ktx2")).exit_code, 0);
    ASSERT_EQ(cli("bake -q --layout seed-2d --size 6 --samples 4096 --out " + path("b2d.dds")).exit_code, 0);
    const LutFile e2 = read_lut(path("b2d.exr"));
    check_ktx2(path("b2d.ktx2"), {kVkR16G16B16A16Sfloat, 2, 6, 6, 0, PixelEncoding::float16, "rd"}, e2);
    check_dds(path("b2d.dds"), kDxgiR32G32B32A32Float, PixelEncoding::float32, e2, false);
}

struct OiioImage {
    std::uint32_t width = 0, height = 0, depth = 0, channels = 0;
    std::string texture_format;
    std::vector<int> values;  // uint8, channels fastest, then x, y, z
};

// Reads an image through OpenImageIO's Python bindings (a subprocess: the bindings are a separate install).
OiioImage oiio_read(const std::string& py, const std::string& script, const std::string& file) {
    std::ofstream(script) << "import sys, OpenImageIO as oiio\n"
                             "config = oiio.ImageSpec()\n"
                             "config.attribute('oiio:UnassociatedAlpha', 1)  # keep channel 4 as stored: no premultiplying\n"
                             "b = oiio.ImageBuf(sys.argv[1], 0, 0, config)\n"
                             "s = b.spec()\n"
                             "print(s.width, s.height, s.depth, s.nchannels, s.get_string_attribute('textureformat').replace(' ', '_'))\n"
                             "p = b.get_pixels(oiio.UINT8)\n"
                             "print(' '.join(str(int(v)) for v in p.reshape(-1)))\n";
    const RunResult r = run_shell(py + " " + script + " " + file + " 2>&1");
    if (r.exit_code != 0) throw std::runtime_error("OpenImageIO could not read " + file + ": " + r.output);
    OiioImage img;
    std::istringstream in(r.output);
    in >> img.width >> img.height >> img.depth >> img.channels >> img.texture_format;
    int v;
    while (in >> v) img.values.push_back(v);
    return img;
}

TEST_F(LutFormatsTest, DdsReadsBackThroughOpenImageIO) {
    const std::string py = oiio_python();
    if (py.empty()) GTEST_SKIP() << "no OpenImageIO with DX10 DDS support (pip OpenImageIO >= 3 in /opt/microshadow-py, "
                                    "see scripts/install-deps.sh); Debian 12's 2.4 reads no DX10 DDS";
    // A 2D DDS (seed-2d) and a volume (custom, 5 NdotV slices), both RGBA8: OpenImageIO 3.2 reads no
    // float DXGI formats ("Unsupported DXGI format: 2"); those are checked field by field above.
    ASSERT_EQ(cli("bake -q --layout seed-2d --size 6 --samples 4096 --out " + path("b2d.exr")).exit_code, 0);
    ASSERT_EQ(cli("bake -q --layout seed-2d --size 6 --samples 4096 --encoding unorm8 --out " + path("b2d.dds")).exit_code, 0);
    bake("lut.exr");
    bake("lut.dds", "--encoding unorm8");
    for (const auto& [name, exr_name, volume] : std::vector<std::tuple<std::string, std::string, bool>>{
             {"b2d.dds", "b2d.exr", false}, {"lut.dds", "lut.exr", true}}) {
        SCOPED_TRACE(name);
        const LutFile exr = read_lut(path(exr_name));
        const OiioImage img = oiio_read(py, path("dump.py"), path(name));
        EXPECT_EQ(img.width, exr.visibility().count);
        EXPECT_EQ(img.height, exr.n_dot_l().count);
        EXPECT_EQ(img.depth, volume ? exr.n_dot_v().count : 1u);
        EXPECT_EQ(img.texture_format, volume ? "Volume_Texture" : "Plain_Texture");
        ASSERT_EQ(img.channels, 4u);
        const std::size_t nc = exr.channels.size(), slice = std::size_t(img.width) * img.height * 4;
        ASSERT_EQ(img.values.size(), slice * img.depth);
        double worst = 0;
        std::size_t zero_slices = 0;
        for (std::uint32_t z = 0; z < img.depth; ++z) {
            // OpenImageIO 3.2's DDS reader copies an R8G8B8A8 image with one read of height rows
            // (ddsinput.cpp, the "direct" path), so a volume's slices after the first come back 0.
            // Slice 0 must match; a later slice must match or be that all-zero artefact.
            bool all_zero = true, match = true;
            for (std::size_t k = 0; k < slice; ++k) {
                const std::size_t i = z * slice + k;
                const float v = exr.data[(i / 4) * nc + std::min(i % 4, nc - 1)];
                all_zero = all_zero && img.values[i] == 0;
                if (img.values[i] != int(std::lround(v * 255.0))) match = false;
                else worst = std::max(worst, std::abs(img.values[i] / 255.0 - v));
            }
            if (z == 0 || !all_zero) EXPECT_TRUE(match) << "slice " << z;
            zero_slices += !match && all_zero;
        }
        EXPECT_LE(worst, 0.5 / 255 + 1e-9);
        std::cout << "[ figures  ] " << name << " via OpenImageIO: max |oiio - exr| = " << worst << " over "
                  << (img.depth - zero_slices) << " of " << img.depth << " slices"
                  << (zero_slices ? " (the others read as 0: OpenImageIO's volume DDS bug)" : "") << "\n";
    }
}

// --- EXR: named roughness channels, old RGBA files, hostile files -------------------------------

// Writes an EXR with the given channel names, metadata JSON and data (interleaved per channel).
void write_raw_exr(const std::string& path, int w, int h, const std::vector<std::string>& names, const std::string& json,
                   std::vector<float> data) {
    Imf::Header header(w, h);
    for (const auto& n : names) header.channels().insert(n, Imf::Channel(Imf::FLOAT));
    header.insert("microshadow", Imf::StringAttribute(json));
    Imf::FrameBuffer fb;
    const std::size_t stride = names.size() * sizeof(float);
    for (std::size_t c = 0; c < names.size(); ++c)
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char*)(data.data() + c), stride, stride * w));
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
}

// Counts PNG texels whose channel differs from round(255 v) by more than one step.
std::size_t png_mismatches(const Png& p, const LutFile& exr, double* worst) {
    std::size_t bad = 0;
    *worst = 0;
    const std::size_t nc = exr.channels.size();
    for (std::size_t i = 0; i < std::size_t(exr.width) * exr.height; ++i)
        for (std::size_t c = 0; c < nc; ++c) {
            const double d = std::abs(p.values.at(i * p.channels + c) / 255.0 - exr.data[i * nc + c]);
            *worst = std::max(*worst, d);
            bad += d > 1.0 / 255.0;
        }
    return bad;
}

TEST_F(LutFormatsTest, ExrConvertedByOpenImageIONeverDividesByAlpha) {
    if (run_shell("command -v oiiotool >/dev/null").exit_code != 0) GTEST_SKIP() << "oiiotool not installed (openimageio-tools)";
    // 4 channels like the seed LUT, named R, G, B, A (what engines' EXR importers read), the last one
    // roughness 1; the roughness of each is in the metadata.
    ASSERT_EQ(cli("bake -q --size 8 --samples 4096 --out " + path("seed.exr")).exit_code, 0);
    const LutFile seed = read_lut(path("seed.exr"));
    const char* rgba[] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; ++c) {
        EXPECT_EQ(seed.metadata.at("channels")[c].at("exr_channel"), rgba[c]);
        EXPECT_EQ(seed.metadata.at("channels")[c].at("roughness"), seed.channels[c].roughness);
    }
    RunResult r = run_shell("iinfo -v " + path("seed.exr") + " 2>&1");
    EXPECT_NE(r.output.find("channel list: R, G, B, A"), std::string::npos) << r.output;
    r = run_shell("oiiotool " + path("seed.exr") + " -d uint8 -o " + path("seed.png") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    double worst = 0;
    EXPECT_EQ(png_mismatches(read_png(path("seed.png")), seed, &worst), 0u) << "worst " << worst;
    std::cout << "[ figures  ] oiiotool -d uint8 of the RGBA EXR: max |png - exr| = " << worst << "\n";
    // `lut info` gives each channel's roughness.
    r = cli("lut info " + path("seed.exr"));
    EXPECT_NE(r.output.find("channel A: roughness 1"), std::string::npos) << r.output;

    // Files that named their channels by roughness ("roughness_0p1", ...) still read.
    nlohmann::json named = seed.metadata;
    std::vector<std::string> names;
    for (auto& c : named.at("channels")) {
        names.push_back(ms::exr_channel_name(c.at("roughness").get<double>()));
        c["exr_channel"] = names.back();
    }
    write_raw_exr(path("named.exr"), int(seed.width), int(seed.height), names, named.dump(), seed.data);
    EXPECT_EQ(read_lut(path("named.exr")).data, seed.data);
    EXPECT_EQ(names[0], "roughness_0p1");

    // The same RGBA data without the bake's oiio:UnassociatedAlpha attribute: the check above does catch
    // the premultiplied-alpha corruption oiiotool causes there (so it can fail).
    nlohmann::json old = seed.metadata;
    for (auto& c : old.at("channels")) c.erase("exr_channel");
    write_raw_exr(path("old.exr"), int(seed.width), int(seed.height), {"R", "G", "B", "A"}, old.dump(), seed.data);
    const LutFile back = read_lut(path("old.exr"));
    EXPECT_EQ(back.data, seed.data);
    r = run_shell("oiiotool " + path("old.exr") + " -d uint8 -o " + path("old.png") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::size_t corrupted = png_mismatches(read_png(path("old.png")), seed, &worst);
    EXPECT_GT(corrupted, 0u) << "an RGBA EXR without oiio:UnassociatedAlpha should show the premultiplied-alpha corruption";
    std::cout << "[ figures  ] oiiotool -d uint8 of an RGBA EXR without the attribute: " << corrupted
              << " channel values off by > 1/255, worst " << worst << "\n";
}

TEST_F(LutFormatsTest, HostileLutFilesAreRefusedNamingFileAndField) {
    const nlohmann::json good = {
        {"axes", {{{"name", "visibility"}, {"min", 0}, {"max", 1}, {"count", 2}, {"texel", "centres"}},
                  {{"name", "n_dot_l"}, {"min", 0}, {"max", 1}, {"count", 1}, {"texel", "centres"}},
                  {{"name", "n_dot_v"}, {"min", 0}, {"max", 1}, {"count", 2}, {"texel", "centres"}}}},
        {"channels", {{{"name", "R"}, {"roughness", 0.5}, {"alpha_x", 0.25}, {"alpha_y", 0.25}}}}};
    const std::vector<float> data = {0.1f, 0.2f, 0.3f, 0.4f};  // 2 x 2 texels, one channel
    write_raw_exr(path("good.exr"), 2, 2, {"R"}, good.dump(), data);
    EXPECT_EQ(read_lut(path("good.exr")).data, data);

    auto expect_refused = [&](const std::string& name, const nlohmann::json& meta, std::vector<float> d, int h,
                              const std::string& field) {
        write_raw_exr(path(name), 2, h, {"R"}, meta.dump(), std::move(d));
        try {
            read_lut(path(name));
            ADD_FAILURE() << name << " was accepted";
        } catch (const std::runtime_error& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find(path(name)), std::string::npos) << what;
            EXPECT_NE(what.find(field), std::string::npos) << what;
        }
    };
    // 2147483649 x 2 wraps to 2 in 32-bit arithmetic: a 2 x 2 image must not pass for it.
    nlohmann::json m = good;
    m["axes"][1]["count"] = 2147483649u;
    m["axes"][2]["count"] = 2;
    expect_refused("wrap.exr", m, {0, 0, 0, 0}, 2, "axes[1].count");
    m = good, m["axes"][0]["count"] = 65536, m["axes"][1]["count"] = 65536;  // refused before any allocation
    expect_refused("huge.exr", m, data, 2, "texels");
    m = good, m["axes"][0]["count"] = 2.5;
    expect_refused("frac.exr", m, data, 2, "axes[0].count");
    m = good, m["axes"][2]["count"] = -2;
    expect_refused("neg.exr", m, data, 2, "axes[2].count");
    m = good, m["axes"][1]["max"] = 2.0;
    expect_refused("range.exr", m, data, 2, "axes[1]");
    m = good, m["channels"][0]["roughness"] = 0.0;
    expect_refused("r0.exr", m, data, 2, "channels[0].roughness");
    m = good, m["channels"][0]["roughness"] = 1.5;
    expect_refused("r15.exr", m, data, 2, "channels[0].roughness");
    m = good, m["channels"][0]["roughness"] = "0.5";
    expect_refused("rstr.exr", m, data, 2, "channels[0].roughness");
    expect_refused("nan.exr", good, {0.1f, NAN, 0.3f, 0.4f}, 2, "texel (x 1, y 0)");
    expect_refused("inf.exr", good, {0.1f, 0.2f, INFINITY, 0.4f}, 2, "texel (x 0, y 1)");
    expect_refused("big.exr", good, {0.1f, 0.2f, 0.3f, 1.5f}, 2, "not in [0, 1]");
    expect_refused("neg.exr", good, {-0.1f, 0.2f, 0.3f, 0.4f}, 2, "not in [0, 1]");
}

// The chunk types of a PNG file in order, with the gAMA value (x 100000) when there is one.
std::vector<std::string> png_chunk_types(const std::string& file, std::uint32_t* gamma) {
    std::ifstream in(file, std::ios::binary);
    const std::vector<unsigned char> b{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    auto be32 = [&](std::size_t at) { return std::uint32_t(b.at(at)) << 24 | std::uint32_t(b.at(at + 1)) << 16 | std::uint32_t(b.at(at + 2)) << 8 | b.at(at + 3); };
    std::vector<std::string> types;
    for (std::size_t at = 8; at + 8 <= b.size();) {
        const std::uint32_t length = be32(at);
        types.emplace_back(b.begin() + long(at + 4), b.begin() + long(at + 8));
        if (types.back() == "gAMA") *gamma = be32(at + 8);
        at += 12 + std::size_t(length);
    }
    return types;
}

// PNG atlases are data: a gAMA chunk of 1.0 (100000) and no sRGB or iCCP chunk, so importers read the
// samples as linear values (OpenImageIO: oiio:ColorSpace "linear"), not as sRGB colour. The DFG LUT's
// 16-bit PNG (`ibl dfg --out F.png`) too.
TEST_F(LutFormatsTest, PngAtlasIsMarkedLinearData) {
    for (const char* encoding : {"unorm8", "unorm16", "dfg"}) {
        SCOPED_TRACE(encoding);
        const bool dfg = std::string(encoding) == "dfg";
        const std::string png = path(std::string("atlas_") + encoding + ".png");
        const RunResult r = cli(dfg ? "ibl dfg -q --method sampled --size 4 --samples 256 --out " + png
                                    : "bake -q --size 4 --samples 256 --encoding " + std::string(encoding) + " --out " + png);
        ASSERT_EQ(r.exit_code, 0) << r.output;
        std::uint32_t gamma = 0;
        const auto types = png_chunk_types(png, &gamma);
        ASSERT_FALSE(types.empty());
        EXPECT_EQ(types.front(), "IHDR");
        EXPECT_NE(std::find(types.begin(), types.end(), "gAMA"), types.end());
        EXPECT_EQ(gamma, 100000u);
        EXPECT_EQ(std::find(types.begin(), types.end(), "sRGB"), types.end());
        EXPECT_EQ(std::find(types.begin(), types.end(), "iCCP"), types.end());
        if (!dfg) EXPECT_FALSE(read_lut(png).data.empty());  // and it still reads back
        if (run_shell("command -v iinfo >/dev/null").exit_code == 0) {
            const RunResult info = run_shell("iinfo -v " + png + " 2>&1");
            EXPECT_NE(info.output.find("oiio:ColorSpace: \"linear\""), std::string::npos) << info.output;
        }
    }
}

}  // namespace
