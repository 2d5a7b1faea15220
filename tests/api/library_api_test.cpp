// The public C++ API (include/microshadow/microshadow.hpp) against the jobs it wraps: evaluate and
// bake give the very numbers of jobs/eval and jobs/bake for the same options, a saved LUT opens
// again, and bad options are refused with the field named. (examples/consumer builds against the
// installed package: the ctest test package.consumer.)
#include <gtest/gtest.h>

#include <microshadow/microshadow.hpp>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <type_traits>

#include "analytic/part1_terms.hpp"
#include "core/cancel.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "lut/exr_lut.hpp"
#include "sampling/point_set.hpp"

namespace {

TEST(LibraryApi, EvaluateGivesTheEvalJobsNumbersForTheSameOptions) {
    microshadow::SamplingOptions o;
    o.method = microshadow::Method::sampled;
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
    spec.samples = 1024, spec.seed = 3, spec.backend = ms::schedule::BackendSpec::oracle();
    const ms::BakeResult r = ms::bake_lut(spec);
    for (std::uint32_t c = 0; c < 2; ++c)
        for (std::uint32_t z = 0; z < 2; ++z)
            for (std::uint32_t y = 0; y < 3; ++y)
                for (std::uint32_t x = 0; x < 5; ++x) ASSERT_EQ(lut.texel(c, x, y, z), r.at(c, x, y, z)) << c << x << y << z;
    EXPECT_EQ(lut.roughness(), (std::vector<double>{0.3, 0.9}));
    // Plus the values' rounding to float32 (at most 2^-24 for values <= 1).
    EXPECT_NEAR(lut.max_total_error(), r.max_std_error + r.azimuth_quadrature_error, std::ldexp(1.0, -24));
    EXPECT_GT(lut.max_total_error(), r.max_std_error + r.azimuth_quadrature_error);

    const auto dir = std::filesystem::temp_directory_path() / ("microshadow_api_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    for (const char* name : {"l.exr", "l.dds", "l.h"}) {
        const std::string path = (dir / name).string();
        lut.save(path);
        const microshadow::Lut back = microshadow::open_lut(path);
        for (std::uint32_t x = 0; x < 5; ++x) EXPECT_EQ(back.texel(1, x, 2, 1), lut.texel(1, x, 2, 1)) << name;
        EXPECT_EQ(back.lookup(0.4, 0.7, 0.6, microshadow::Roughness(0.5)), lut.lookup(0.4, 0.7, 0.6, microshadow::Roughness(0.5))) << name;
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
    one.method = microshadow::Method::sampled;
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
    // PrefilterOptions::bright takes what `ibl prefilter --bright` and Python's bright= take.
    microshadow::PrefilterOptions prefilter;
    prefilter.environment.image = "/nonexistent/sky.exr";
    prefilter.bright = "Auto";
    try {
        microshadow::prefilter(prefilter);
        ADD_FAILURE() << "bright = 'Auto' accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("bright = 'Auto' (auto or off)"), std::string::npos) << e.what();
    }
    EXPECT_EQ(microshadow::version(), MICROSHADOW_VERSION);
}

TEST(LibraryApi, AProgressThatReturnsFalseStopsTheCallWithCancelledAndTheNextCallRuns) {
    microshadow::SamplingOptions o;
    o.method = microshadow::Method::exact;
    o.backend = microshadow::Backend::oracle;
    o.tolerance = 1e-6;
    std::vector<microshadow::Query> queries(64, microshadow::isotropic_query(0.5, 0.4, 0.7, microshadow::Roughness(0.6), 90));
    std::uint64_t reports = 0;
    EXPECT_THROW(microshadow::evaluate(queries, o,
                                       [&](std::uint64_t, std::uint64_t) {
                                           ++reports;
                                           return false;
                                       }),
                 microshadow::Cancelled);
    EXPECT_GE(reports, 1u);
    // The jobs' cancel flag is lowered again: the same call now completes, its progress told the total.
    EXPECT_FALSE(ms::cancel_requested().load());
    std::uint64_t last_done = 0, last_total = 0;
    const auto values = microshadow::evaluate(queries, o, [&](std::uint64_t done, std::uint64_t total) {
        last_done = done, last_total = total;
        return true;
    });
    ASSERT_EQ(values.size(), queries.size());
    EXPECT_EQ(last_done, last_total);
    EXPECT_GT(values[0].value, 0.0);
}

TEST(LibraryApi, IsotropicQueryHasTheSweepsDirections) {
    const microshadow::Query q = microshadow::isotropic_query(0.3, 0.6, 0.8, microshadow::Roughness(0.5), 90);
    EXPECT_EQ(q.visibility, 0.3);
    EXPECT_EQ(q.alpha_x, 0.25);
    EXPECT_EQ(q.alpha_y, 0.25);
    EXPECT_NEAR(q.wi.x, 0.6, 1e-15);
    EXPECT_EQ(q.wi.y, 0.0);
    EXPECT_EQ(q.wi.z, 0.8);
    EXPECT_NEAR(q.wo.x, 0.0, 1e-15);  // 90 degrees from the view's side
    EXPECT_NEAR(q.wo.y, 0.8, 1e-15);
    EXPECT_EQ(q.wo.z, 0.6);
}

TEST(LibraryApi, AnalyticTermsByNameAreThePart1Terms) {
    const auto names = microshadow::analytic_term_names();
    ASSERT_EQ(names.size(), ms::analytic::kAllAnalyticTerms.size());
    EXPECT_EQ(names[1], "naughty-dog");
    const std::vector<microshadow::AnalyticInputs> in = {{0.5, 0.3, 0.8, 0.6}, {0.9, 0.1, 0.4, 0.2}};
    const auto nd = microshadow::analytic_term("naughty-dog", in);
    EXPECT_EQ(nd[0], ms::analytic::naughty_dog(0.5, 0.3));
    EXPECT_EQ(nd[1], ms::analytic::naughty_dog(0.9, 0.1));
    const auto act = microshadow::analytic_term("activision-adjusted", in, microshadow::AoWeighting::uniform);
    EXPECT_EQ(act[0], ms::analytic::activision_with_cone_adjustment(
                          0.5, ms::analytic::activision_roughness_from_alpha(0.36), 0.3, 0.8, ms::AoWeighting::uniform));
    EXPECT_THROW(microshadow::analytic_term("naughty-cat", in), std::invalid_argument);
}

// A 4 x 3 x 2 LUT of one roughness channel (0.5), sampled on the oracle in well under a second.
microshadow::Lut small_oracle_lut() {
    microshadow::BakeOptions b;
    b.layout = "custom";
    b.visibility_count = 4, b.n_dot_l_count = 3, b.n_dot_v_count = 2;
    b.roughness = {0.5};
    b.sampling.backend = microshadow::Backend::oracle;
    b.sampling.samples = 512;
    return microshadow::bake(b);
}

TEST(LibraryApi, OpenFileOpensALutAndRefusesOtherFiles) {
    const microshadow::Lut lut = small_oracle_lut();
    EXPECT_EQ(lut.axis_values("n_dot_l"), (std::vector<double>{1.0 / 6, 0.5, 5.0 / 6}));
    const std::vector<float> texels = lut.texels();
    ASSERT_EQ(texels.size(), 4u * 3 * 2);
    EXPECT_EQ(texels[(1 * 3 + 2) * 4 + 3], lut.texel(0, 3, 2, 1));  // [n_dot_v][n_dot_l][visibility][channel]
    const auto path = std::filesystem::temp_directory_path() / ("microshadow_api_open_" + std::to_string(::getpid()) + ".exr");
    lut.save(path.string());
    const microshadow::LookupFile file = microshadow::open_file(path.string());
    EXPECT_EQ(file.kind(), "lut");
    EXPECT_FALSE(file.keeps_azimuth());
    EXPECT_EQ(file.lookup(0.4, 0.5, 0.6, microshadow::Roughness(0.5), 120), lut.lookup(0.4, 0.5, 0.6, microshadow::Roughness(0.5)));
    EXPECT_NE(file.metadata_json().find("\"layout\""), std::string::npos);
    std::filesystem::remove(path);
    EXPECT_THROW(microshadow::open_file(path.string()), std::runtime_error);
}

// A preset sets the whole layout: a layout field beside it, or a name that is no preset, is refused
// before any bake, with the reason (the bake itself is compared with the CLI's in the Python tests).
TEST(LibraryApi, ARepresentationPresetRefusesALayoutBesideItAndUnknownNames) {
    microshadow::ReprBakeOptions o;
    o.preset = "full-range";
    o.visibility_count = 8;
    try {
        microshadow::repr_bake(o);
        ADD_FAILURE() << "a layout field beside a preset was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("sets the whole layout"), std::string::npos) << e.what();
    }
    o = {};
    o.preset = "fullrange";
    try {
        microshadow::repr_bake(o);
        ADD_FAILURE() << "an unknown preset was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("full-range"), std::string::npos) << e.what();
    }
}

}  // namespace

// One order and one type for isotropic parameters: a double never converts to a Roughness (so an
// alpha is never taken for a roughness by position), and from_alpha is the roughness of an alpha.
static_assert(!std::is_convertible_v<double, microshadow::Roughness>, "roughness is never an implicit double");

TEST(LibraryApi, RoughnessIsItsOwnTypeAndEvaluateDefaultsToTheExactMethodAsEval) {
    const microshadow::Roughness r = microshadow::Roughness::from_alpha(0.3);
    EXPECT_DOUBLE_EQ(r.alpha(), 0.3);
    const microshadow::Query q = microshadow::isotropic_query(0.5, 0.4, 0.8, r, 180);
    EXPECT_DOUBLE_EQ(q.alpha_x, 0.3);
    EXPECT_EQ(q.wo.z, 0.4);
    EXPECT_EQ(q.wi.z, 0.8);
    // `microshadow eval` defaults to the exact method; so does evaluate() with default options.
    microshadow::SamplingOptions defaults;
    defaults.backend = microshadow::Backend::oracle;
    microshadow::SamplingOptions exact = defaults;
    exact.method = microshadow::Method::exact;
    const auto got = microshadow::evaluate({q}, defaults);
    const auto want = microshadow::evaluate({q}, exact);
    EXPECT_EQ(got[0].value, want[0].value);
    EXPECT_EQ(got[0].std_error, want[0].std_error);
    EXPECT_LE(got[0].std_error, 1e-9);
}

TEST(LibraryApi, ALookupOfNotANumberIsAnInputErrorNamingIt) {
    const microshadow::Lut lut = small_oracle_lut();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const microshadow::Roughness half(0.5);
    auto message = [](const std::function<void()>& call) {
        try {
            call();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no std::invalid_argument");
    };
    EXPECT_EQ(message([&] { lut.lookup(nan, 0.5, 0.5, half); }), "lookup: visibility = nan: not a number");
    EXPECT_EQ(message([&] { lut.lookup(0.5, 0.5, nan, half); }), "lookup: n_dot_v = nan: not a number");
    EXPECT_EQ(message([&] { lut.lookup(0.5, 0.5, 0.5, microshadow::Roughness(nan)); }), "lookup: roughness = nan: not a number");
    EXPECT_TRUE(std::isfinite(lut.lookup(0.5, 0.5, 0.5, half)));
}
