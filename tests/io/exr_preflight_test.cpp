// The OpenEXR preflight (io/exr_preflight.hpp): every claim a header makes must fit in the file before
// OpenEXR allocates it. A fuzzer finding: fuzz_lut_file made read_lut ask for 1.7 GB from a
// 4 KB file through an attribute's declared size (tests/data/hostile/exr/attribute-claims-1.7GB.exr).
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>

#include <cstring>
#include <functional>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_runner.hpp"
#include "io/exr_preflight.hpp"
#include "env/image.hpp"
#include "lut/exr_lut.hpp"
#include "repr/representation.hpp"
#include "scene/image_io.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::ScratchDirTest;

class ExrPreflightTest : public ScratchDirTest {
protected:
    ExrPreflightTest() : ScratchDirTest("exr_preflight") {}
    // A 4 x (3 x 2) two-channel LUT as the bake writes it.
    std::string write_small_lut() {
        std::vector<ms::LutAxis> axes{{"visibility", 0, 1, 4, ms::TexelConvention::centres},
                                      {"n_dot_l", 0, 1, 3, ms::TexelConvention::centres},
                                      {"n_dot_v", 0, 1, 2, ms::TexelConvention::centres}};
        std::vector<ms::LutChannel> channels{{"R", 0.4, 0.16, 0.16}, {"G", 0.7, 0.49, 0.49}};
        std::vector<float> data(4 * 6 * 2, 0.5f);
        const std::string p = path("lut.exr");
        ms::write_lut(p, axes, channels, data, nlohmann::json::object(), false);
        return p;
    }
    static std::string slurp(const std::string& file) {
        std::ifstream in(file, std::ios::binary);
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }
    std::string write(const std::string& name, const std::string& bytes) {
        const std::string p = path(name);
        std::ofstream(p, std::ios::binary) << bytes;
        return p;
    }
    // The message preflight throws for `path` ("" when it accepts the file).
    static std::string refusal(const std::string& file) {
        try {
            ms::exr::preflight(file);
        } catch (const ms::exr::PreflightError& e) {
            return e.what();
        }
        return "";
    }
    static void put_i32(std::string& bytes, std::size_t at, std::int32_t v) {
        for (int i = 0; i < 4; ++i) bytes[at + std::size_t(i)] = char((std::uint32_t(v) >> (8 * i)) & 0xff);
    }
    // The offset of the 4-byte size field of attribute `name` of type `type`.
    static std::size_t size_field(const std::string& bytes, const std::string& name, const std::string& type) {
        const std::string key = name + std::string(1, '\0') + type + std::string(1, '\0');
        const std::size_t at = bytes.find(key);
        EXPECT_NE(at, std::string::npos) << name;
        return at + key.size();
    }
};

TEST_F(ExrPreflightTest, AcceptsWhatTheBakeWritesAndDescribesIt) {
    const auto s = ms::exr::preflight(write_small_lut());
    ASSERT_EQ(s.parts.size(), 1u);
    EXPECT_FALSE(s.multi_part);
    EXPECT_EQ(s.parts[0].type, "scanlineimage");
    EXPECT_EQ(s.parts[0].width, 4);
    EXPECT_EQ(s.parts[0].height, 6);
    EXPECT_EQ(s.parts[0].channels, 2u);
    EXPECT_EQ(s.parts[0].chunks, 1u);  // ZIP: 16 lines per chunk
}

// The files fuzz_lut_file found: an opaque attribute declaring 1.7 GB; a box2i declared 1 byte long and a
// channel list declared longer than its entries, after which OpenEXR parsed the rest of the header out
// of step and met a size of 1.7-2 GB.
TEST_F(ExrPreflightTest, TheFuzzerFindingsAreRefusedBeforeOpenExrAllocates) {
    const std::string data = std::string(MICROSHADOW_TEST_DATA) + "/hostile/exr/";
    for (const auto& [file, reason] : {std::pair<std::string, std::string>{"attribute-claims-1.7GB.exr", "claims 1700986880 bytes"},
                                       {"box2i-declared-1-byte.exr", "(box2i) declares 1 bytes, its type has 16"},
                                       {"chlist-declared-longer.exr", "the channel list ends before its declared size"}}) {
        EXPECT_NE(refusal(data + file).find(reason), std::string::npos) << refusal(data + file);
        try {
            ms::read_lut(data + file);
            ADD_FAILURE() << "read_lut accepted " << file;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
        }
    }
}

// One class per claim a header makes: an attribute's size, the data window (the offset table's and
// the chunks' size), the multi-part header list, and a file cut short.
TEST_F(ExrPreflightTest, EveryClaimBeyondTheFileIsRefusedAndNamed) {
    const std::string good = slurp(write_small_lut());
    ASSERT_EQ(refusal(write("good.exr", good)), "");

    std::string big_string = good;  // the metadata string claims 1.5 GB
    put_i32(big_string, size_field(good, "microshadow", "string"), 1500000000);
    EXPECT_NE(refusal(write("a.exr", big_string)).find("attribute 'microshadow' (string) claims 1500000000 bytes"), std::string::npos)
        << refusal(write("a.exr", big_string));

    std::string negative = good;
    put_i32(negative, size_field(good, "microshadow", "string"), -4);
    EXPECT_NE(refusal(write("b.exr", negative)).find("negative size"), std::string::npos);

    std::string tall = good;  // dataWindow y max = 2^30: 2^26 ZIP chunks the file cannot hold
    put_i32(tall, size_field(good, "dataWindow", "box2i") + 4 + 12, 1 << 30);
    EXPECT_NE(refusal(write("c.exr", tall)).find("(4 x 1073741825) needs at least 67108865 chunks"), std::string::npos) << refusal(write("c.exr", tall));
    EXPECT_THROW(ms::read_lut(write("c.exr", tall)), std::runtime_error);

    std::string short_box = good;  // OpenEXR reads a box2i as 16 bytes whatever its declared size
    put_i32(short_box, size_field(good, "displayWindow", "box2i"), 1);
    EXPECT_NE(refusal(write("f.exr", short_box)).find("attribute 'displayWindow' (box2i) declares 1 bytes, its type has 16"),
              std::string::npos)
        << refusal(write("f.exr", short_box));

    std::string long_list = good;  // a channel list declared longer than its entries
    {
        const std::size_t at = size_field(good, "channels", "chlist");
        std::int32_t declared = 0;
        for (int i = 3; i >= 0; --i) declared = declared * 256 + std::uint8_t(good[at + std::size_t(i)]);
        long_list.insert(at + 4 + std::size_t(declared), 8, '\x01');
        put_i32(long_list, at, declared + 8);
    }
    EXPECT_NE(refusal(write("g.exr", long_list)).find("the channel list ends before its declared size"), std::string::npos)
        << refusal(write("g.exr", long_list));

    std::string multi = good;  // the multi-part flag without the empty header that ends the list
    multi[5] = char(multi[5] | 0x10);
    EXPECT_NE(refusal(write("d.exr", multi)), "");

    for (std::size_t cut : {std::size_t(3), std::size_t(40), good.size() / 2, good.size() - 20}) {
        const std::string msg = refusal(write("e.exr", good.substr(0, cut)));
        EXPECT_NE(msg.find("not a readable OpenEXR file"), std::string::npos) << "cut at " << cut << ": " << msg;
    }
}

// Scene images come from DCC tools as multi-part files: the preflight walks every header.
TEST_F(ExrPreflightTest, MultiPartFilesPassWithEveryPartDescribed) {
    const std::string file = path("multi.exr");
    {
        std::vector<Imf::Header> headers;
        for (const char* name : {"beauty", "normals"}) {
            Imf::Header h(8, 5);
            h.setName(name);
            h.setType(Imf::SCANLINEIMAGE);
            h.channels().insert("Y", Imf::Channel(Imf::FLOAT));
            headers.push_back(h);
        }
        Imf::MultiPartOutputFile out(file.c_str(), headers.data(), int(headers.size()));
        std::vector<float> pixels(8 * 5, 0.25f);
        for (int p = 0; p < 2; ++p) {
            Imf::OutputPart part(out, p);
            Imf::FrameBuffer fb;
            fb.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data()), sizeof(float), 8 * sizeof(float)));
            part.setFrameBuffer(fb);
            part.writePixels(5);
        }
    }
    const auto s = ms::exr::preflight(file);
    EXPECT_TRUE(s.multi_part);
    ASSERT_EQ(s.parts.size(), 2u);
    EXPECT_EQ(s.parts[0].name, "beauty");
    EXPECT_EQ(s.parts[1].name, "normals");
    EXPECT_EQ(s.parts[1].width, 8);
    EXPECT_EQ(s.parts[1].height, 5);
    EXPECT_THROW(ms::read_lut(file), std::runtime_error);  // a LUT is one part

    // The same file claiming 2^30 chunks for its second part.
    std::string bytes = slurp(file);
    const std::string key = std::string("chunkCount") + '\0' + "int" + '\0';
    const std::size_t first = bytes.find(key), second = bytes.find(key, first + 1);
    ASSERT_NE(second, std::string::npos);
    put_i32(bytes, second + key.size() + 4, 1 << 30);
    EXPECT_NE(refusal(write("multi-forged.exr", bytes)).find("needs at least"), std::string::npos);
}

// Every reader of EXR files runs the preflight: scene images, environments and representation files
// refuse the fuzzer's files with the same named claim, and a 2^28-pixel limit bounds what a well-formed
// image may make a reader decode.
TEST_F(ExrPreflightTest, SceneEnvironmentAndRepresentationReadersRefuseTheSameFiles) {
    const std::string forged = std::string(MICROSHADOW_TEST_DATA) + "/hostile/exr/attribute-claims-1.7GB.exr";
    const auto message = [](const std::function<void()>& read) -> std::string {
        try {
            read();
        } catch (const std::exception& e) {
            return e.what();
        }
        return "accepted";
    };
    for (const std::string& m : {message([&] { ms::scene::list_channels(forged); }),
                                 message([&] { ms::env::read_exr_rgb(forged); }),
                                 message([&] { ms::repr::open_representation(forged); })})
        EXPECT_NE(m.find("claims 1700986880 bytes"), std::string::npos) << m;

    std::string wide = slurp(write_small_lut());  // data window 2^20 x 2^10 texels: 2^30 > 2^28
    const std::size_t at = size_field(wide, "dataWindow", "box2i") + 4;
    put_i32(wide, at + 8, (1 << 20) - 1);
    put_i32(wide, at + 12, (1 << 10) - 1);
    wide.append(std::size_t(1 << 10) / 16 * 16 + 64, '\0');  // room for the 64 ZIP chunks' offsets and headers
    const std::string path_wide = write("wide.exr", wide);
    EXPECT_EQ(refusal(path_wide), "");
    EXPECT_NE(message([&] { ms::scene::list_channels(path_wide); }).find("more than the limit of 268435456 pixels"), std::string::npos)
        << message([&] { ms::scene::list_channels(path_wide); });

    // fuzz_repr_file's finding: a 2^22-wide image whose chunk buffer OpenEXR sizes at 1.6 GB.
    const std::string wide_chunk = std::string(MICROSHADOW_TEST_DATA) + "/hostile/exr/wide-chunk-buffer-1.6GB.exr";
    for (const std::string& m : {message([&] { ms::scene::list_channels(wide_chunk); }),
                                 message([&] { ms::env::read_exr_rgb(wide_chunk); }),
                                 message([&] { ms::repr::open_representation(wide_chunk); }),
                                 message([&] { ms::read_lut(wide_chunk); })})
        EXPECT_TRUE(m.find("chunk buffer of more than 256 MiB") != std::string::npos || m.find("more than the limit of") != std::string::npos) << m;
}

}  // namespace
