// Recorded bounds of written files hold for the values the files store: the exact DFG LUT's
// "max_error_bound_99.9" includes the rounding of its quadrature values to float32 (or float16), checked
// texel by texel, every texel, against the independent quadrature (integrands/dfg/dfg_quadrature.hpp,
// other variables and its own code) at order 20.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include "cli_runner.hpp"
#include "env/image.hpp"
#include "integrands/dfg/dfg_quadrature.hpp"
#include "jobs/ibl_dfg.hpp"

namespace {

using ms::testing::ScratchDirTest;

class StoredBoundTest : public ScratchDirTest {
protected:
    StoredBoundTest() : ScratchDirTest("stored_bound") {}
};

// The RGB texels of a float32 KTX2 2D texture of RGBA (KTX 2.0: level 0's offset at byte 80).
std::vector<float> ktx2_rgb(const std::string& path, std::uint32_t texels) {
    std::ifstream in(path, std::ios::binary);
    const std::vector<char> b{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::uint64_t offset = 0;
    std::memcpy(&offset, b.data() + 80, 8);
    std::vector<float> rgb;
    for (std::uint32_t i = 0; i < texels; ++i)
        for (int c = 0; c < 3; ++c) {
            float v;
            std::memcpy(&v, b.data() + offset + (std::size_t(i) * 4 + c) * 4, 4);
            rgb.push_back(v);
        }
    return rgb;
}

std::string read_all(const std::string& path) {
    std::ifstream in(path);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST_F(StoredBoundTest, ExactDfgFilesHoldEveryTexelWithinTheirRecordedBound) {
    ms::DfgBakeSpec spec;
    spec.method = ms::DfgMethod::exact;
    spec.n_dot_v = {"n_dot_v", 0, 1, 8};
    spec.roughness = {"roughness", 0, 1, 10};
    const ms::DfgBakeResult result = ms::bake_dfg(spec);
    const nlohmann::json meta = ms::dfg_metadata(spec, result);
    // The independent reference per texel, and its own error (two orders; at most 1e-10 by
    // IblDfgExact.AgreesWithTheIndependentQuadratureTo1e10): far below a float step.
    std::vector<double> reference, reference_error;
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x) {
            const auto p = ms::dfg_texel_point(spec, x, y);
            const auto q = ms::dfg::dfg_quadrature(p.n_dot_v, p.alpha, 20);
            reference.insert(reference.end(), {q.scale, q.bias, q.scale + q.bias});
            const double e = std::max({q.scale_error, q.bias_error, 1e-10});
            reference_error.insert(reference_error.end(), {e, e, 2 * e});
        }
    struct Case {
        std::string file;
        bool half;
    };
    double worst_ratio = 0;
    for (const Case& c : std::vector<Case>{{"dfg.exr", false}, {"dfg_half.exr", true}, {"dfg.ktx2", false}, {"dfg.inc", false}}) {
        SCOPED_TRACE(c.file);
        ms::write_dfg_lut(path(c.file), result, meta, c.half);
        std::vector<float> stored;
        nlohmann::json recorded;
        if (c.file.find(".exr") != std::string::npos) {
            stored = ms::env::read_exr_rgb(path(c.file), &recorded).data;
        } else if (c.file.find(".ktx2") != std::string::npos) {
            stored = ktx2_rgb(path(c.file), result.width * result.height);
            // The KTX2's metadata: the key/value entry "microshadow" (a JSON object after the key's NUL).
            const std::string bytes = read_all(path(c.file));
            const std::size_t key = bytes.find(std::string("microshadow") + '\0');
            ASSERT_NE(key, std::string::npos);
            const std::size_t from = key + 12, to = bytes.find('\0', from);
            recorded = nlohmann::json::parse(bytes.substr(from, to - from));
        } else {
            // The C initialiser list: the metadata on its comment line, then the floats.
            const std::string text = read_all(path(c.file));
            const std::string tag = "/* microshadow-metadata: ";
            const std::size_t open = text.find(tag) + tag.size(), close = text.find(" */", open);
            ASSERT_NE(close, std::string::npos);
            recorded = nlohmann::json::parse(text.substr(open, close - open));
            std::size_t at = text.find("#include inside an initialiser */");
            ASSERT_NE(at, std::string::npos);
            for (at = text.find_first_of("0123456789-", at + 33); at != std::string::npos && stored.size() < reference.size();
                 at = text.find_first_of("0123456789-", text.find_first_of(",}", at))) {
                std::size_t used = 0;
                stored.push_back(std::stof(text.substr(at, 40), &used));
                at += used;
            }
        }
        ASSERT_EQ(stored.size(), reference.size());
        const double bound = recorded.at("max_error_bound_99.9").get<double>();
        EXPECT_GT(bound, recorded.at("computed_error_bound_99.9").get<double>()) << "the storage's rounding is part of the bound";
        std::size_t over = 0;
        for (std::size_t i = 0; i < stored.size(); ++i) {
            const double error = std::abs(double(stored[i]) - reference[i]) - reference_error[i];
            worst_ratio = std::max(worst_ratio, error / bound);
            over += error > bound;
        }
        EXPECT_EQ(over, 0u) << "of " << stored.size() << " stored values, recorded bound " << bound;
    }
    std::printf("[ figures  ] exact DFG 8 x 10: worst |stored - quadrature| / recorded bound %.3f\n", worst_ratio);
}

}  // namespace
