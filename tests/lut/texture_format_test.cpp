// The one table of texture formats (lut/formats/texture_format.hpp) and the one writer
// (lut/formats/texture_writer.hpp): every output kind chooses its format by extension in any case, from
// the formats the table gives it, and refuses the others naming the table's list; the CLI's format
// lists are the table's; one TextureData written in every format reads back as the same values; the
// C source convention compiles in C99 and C++17 whatever the values (0 and 1 included).
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "cli_runner.hpp"
#include "env/image.hpp"
#include "lut/formats/texture_format.hpp"
#include "lut/formats/texture_reader.hpp"
#include "lut/formats/texture_writer.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ms::lutfmt;
using ms::testing::RunResult;
using ms::testing::run_shell;

const TextureUse kUses[] = {TextureUse::lut, TextureUse::dfg, TextureUse::representation, TextureUse::cubemap};

std::string upper(std::string s) {
    for (char& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

TEST(TextureFormatTable, EveryUseChoosesItsFormatsByExtensionInAnyCaseAndRefusesTheOthers) {
    for (TextureUse use : kUses) {
        const auto allowed = formats_for(use);
        ASSERT_FALSE(allowed.empty());
        for (const TextureFormatInfo& info : texture_formats())
            for (const char* ext : info.extensions) {
                const bool ok = std::find(allowed.begin(), allowed.end(), info.format) != allowed.end();
                for (const std::string path : {std::string("out/a") + ext, upper(std::string("out/a") + ext)}) {
                    if (ok) {
                        EXPECT_EQ(texture_format_for_path(path, use), info.format) << path;
                        continue;
                    }
                    try {
                        texture_format_for_path(path, use);
                        ADD_FAILURE() << path << " accepted for " << use_noun(use);
                    } catch (const std::invalid_argument& e) {
                        EXPECT_NE(std::string(e.what()).find(extension_list(use)), std::string::npos) << e.what();
                    }
                }
            }
        EXPECT_THROW(texture_format_for_path("a.jpg", use), std::invalid_argument);
        EXPECT_THROW(texture_format_for_path("noextension", use), std::invalid_argument);
        for (const std::string& name : format_names(use)) EXPECT_EQ(to_string(parse_texture_format(name, use)), name);
        EXPECT_THROW(parse_texture_format("hdr", use), std::invalid_argument);
    }
    // The lists are the table's, in its order.
    EXPECT_EQ(format_list(TextureUse::lut), "exr, ktx2, dds, header, inc or png");
    EXPECT_EQ(extension_list(TextureUse::cubemap), ".exr, .ktx2 or .dds");
    EXPECT_EQ(format_names(TextureUse::representation), (std::vector<std::string>{"exr", "ktx2", "dds"}));
    // Each format's default encoding is the first it stores.
    for (const TextureFormatInfo& info : texture_formats()) EXPECT_TRUE(format_supports(info.format, info.encodings.front()));
    EXPECT_FALSE(format_supports(TextureFormat::png, PixelEncoding::float32));
    EXPECT_FALSE(format_supports(TextureFormat::exr, PixelEncoding::unorm8));
}

class TextureWriterTest : public ms::testing::ScratchDirTest {
protected:
    TextureWriterTest() : ScratchDirTest("texture_writer") {}
    // 3 x 2 texels, 3 channels, values in [0, 1] with exact 0 and 1 among them.
    static TextureData image() {
        TextureData t;
        t.width = 3, t.height = 2, t.channels = 3;
        t.levels = {{0.0f, 1.0f, 0.5f, 0.25f, 0.125f, 1.0f, 0.0f, 0.75f, 0.2f, 0.3f, 0.4f, 0.6f, 0.9f, 1.0f, 0.0f, 0.33f, 0.66f, 0.99f}};
        t.metadata = {{"what", "a test image"}};
        t.c_identifier = "tiny_tex";
        t.c_comment = {"a test texture", "3 x 2 texels, 3 components"};
        t.c_defines = {"#define TINY_TEX_WIDTH 3u", "#define TINY_TEX_HEIGHT 2u", "#define TINY_TEX_DEPTH 1u"};
        return t;
    }
};

// KTX2, DDS and EXR of one TextureData hold the same floats (the containers' own readers).
TEST_F(TextureWriterTest, OneImageInEveryFloatFormatReadsBackTheSame) {
    const TextureData t = image();
    write_texture(path("t.exr"), TextureFormat::exr, t, PixelEncoding::float32);
    write_texture(path("t.ktx2"), TextureFormat::ktx2, t, PixelEncoding::float32);
    write_texture(path("t.dds"), TextureFormat::dds, t, PixelEncoding::float32);
    EXPECT_TRUE(fs::exists(path("t.dds.json"))) << "the DDS's metadata sidecar";
    nlohmann::json meta;
    const ms::env::Image exr = ms::env::read_exr_rgb(path("t.exr"), &meta);
    EXPECT_EQ(meta.at("what"), "a test image");
    ASSERT_EQ(exr.width, 3u);
    ASSERT_EQ(exr.height, 2u);
    for (const std::string name : {"t.ktx2", "t.dds"}) {
        const TextureFile file = name == "t.ktx2" ? read_ktx2_texture(path(name), 1000) : read_dds_texture(path(name), 1000);
        const TextureData& back = file.texture;
        EXPECT_EQ(back.metadata.at("what"), "a test image") << name;
        ASSERT_EQ(back.levels.size(), 1u) << name;
        ASSERT_EQ(back.levels[0].size(), 3u * 2 * 4) << name;  // RGBA, A repeating B
        for (std::uint32_t i = 0; i < 6; ++i)
            for (int c = 0; c < 4; ++c) {
                EXPECT_EQ(back.levels[0][i * 4 + c], t.levels[0][i * 3 + std::min(c, 2)]) << name << " texel " << i;
                if (c < 3) EXPECT_EQ(exr.at(i % 3, i / 3, c), t.levels[0][i * 3 + c]);
            }
    }
    // A format that cannot hold the encoding is refused, naming the file; nothing is written.
    EXPECT_THROW(write_texture(path("t.png"), TextureFormat::png, t, PixelEncoding::float32), std::invalid_argument);
    EXPECT_FALSE(fs::exists(path("t.png")));
}

// The C convention: a header and an initialiser list that compile in C99 and C++17 with exact 0 and 1
// values (a float literal always has a point or an exponent: "0.0f", never "0f").
TEST_F(TextureWriterTest, CSourceCompilesWithExactIntegersAndReadsBackTheFloats) {
    const TextureData t = image();
    write_texture(path("tiny_tex.h"), TextureFormat::header, t, PixelEncoding::float32);
    write_texture(path("tiny.inc"), TextureFormat::inc, t, PixelEncoding::float32);
    std::ifstream in(path("tiny_tex.h"));
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("static const float tiny_tex_data[TINY_TEX_DEPTH * TINY_TEX_HEIGHT * TINY_TEX_WIDTH * 3u]"), std::string::npos);
    EXPECT_NE(text.find("0.0f, 1.0f"), std::string::npos) << text;
    std::ofstream(path("use.c")) << "#include \"tiny_tex.h\"\nint main(void) { return (int)(tiny_tex_data[1] - 1.0f) + (int)sizeof tiny_tex_metadata * 0; }\n";
    std::ofstream(path("use.cpp")) << "static const float values[] = {\n#include \"tiny.inc\"\n};\nstatic_assert(sizeof values == 18 * sizeof(float), \"18\");\n"
                                      "#include \"tiny_tex.h\"\nint main() { return static_cast<int>(tiny_tex_data[TINY_TEX_WIDTH] * 0.0f + values[0]); }\n";
    for (const std::string cc : {"cc -std=c99 -Wall -Werror -fsyntax-only " + path("use.c"), "c++ -std=c++17 -Wall -Werror -fsyntax-only " + path("use.cpp")}) {
        const RunResult r = run_shell(cc + " 2>&1");
        EXPECT_EQ(r.exit_code, 0) << cc << "\n" << r.output;
    }
}

// The CLI's format lists and checks are the table's.
TEST(TextureFormatCli, FormatListsInHelpAndRefusalsComeFromTheTable) {
    const RunResult bake = run_shell(std::string(MICROSHADOW_CLI) + " bake --help 2>&1");
    EXPECT_NE(bake.output.find(format_list(TextureUse::lut)), std::string::npos) << bake.output;
    const RunResult dfg = run_shell(std::string(MICROSHADOW_CLI) + " ibl dfg --help 2>&1");
    EXPECT_NE(dfg.output.find(extension_list(TextureUse::dfg)), std::string::npos) << dfg.output;
    const RunResult prefilter = run_shell(std::string(MICROSHADOW_CLI) + " ibl prefilter --format hdr --out /nonexistent x.exr 2>&1");
    EXPECT_EQ(prefilter.exit_code, 2) << prefilter.output;
    for (const std::string& name : format_names(TextureUse::cubemap)) EXPECT_NE(prefilter.output.find(name), std::string::npos) << prefilter.output;
}

}  // namespace
