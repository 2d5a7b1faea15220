// Every LUT file the bake writes reads back (lut/formats/lut_reader.hpp): KTX2, DDS with its
// .dds.json, C header, .inc and 8/16-bit PNG atlases equal the OpenEXR of the same bake within the
// encoding's step (float32 exactly, float16 as the rounded half, unorm as q / (2^n - 1)), and open
// wherever a LUT is an input (eval --compare, shader, lut info|export); a representation given for a
// LUT, or a LUT for a representation, gets one line naming the command that reads it; representation
// DDS files open like their KTX2 and EXR.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

#include "cli_runner.hpp"
#include "lut/exr_lut.hpp"
#include "lut/formats/encoding.hpp"
#include "lut/formats/lut_formats.hpp"
#include "lut/formats/lut_reader.hpp"
#include "lut/lookup.hpp"
#include "repr/representation.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms;
using namespace ms::lutfmt;
using ms::testing::RunResult;
using ms::testing::run_shell;

using ms::testing::cli;

// What a stored component must read back as: the encoding's own rounding of the baked float,
// computed here from the definitions (encoding.hpp), not by the reader.
float expected_texel(float v, PixelEncoding e) {
    switch (e) {
        case PixelEncoding::float32: return v;
        case PixelEncoding::float16: return half_to_float(float_to_half(v));
        case PixelEncoding::unorm8: return float(std::lround(double(v) * 255.0) / 255.0);
        case PixelEncoding::unorm16: return float(std::lround(double(v) * 65535.0) / 65535.0);
    }
    return v;
}

std::map<std::string, std::vector<std::string>> read_columns(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    std::vector<std::string> names;
    std::stringstream hs(line);
    for (std::string n; std::getline(hs, n, ',');) names.push_back(n);
    std::map<std::string, std::vector<std::string>> cols;
    while (std::getline(in, line)) {
        std::stringstream ls(line);
        std::size_t i = 0;
        for (std::string v; std::getline(ls, v, ',') && i < names.size(); ++i) cols[names[i]].push_back(v);
    }
    return cols;
}

class LutReaderTest : public ms::testing::ScratchDirTest {
protected:
    LutReaderTest() : ScratchDirTest("lut_reader") {}
    // A 3D LUT with 3 roughness channels (so the RGBA padding is exercised), a few seconds' bake.
    void bake(const std::string& out) {
        const RunResult r = cli("bake -q --layout custom --size-visibility 5 --size-n-dot-l 4 --size-n-dot-v 3 --roughness 0.2,0.5,0.9 "
                                "--samples 1024 --azimuth-intervals 2 --seed 5 --out " + path(out));
        ASSERT_EQ(r.exit_code, 0) << r.output;
    }
    // Every texel of `got` is the encoding's rounding of the EXR's, and so within the step bound.
    void expect_equal_within_step(const LutFile& got, const LutFile& exr, PixelEncoding e, const std::string& what) {
        ASSERT_EQ(got.axes.size(), 3u) << what;
        for (std::size_t i = 0; i < 3; ++i) {
            EXPECT_EQ(got.axes[i].count, exr.axes[i].count) << what;
            EXPECT_EQ(got.axes[i].min, exr.axes[i].min) << what;
            EXPECT_EQ(got.axes[i].max, exr.axes[i].max) << what;
            EXPECT_EQ(got.axes[i].texel, exr.axes[i].texel) << what;
        }
        ASSERT_EQ(got.channels.size(), exr.channels.size()) << what;
        for (std::size_t c = 0; c < got.channels.size(); ++c) EXPECT_EQ(got.channels[c].roughness, exr.channels[c].roughness) << what;
        ASSERT_EQ(got.data.size(), exr.data.size()) << what;
        const double bound = encoding_step_bound(e);
        double worst = 0;
        for (std::size_t i = 0; i < got.data.size(); ++i) {
            ASSERT_EQ(got.data[i], expected_texel(exr.data[i], e)) << what << " texel " << i;
            worst = std::max(worst, std::abs(double(got.data[i]) - exr.data[i]));
        }
        // float rounding of q / (2^n - 1) adds at most one float ulp at 1 (2^-24) to the half step.
        EXPECT_LE(worst, bound + std::ldexp(1.0, -24)) << what;
        EXPECT_EQ(got.metadata.value("layout", ""), exr.metadata.value("layout", "")) << what;
        EXPECT_EQ(got.metadata.value("seed", 0), exr.metadata.value("seed", 0)) << what;
        std::cout << "[ figures  ] " << what << ": max |read - exr| = " << worst << " (bound " << bound << ")\n";
    }
};

TEST_F(LutReaderTest, EveryFormatAndEncodingReadsBackEqualToTheExrWithinItsStep) {
    bake("lut.exr");
    const LutFile exr = read_lut(path("lut.exr"));
    ASSERT_EQ(exr.channels.size(), 3u);
    struct Case {
        std::string name;
        LutFormat format;
        PixelEncoding encoding;
    };
    std::vector<Case> cases;
    for (PixelEncoding e : {PixelEncoding::float32, PixelEncoding::float16, PixelEncoding::unorm8, PixelEncoding::unorm16}) {
        const std::string tag = to_string(e);
        cases.push_back({tag + ".ktx2", LutFormat::ktx2, e});
        cases.push_back({tag + ".dds", LutFormat::dds, e});
        cases.push_back({tag + ".h", LutFormat::header, e});
        cases.push_back({tag + ".inc", LutFormat::inc, e});
        if (e == PixelEncoding::unorm8 || e == PixelEncoding::unorm16) cases.push_back({tag + ".png", LutFormat::png, e});
    }
    cases.push_back({"half.exr", LutFormat::exr, PixelEncoding::float16});
    for (const Case& c : cases) {
        write_lut_output(path(c.name), exr, {c.format, c.encoding});
        LutFileInfo info;
        const LutFile back = read_lut_file(path(c.name), &info);
        EXPECT_EQ(info.format, c.format) << c.name;
        EXPECT_EQ(info.encoding, c.encoding) << c.name;
        expect_equal_within_step(back, exr, c.encoding, c.name);
        // A lookup blends texels with weights summing to 1: it moves by at most the texels' step.
        const LutLookup a(exr), b(back);
        for (double q : {0.1, 0.37, 0.8})
            EXPECT_LE(std::abs(a(q, 1 - q, 0.5, q) - b(q, 1 - q, 0.5, q)), encoding_step_bound(c.encoding) + 1e-7) << c.name;
    }
}

TEST_F(LutReaderTest, HostileOrMismatchedFilesAreRefusedWithTheProblemNamed) {
    bake("lut.exr");
    const LutFile exr = read_lut(path("lut.exr"));
    write_lut_output(path("a.dds"), exr, {LutFormat::dds, PixelEncoding::float32});
    write_lut_output(path("b.dds"), exr, {LutFormat::dds, PixelEncoding::unorm8});
    write_lut_output(path("a.ktx2"), exr, {LutFormat::ktx2, PixelEncoding::float16});
    auto refused = [&](const std::string& file, const std::string& message) {
        try {
            read_lut(path(file));
            ADD_FAILURE() << file << " was accepted";
        } catch (const std::runtime_error& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find(message), std::string::npos) << file << ": " << what;
            EXPECT_NE(what.find(path(file)), std::string::npos) << "names the file: " << what;
            EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
        }
    };
    // The sidecar of another file (unorm8 metadata on float32 texels), then no sidecar at all.
    fs::copy_file(path("b.dds.json"), path("a.dds.json"), fs::copy_options::overwrite_existing);
    refused("a.dds", "metadata of another file");
    fs::remove(path("a.dds.json"));
    refused("a.dds", "no metadata sidecar");
    // A truncated KTX2: the level lies beyond the end of the file.
    {
        std::ifstream in(path("a.ktx2"), std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::ofstream(path("cut.ktx2"), std::ios::binary) << bytes.substr(0, bytes.size() - 10);
    }
    refused("cut.ktx2", "beyond the end");
    // A header whose values were edited out of range, and a file of no known kind.
    write_lut_output(path("l.inc"), exr, {LutFormat::inc, PixelEncoding::unorm8});
    {
        std::ifstream in(path("l.inc"));
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        const std::size_t at = text.rfind('\n', text.size() - 2);
        std::ofstream(path("bad.inc")) << text.substr(0, at + 1) << "    999\n";
    }
    refused("bad.inc", "outside the unorm8 range");
    std::ofstream(path("notes.txt")) << "hello\n";
    refused("notes.txt", "not a LUT file this tool writes");
    // A partial bake cannot go to a format that has no NaN.
    LutFile partial = exr;
    partial.metadata["coverage"] = {{"unbaked", "NaN"}, {"rows", nlohmann::json::array()}};
    EXPECT_THROW(write_lut_output(path("p.png"), partial, {LutFormat::png, PixelEncoding::unorm8}), std::invalid_argument);
    EXPECT_FALSE(fs::exists(path("p.png")));
}

// A small LUT made here (no bake): 3 x 2 x 2 texels, 2 channels, values in [0, 1].
LutFile synthetic_lut() {
    std::vector<float> data(3 * 2 * 2 * 2);
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = float(i) / float(data.size());
    nlohmann::json meta = {{"layout", "custom"}, {"max_error", 0.001}, {"version", "test"}};
    return make_lut_file({{"visibility", 0, 1, 3, TexelConvention::centres}, {"n_dot_l", 0, 1, 2, TexelConvention::centres},
                          {"n_dot_v", 0, 1, 2, TexelConvention::centres}},
                         {{"R", 0.3, 0.09, 0.09}, {"G", 0.8, 0.64, 0.64}}, data, meta);
}

TEST_F(LutReaderTest, CutOrBitFlippedFilesOfEveryFormatAreRefusedOrReadAsValidLuts) {
    // A deterministic miniature of fuzz_lut_file: every prefix length in steps, and single-byte flips,
    // of a file of each format either read as a LUT that passes every check or refused with
    // std::runtime_error (never another exception, a crash or a texel outside [0, 1]).
    const LutFile lut = synthetic_lut();
    std::size_t refused = 0, accepted = 0;
    for (const auto& [name, format, encoding] : std::vector<std::tuple<std::string, LutFormat, PixelEncoding>>{
             {"l.ktx2", LutFormat::ktx2, PixelEncoding::float16}, {"l.dds", LutFormat::dds, PixelEncoding::unorm16},
             {"l.h", LutFormat::header, PixelEncoding::float32}, {"l.inc", LutFormat::inc, PixelEncoding::unorm8},
             {"l.png", LutFormat::png, PixelEncoding::unorm8}}) {
        write_lut_output(path(name), lut, {format, encoding});
        std::ifstream in(path(name), std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::vector<std::string> variants;
        for (std::size_t cut = 0; cut < bytes.size(); cut += 1 + bytes.size() / 23) variants.push_back(bytes.substr(0, cut));
        for (std::size_t at = 0; at < bytes.size(); at += 1 + bytes.size() / 37)
            for (unsigned char flip : {0x01, 0xff}) {
                std::string v = bytes;
                v[at] = char(static_cast<unsigned char>(v[at]) ^ flip);
                variants.push_back(v);
            }
        const std::string target = path("m" + fs::path(name).extension().string());
        if (format == LutFormat::dds) fs::copy_file(path(name) + ".json", target + ".json", fs::copy_options::overwrite_existing);
        for (const std::string& v : variants) {
            std::ofstream(target, std::ios::binary | std::ios::trunc) << v;
            try {
                const LutFile back = read_lut(target);
                ASSERT_EQ(back.data.size(), std::size_t(back.width) * back.height * back.channels.size()) << name;
                for (float x : back.data) ASSERT_TRUE(x >= 0 && x <= 1) << name;
                ++accepted;
            } catch (const std::runtime_error&) {
                ++refused;
            }
        }
    }
    std::cout << "[ figures  ] damaged files: " << refused << " refused, " << accepted << " read as valid LUTs\n";
    EXPECT_GT(refused, 0u);
}

TEST_F(LutReaderTest, EvalCompareShaderAndLutCommandsTakeEveryFormat) {
    bake("lut.exr");
    bake("lut.ktx2");  // from the bake itself, not converted
    const LutFile exr = read_lut(path("lut.exr"));
    write_lut_output(path("lut.dds"), exr, {LutFormat::dds, PixelEncoding::float32});
    write_lut_output(path("lut.h"), exr, {LutFormat::header, PixelEncoding::float32});
    write_lut_output(path("lut8.png"), exr, {LutFormat::png, PixelEncoding::unorm8});
    std::ofstream(path("q.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n"
                                    "0.5,0.16,0.16,0.9797959,0,0.2,0.6,0,0.8\n0.7,0.3,0.3,0,0.6,0.8,0.3,0,0.9539392\n";
    RunResult r = cli("eval --method sampled -q --backend oracle --samples 256 --in " + path("q.csv") + " --out " + path("r.csv") + " --compare exr=" +
                      path("lut.exr") + " --compare ktx2=" + path("lut.ktx2") + " --compare dds=" + path("lut.dds") +
                      " --compare h=" + path("lut.h") + " --compare png=" + path("lut8.png"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    auto cols = read_columns(path("r.csv"));
    ASSERT_EQ(cols["exr"].size(), 2u);
    EXPECT_EQ(cols["ktx2"], cols["exr"]);
    EXPECT_EQ(cols["dds"], cols["exr"]);
    EXPECT_EQ(cols["h"], cols["exr"]);
    for (std::size_t i = 0; i < 2; ++i)
        EXPECT_LE(std::abs(std::stod(cols["png"][i]) - std::stod(cols["exr"][i])), 0.5 / 255 + 1e-7);

    // shader: the same code from the KTX2 as from the EXR but for the file name it quotes.
    r = cli("shader " + path("lut.ktx2") + " --out " + path("k.glsl"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(fs::exists(path("k.glsl")));

    // lut info names the format, encoding and layout; lut export converts (unorm8 PNG -> EXR keeps the
    // PNG's rounding in its error budget).
    r = cli("lut info " + path("lut8.png"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("LUT, png unorm8"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("3D texture 5 x 4 x 3"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("channel B: roughness 0.9"), std::string::npos) << r.output;
    r = cli("lut export " + path("lut8.png") + " --out " + path("back.exr"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const LutFile back = read_lut(path("back.exr"));
    const LutFile png = read_lut(path("lut8.png"));
    EXPECT_EQ(back.data, png.data);
    EXPECT_EQ(back.metadata.at("exported_from").at("format"), "png");
    // The PNG's rounding: its 8-bit step plus the float32 rounding before it (at most 2^-24 for values <= 1).
    EXPECT_NEAR(back.metadata.at("error_budget").at("earlier_quantisation").get<double>(), 0.5 / 255, std::ldexp(1.0, -24));
    EXPECT_GE(back.metadata.at("error_budget").at("earlier_quantisation").get<double>(), 0.5 / 255);
    EXPECT_GE(back.metadata.at("max_total_error").get<double>(), png.metadata.at("max_total_error").get<double>())
        << "the total keeps the PNG's rounding";
    EXPECT_NEAR(back.metadata.at("max_total_error").get<double>(), png.metadata.at("max_total_error").get<double>(),
                std::ldexp(1.0, -24));
    r = cli("lut export " + path("lut.ktx2") + " --out " + path("x.dds") + " --encoding unorm16");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    expect_equal_within_step(read_lut(path("x.dds")), exr, PixelEncoding::unorm16, "ktx2 -> dds unorm16");
    // Bad requests: exit 2, nothing written.
    r = cli("lut export " + path("lut.exr") + " --out " + path("y.png") + " --encoding float32");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    r = cli("lut export " + path("missing.exr") + " --out " + path("y.exr"));
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_FALSE(fs::exists(path("y.png")));
    EXPECT_FALSE(fs::exists(path("y.exr")));
}

TEST_F(LutReaderTest, WrongKindOfFileGetsOneLineNamingTheRightCommand) {
    bake("lut.exr");
    RunResult r = cli("repr bake -q --kind azimuth-axis --visibility-count 2 --n-dot-l-count 2 --n-dot-v-count 2 "
                      "--azimuth-nodes 3 --roughness 0.5 --samples 256 --out " + path("r.exr"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    auto one_line = [](const RunResult& x, const std::string& want) {
        EXPECT_EQ(x.exit_code, 2) << x.output;
        EXPECT_NE(x.output.find(want), std::string::npos) << x.output;
        EXPECT_EQ(x.output.find("json.exception"), std::string::npos) << x.output;
        EXPECT_EQ(std::count(x.output.begin(), x.output.end(), '\n'), 1) << x.output;
    };
    // A representation where a LUT is expected (before: "[json.exception.out_of_range.403] key 'axes' not found").
    one_line(cli("shader " + path("r.exr")), "microshadow repr");
    one_line(cli("lut info " + path("r.exr")), "microshadow repr");
    // A LUT where a representation is expected.
    one_line(cli("repr info " + path("lut.exr")), "microshadow lut info");
    one_line(cli("repr shader " + path("lut.exr")), "microshadow shader");
    EXPECT_FALSE(fs::exists(path("out.glsl")));
}

TEST_F(LutReaderTest, RepresentationDdsOpensLikeItsExr) {
    RunResult r = cli("repr bake -q --kind azimuth-axis --visibility-count 2 --n-dot-l-count 3 --n-dot-v-count 2 "
                      "--azimuth-nodes 3 --roughness 0.4,0.8 --samples 256 --out " + path("r.exr"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = cli("repr export " + path("r.exr") + " --float --out " + path("r.dds"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(repr::is_representation_file(path("r.dds")));
    const auto a = repr::open_representation(path("r.exr"));
    const auto b = repr::open_representation(path("r.dds"));
    EXPECT_EQ(a->texels(), b->texels()) << "RGBA32F: the same floats";
    approx::Inputs in;
    for (double v : {0.3, 0.9}) {
        in.visibility = v, in.n_dot_l = 0.7, in.n_dot_v = 0.6, in.roughness = 0.5, in.relative_azimuth = 1.0;
        EXPECT_EQ((*a)(in), (*b)(in));
    }
    r = cli("repr info " + path("r.dds"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    // And from the command line, as a comparator.
    std::ofstream(path("q.csv")) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0.8,0.25,0.25,0.6,0,0.8,-0.6,0,0.8\n";
    r = cli("eval --method sampled -q --backend oracle --samples 256 --in " + path("q.csv") + " --out " + path("o.csv") + " --compare e=" + path("r.exr") +
            " --compare d=" + path("r.dds"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    auto cols = read_columns(path("o.csv"));
    EXPECT_EQ(cols["e"], cols["d"]);
}

}  // namespace
