// The public C++ API (include/microshadow/microshadow.hpp) against the jobs it wraps: evaluate and
// bake give the very numbers of jobs/eval and jobs/bake for the same options, a saved LUT opens
// again, and bad options are refused with the field named. (examples/consumer builds against the
// installed package: the ctest test package.consumer.)
#include <gtest/gtest.h>

#include <microshadow/microshadow.hpp>

#include <unistd.h>

#include <filesystem>

#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "lut/exr_lut.hpp"
#include "sampling/point_set.hpp"

namespace {

TEST(LibraryApi, EvaluateGivesTheEvalJobsNumbersForTheSameOptions) {
    microshadow::SamplingOptions o;
    o.backend = microshadow::Backend::oracle;
    o.samples = 2048;
    o.replicates = 4;
    o.seed = 11;
    o.ao_weighting = microshadow::AoWeighting::uniform;
    o.form = microshadow::Form::uncorrelated;
    microshadow::Query q;
    q.visibility = 0.6;
    q.alpha_x = 0.2, q.alpha_y = 0.5;
    q.wi = {0.6, 0, 0.8};
    q.wo = {0, 0.8, 0.6};
    const auto got = microshadow::evaluate({q, microshadow::Query{}}, o);

    ms::SamplingPlan plan;
    plan.samples = 2048, plan.replicates = 4, plan.seed = 11;
    ms::TermOptions t;
    t.ao_weighting = ms::AoWeighting::uniform, t.form = ms::Form::uncorrelated;
    auto backend = ms::make_oracle_backend();
    const auto want = ms::evaluate(*backend, {{0.6, 0.2, 0.5, {0.6, 0, 0.8}, {0, 0.8, 0.6}}, ms::Query{}}, t, plan);
    ASSERT_EQ(got.size(), 2u);
    EXPECT_EQ(got[0].value, want[0].term);
    EXPECT_EQ(got[0].std_error, want[0].std_error);
    EXPECT_GT(got[0].std_error, 0);
    EXPECT_EQ(got[1].value, 1.0);  // the default query: visibility 1
}

TEST(LibraryApi, BakeGivesTheBakeJobsTexelsAndSavedFilesOpenAgain) {
    microshadow::BakeOptions b;
    b.layout = "custom";
    b.visibility_count = 5, b.n_dot_l_count = 3, b.n_dot_v_count = 2;
    b.roughness = {0.3, 0.9};
    b.sampling.backend = microshadow::Backend::oracle;
    b.sampling.samples = 1024;
    b.sampling.seed = 3;
    const microshadow::Lut lut = microshadow::bake(b);

    ms::BakeSpec spec = ms::default_bake_spec(ms::LutLayout::custom, 32);
    spec.visibility.count = 5, spec.n_dot_l.count = 3, spec.n_dot_v.count = 2;
    spec.roughness = {0.3, 0.9};
    spec.samples = 1024, spec.seed = 3, spec.oracle = true;
    const ms::BakeResult r = ms::bake_lut(spec);
    for (std::uint32_t c = 0; c < 2; ++c)
        for (std::uint32_t z = 0; z < 2; ++z)
            for (std::uint32_t y = 0; y < 3; ++y)
                for (std::uint32_t x = 0; x < 5; ++x) ASSERT_EQ(lut.texel(c, x, y, z), r.at(c, x, y, z)) << c << x << y << z;
    EXPECT_EQ(lut.roughness(), (std::vector<double>{0.3, 0.9}));
    EXPECT_NEAR(lut.max_total_error(), r.max_std_error + r.azimuth_quadrature_error, 1e-9);

    const auto dir = std::filesystem::temp_directory_path() / ("microshadow_api_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    for (const char* name : {"l.exr", "l.dds", "l.h"}) {
        const std::string path = (dir / name).string();
        lut.save(path);
        const microshadow::Lut back = microshadow::open_lut(path);
        for (std::uint32_t x = 0; x < 5; ++x) EXPECT_EQ(back.texel(1, x, 2, 1), lut.texel(1, x, 2, 1)) << name;
        EXPECT_EQ(back.lookup(0.4, 0.7, 0.6, 0.5), lut.lookup(0.4, 0.7, 0.6, 0.5)) << name;
    }
    lut.save((dir / "l8.png").string());  // unorm8 by default
    EXPECT_NEAR(microshadow::open_lut((dir / "l8.png").string()).texel(0, 2, 1, 0), lut.texel(0, 2, 1, 0), 0.5 / 255 + 1e-7);
    std::filesystem::remove_all(dir);
}

TEST(LibraryApi, BadOptionsAreRefusedWithTheFieldNamed) {
    microshadow::SamplingOptions exact;
    exact.method = microshadow::Method::exact;
    exact.backend = microshadow::Backend::oracle;
    exact.tolerance = 1e-20;  // below what the evaluator is asked for
    try {
        microshadow::evaluate({microshadow::Query{}}, exact);
        ADD_FAILURE() << "tolerance 1e-20 accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("tolerance"), std::string::npos) << e.what();
    }
    exact.tolerance = 1e-9;
    microshadow::Query q;
    q.visibility = 0.6;
    q.wi = {0.6, 0, 0.8};
    q.wo = {0, 0.6, 0.8};
    const auto values = microshadow::evaluate({q}, exact);
    ASSERT_EQ(values.size(), 1u);
    EXPECT_GT(values[0].value, 0.0);
    EXPECT_LE(values[0].std_error, 1e-9);
    microshadow::SamplingOptions one;
    one.replicates = 1;
    one.backend = microshadow::Backend::oracle;
    EXPECT_THROW(microshadow::evaluate({microshadow::Query{}}, one), std::invalid_argument);
    microshadow::BakeOptions seed;
    seed.roughness = {0.5};  // the seed layouts fix their roughness
    EXPECT_THROW(microshadow::bake(seed), std::invalid_argument);
    microshadow::BakeOptions layout;
    layout.layout = "seed-4d";
    EXPECT_THROW(microshadow::bake(layout), std::invalid_argument);
    EXPECT_THROW(microshadow::open_lut("/nonexistent/l.exr"), std::runtime_error);
    EXPECT_EQ(microshadow::version(), MICROSHADOW_VERSION);
}

}  // namespace
