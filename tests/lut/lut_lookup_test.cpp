// The LUT lookup's early-out (lut/lookup.hpp): the C++ lookup behind eval --compare, sweeps, scenes,
// design and the library answers exactly 0 where the generated shader returns 0 (the zero region of the
// LUT's AO weighting and the light at or below the horizon), before reading any texel, and decides the
// region's edge in binary32 as the shader does. tests/gpu/shader_test.cpp runs the shaders against it.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lut/formats/lut_formats.hpp"
#include "lut/lookup.hpp"

namespace {

using ms::LutFile;
using ms::TexelConvention;

// Every texel 1: a lookup that reads any texel answers 1, one that answers by rule 0.
LutFile lut_of_ones(const std::string& weighting) {
    std::vector<float> data(8 * 6 * 3 * 2, 1.0f);
    nlohmann::json meta = {{"layout", "custom"}, {"version", "test"}};
    if (!weighting.empty()) meta["ao_weighting"] = weighting;
    return ms::lutfmt::make_lut_file({{"visibility", 0, 1, 8, TexelConvention::centres}, {"n_dot_l", 0, 1, 6, TexelConvention::endpoints},
                                      {"n_dot_v", 0, 1, 3, TexelConvention::centres}},
                                     {{"R", 0.3, 0.09, 0.09}, {"G", 0.8, 0.64, 0.64}}, data, meta);
}

TEST(LutLookupTest, AnswersZeroInTheZeroRegionOfItsWeightingAndReadsTexelsOutside) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0, 1);
    for (const std::string weighting : {"", "cosine", "uniform"}) {
        SCOPED_TRACE(weighting);
        const ms::LutLookup lookup(lut_of_ones(weighting));
        const bool cosine = weighting != "uniform";
        EXPECT_EQ(lookup.ao_weighting(), cosine ? ms::AoWeighting::cosine : ms::AoWeighting::uniform);
        std::size_t zeros = 0, ones = 0;
        for (int i = 0; i < 20000; ++i) {
            const double v = u(rng), l = 1.1 * u(rng) - 0.1, nv = u(rng), r = u(rng);
            // The region with margins well beyond binary32 rounding: its exact form.
            const double edge = cosine ? 1 - 2 * v : 2 * (1 - v) * (1 - v) - 1;
            if (std::abs(l - edge) < 1e-6 || std::abs(l) < 1e-6) continue;
            const bool zero = l <= 0 || l <= edge;
            EXPECT_EQ(lookup(v, l, nv, r), zero ? 0.0 : 1.0) << "v " << v << " NdotL " << l;
            (zero ? zeros : ones)++;
        }
        EXPECT_GT(zeros, 2000u);
        EXPECT_GT(ones, 2000u);
    }
    EXPECT_THROW(ms::LutLookup(lut_of_ones("hemispherical")), std::runtime_error);
}

// On the edge and one binary32 step either side: the region decided in binary32 arithmetic on binary32
// inputs, as the shaders decide it (2 v + NdotL rounds to 1 one step above the edge; a double test would
// call that point outside and read the texels there).
TEST(LutLookupTest, DecidesTheZeroRegionsEdgeInBinary32AsTheShaderDoes) {
    const ms::LutLookup cosine(lut_of_ones("cosine")), uniform(lut_of_ones("uniform"));
    for (int k = 0; k <= 64; ++k) {
        const float v = 0.25f + 0.25f * float(k) / 64;
        const float on = 1.0f - 2.0f * v;  // exact
        EXPECT_EQ(cosine(v, on, 0.5, 0.5), 0.0);
        EXPECT_EQ(cosine(v, std::nextafter(on, -1.0f), 0.5, 0.5), 0.0);
        // One step above: 2 v + NdotL = 1 + ulp(NdotL) rounds to 1 in binary32 (ulp(NdotL) <= 2^-24).
        EXPECT_EQ(cosine(v, std::nextafter(on, 2.0f), 0.5, 0.5), 0.0) << v;
        EXPECT_EQ(cosine(v, on + std::ldexp(1.0f, -21), 0.5, 0.5), 1.0) << v;
        EXPECT_TRUE(ms::lookup_zero_region(ms::AoWeighting::cosine, v, double(std::nextafter(on, 2.0f))));
    }
    for (int k = 1449; k < 2048; k += 37) {
        const float c = float(k) / 2048, v = 1.0f - c, on = 2.0f * c * c - 1.0f;  // all exact
        EXPECT_EQ(uniform(v, on, 0.5, 0.5), 0.0);
        EXPECT_EQ(uniform(v, std::nextafter(on, -1.0f), 0.5, 0.5), 0.0);
        EXPECT_EQ(uniform(v, on + std::ldexp(1.0f, -21), 0.5, 0.5), 1.0) << v;
    }
    // The horizon: NdotL 0 and below answer 0 at any visibility, v = 1 included.
    EXPECT_EQ(cosine(1.0, 0.0, 0.5, 0.5), 0.0);
    EXPECT_EQ(uniform(1.0, -0.25, 0.5, 0.5), 0.0);
    EXPECT_EQ(cosine(1.0, 1e-3, 0.5, 0.5), 1.0);
}

}  // namespace
