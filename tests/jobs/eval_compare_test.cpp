// `microshadow eval --method sampled --compare`: comparator columns of part 1's analytic terms
// and of baked LUTs beside the term, their error columns, the summary and the refusals.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cli_runner.hpp"
#include "io/csv.hpp"
#include "jobs/compare.hpp"
#include "jobs/eval.hpp"
#include "jobs/sweep/points.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "lut/exr_lut.hpp"
#include "lut/lookup.hpp"

namespace {

namespace fs = std::filesystem;
using ms::testing::RunResult;
using ms::testing::ScratchDirTest;
using ms::testing::run_shell;

RunResult run_compare_cli(const std::string& args) { return run_shell(std::string(MICROSHADOW_CLI) + " " + args + " 2>&1"); }

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string x;
    while (std::getline(ss, x, ',')) f.push_back(x);
    return f;
}

// A CSV as columns of text by header name.
std::map<std::string, std::vector<std::string>> read_columns(const fs::path& p) {
    std::ifstream in(p);
    std::string line;
    std::getline(in, line);
    const auto header = split(line);
    std::map<std::string, std::vector<std::string>> cols;
    for (const auto& h : header) cols[h];
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        const auto f = split(line);
        EXPECT_EQ(f.size(), header.size()) << line;
        for (std::size_t i = 0; i < header.size() && i < f.size(); ++i) cols[header[i]].push_back(f[i]);
    }
    return cols;
}

// A small LUT with a smooth, roughness- and NdotV-dependent content (not a real bake: the lookup is
// what is compared), with "version" and "command_line" in its metadata.
fs::path write_lut(const fs::path& dir, const std::string& name) {
    using ms::LutAxis;
    using ms::LutChannel;
    const auto texel = ms::TexelConvention::centres;
    std::vector<LutAxis> axes = {{"visibility", 0, 1, 5, texel}, {"n_dot_l", 0, 1, 4, texel}, {"n_dot_v", 0, 1, 3, texel}};
    std::vector<LutChannel> ch = {{"R", 0.1, 0.01, 0.01}, {"G", 0.4, 0.16, 0.16}, {"B", 0.7, 0.49, 0.49}};
    std::vector<float> data;
    for (std::uint32_t k = 0; k < 3; ++k)
        for (std::uint32_t j = 0; j < 4; ++j)
            for (std::uint32_t i = 0; i < 5; ++i)
                for (const auto& c : ch)
                    data.push_back(float((axes[0].value(i) * axes[0].value(i) + 2 * axes[1].value(j) +
                                          4 * axes[2].value(k) * axes[2].value(k) + 8 * c.roughness) / 16));
    nlohmann::json meta = {{"layout", "custom"}, {"azimuth", "mean"}, {"form", "height-correlated"},
                           {"ao_weighting", "uniform"}, {"sequence", "sobol"}, {"seed", 0}, {"samples", 16},
                           {"max_error", 0}, {"device", "test"}, {"version", "lut-version-7"},
                           {"command_line", "microshadow bake --test"}};
    const fs::path p = dir / name;
    ms::write_lut(p.string(), axes, ch, data, meta, false);
    return p;
}

const std::vector<std::string> kAnalytic = {"reference-step", "naughty-dog", "naughty-dog-ao-fresnel",
                                            "activision", "activision-adjusted", "pz-analytic"};

class EvalCompareTest : public ScratchDirTest {
protected:
    EvalCompareTest() : ScratchDirTest("eval_compare") {}
    // The query CSV of the sweep spec's points (anisotropic, two NdotV, uniform AO weighting).
    std::string spec_text() const {
        std::string analytic;
        for (const auto& a : kAnalytic) analytic += (analytic.empty() ? "\"" : ", \"") + a + "\"";
        return "[sweep]\nchunk_size = 64\n[parameters]\nvisibility = {start = 0.05, stop = 0.95, count = 4}\n"
               "n_dot_l = {start = 0.1, stop = 1, count = 3}\nn_dot_v = [0.35, 0.9]\nalpha_x = [0.05, 0.6]\n"
               "alpha_y = [0.3]\nphi_i = [30]\ndelta_phi = [0, 120]\nao_weighting = [\"uniform\"]\n"
               "[comparators]\nanalytic = [" + analytic + "]\n[[comparators.lut]]\nname = \"lut\"\nfile = \"lut.exr\"\n";
    }
};

TEST_F(EvalCompareTest, ColumnsEqualTheSweepsComparatorsAtTheSamePoints) {
    const fs::path lut = write_lut(dir_, "lut.exr");
    const ms::sweep::Spec spec = ms::sweep::parse_spec(spec_text(), "t.toml", dir_.string());
    auto backend = ms::make_oracle_backend(1);
    ms::sweep::RunConfig config;
    config.out_dir = path("sweep");
    fs::create_directories(config.out_dir);
    config.plan.samples = 256;
    config.plan.replicates = 4;
    config.backend = backend.get();
    config.backend_label = backend->name();
    ASSERT_TRUE(ms::sweep::run_sweep(spec, config).assembled);
    auto sweep = read_columns(fs::path(config.out_dir) / "sweep.csv");

    // The same points as eval queries.
    const ms::sweep::PointGrid grid(spec, ms::Form::height_correlated, ms::AoWeighting::uniform);
    std::ofstream q(path("q.csv"));
    q << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n";
    for (std::uint64_t i = 0; i < grid.size(); ++i) {
        const ms::Query x = ms::sweep::to_query(grid.at(i));
        for (double v : {x.visibility, x.alpha_x, x.alpha_y, x.wi.x, x.wi.y, x.wi.z, x.wo.x, x.wo.y})
            q << ms::format_number(v) << ",";
        q << ms::format_number(x.wo.z) << "\n";
    }
    q.close();
    std::string compare;
    for (const auto& a : kAnalytic) compare += " --compare " + a;
    compare += " --compare " + lut.string();
    const auto r = run_compare_cli("eval --method sampled --in " + path("q.csv") + " --out " + path("r.csv") +
                       " --backend oracle --samples 256 --ao-weighting uniform" + compare);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    auto eval = read_columns(path("r.csv"));
    ASSERT_EQ(eval["term"].size(), grid.size());
    std::vector<std::string> names = kAnalytic;
    names.push_back("lut");
    for (const auto& n : names) {
        ASSERT_EQ(eval[n].size(), grid.size()) << n;
        ASSERT_EQ(sweep[n].size(), grid.size()) << n;
        for (std::size_t i = 0; i < grid.size(); ++i) {
            // The directions go through text and normalisation: NdotL and NdotV may differ by an ulp.
            EXPECT_NEAR(std::stod(eval[n][i]), std::stod(sweep[n][i]), 1e-9) << n << " point " << i;
            const double e = std::stod(eval[n][i]) - std::stod(eval["term"][i]);
            EXPECT_DOUBLE_EQ(std::stod(eval[n + "_error"][i]), e) << n << " point " << i;
        }
    }
    // The LUT is not constant and the analytic terms differ from each other on these points.
    EXPECT_NE(eval["lut"].front(), eval["lut"].back());
    EXPECT_NE(eval["naughty-dog"], eval["pz-analytic"]);
    // Summary on stderr, one line per comparator.
    EXPECT_NE(r.output.find("activision-adjusted - term: max |error|"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("N.L-weighted RMS"), std::string::npos) << r.output;
}

TEST_F(EvalCompareTest, NamedLutAndSidecarProvenance) {
    const fs::path lut = write_lut(dir_, "my-bake.exr");
    const auto in = path("q.csv");
    std::ofstream(in) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n"
                         "0.5,0.16,0.16,0.9797959,0,0.2,0.6,0,0.8\n0.3,0.2,0.5,0,0.6,0.8,0,0,2\n";
    const auto r = run_compare_cli("eval --method sampled -q --in " + in + " --out " + path("r.csv") + " --backend oracle --samples 256 --compare " +
                       lut.string() + " --compare mine=" + lut.string() + " --compare naughty-dog");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output.find("max |error|"), std::string::npos) << "-q prints no summary";
    std::ifstream csv(path("r.csv"));
    std::string header;
    std::getline(csv, header);
    EXPECT_EQ(header, "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,term,std_error,my-bake,my-bake_error,"
                      "mine,mine_error,naughty-dog,naughty-dog_error");
    auto cols = read_columns(path("r.csv"));
    EXPECT_EQ(cols["my-bake"], cols["mine"]);
    // The second query's wo = (0, 0, 2) is normalised: NdotL = 1; roughness = (0.2 * 0.5)^(1/4).
    const ms::LutLookup lookup = ms::LutLookup::open(lut.string());
    EXPECT_NEAR(std::stod(cols["mine"][1]), lookup(0.3, 1.0, 0.8, std::pow(0.1, 0.25)), 1e-12);
    EXPECT_NEAR(std::stod(cols["naughty-dog"][1]), 1.0 + 2 * 0.09 - 1, 1e-12);

    std::ifstream js(path("r.csv.json"));
    const auto meta = nlohmann::json::parse(js);
    ASSERT_TRUE(meta.contains("comparators")) << meta.dump();
    const auto& c = meta["comparators"];
    ASSERT_EQ(c.size(), 3u);
    EXPECT_EQ(c[0]["name"], "my-bake");
    EXPECT_EQ(c[0]["file"], lut.string());
    EXPECT_EQ(c[0]["version"], "lut-version-7");
    EXPECT_EQ(c[0]["command_line"], "microshadow bake --test");
    EXPECT_EQ(c[1]["name"], "mine");
    EXPECT_EQ(c[2]["kind"], "analytic");
    EXPECT_EQ(c[2]["term"], "naughty-dog");
    EXPECT_TRUE(c[2].contains("n_dot_l_weighted_rms_error"));
}

TEST_F(EvalCompareTest, BadComparatorsAreRefusedBeforeAnyWork) {
    const fs::path lut = write_lut(dir_, "lut.exr");
    const auto in = path("q.csv");
    std::ofstream(in) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0.5,0.16,0.16,0,0,1,0,0,1\n";
    std::ofstream(path("garbage.exr")) << "not an exr";
    const std::string out = path("r.csv");
    auto refused = [&](const std::string& compare, const std::string& message) {
        const auto r = run_compare_cli("eval --method sampled --in " + in + " --out " + out + " --backend oracle --samples 256 " + compare);
        EXPECT_EQ(r.exit_code, 2) << compare << "\n" << r.output;
        EXPECT_NE(r.output.find(message), std::string::npos) << compare << "\n" << r.output;
        EXPECT_FALSE(fs::exists(out)) << compare;
        EXPECT_FALSE(fs::exists(out + ".json")) << compare;
        for (const auto& e : fs::directory_iterator(dir_))
            EXPECT_TRUE(e.path().extension() == ".csv" || e.path().extension() == ".exr") << e.path();
    };
    refused("--compare naughty-dgo", "did you mean naughty-dog?");
    refused("--compare nonsense", "valid: reference-step, naughty-dog, naughty-dog-ao-fresnel, activision, "
                                  "activision-adjusted, pz-analytic");
    refused("--compare " + path("missing.exr"), "missing.exr");
    refused("--compare " + path("garbage.exr"), "garbage.exr");
    refused("--compare naughty-dog --compare naughty-dog", "duplicate column name 'naughty-dog'");
    refused("--compare " + lut.string() + " --compare " + lut.string(), "duplicate column name 'lut'");
    refused("--compare term=" + lut.string(), "duplicate column name 'term'");
    refused("--compare activision --compare activision_error=" + lut.string(), "duplicate column name 'activision_error'");

    // Activision's roughness needs alpha_x alpha_y < 2: such a query is refused before the term is computed.
    std::ofstream(in) << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0.5,0.16,0.16,0,0,1,0,0,1\n"
                         "0.5,1.5,1.5,0,0,1,0,0,1\n";
    refused("--compare activision-adjusted", "query 2: --compare activision-adjusted");
    const auto ok = run_compare_cli("eval --method sampled -q --in " + in + " --out " + out + " --backend oracle --samples 256 --compare activision");
    EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

}  // namespace

namespace {

// The relative azimuth every azimuth-keeping representation reads: the angle between the tangent-plane
// projections of wi and wo, folded to [0, pi], independent of the frame's rotation about the normal and
// of the directions' lengths.
TEST(ComparatorInputs, RelativeAzimuthIsTheAngleBetweenTheProjections) {
    const double pi = 3.14159265358979323846;
    for (double phi_i : {0.0, 0.7, 2.5, -1.9}) {
        for (double dphi : {0.0, 0.3, pi / 2, 2.0, pi, 4.0}) {
            ms::Query q;
            q.visibility = 0.8;
            q.alpha_x = q.alpha_y = 0.25;
            q.wi = {0.6 * std::cos(phi_i), 0.6 * std::sin(phi_i), 0.8};
            // wo scaled by 3: comparators see normalised directions.
            q.wo = {3 * 0.28 * std::cos(phi_i + dphi), 3 * 0.28 * std::sin(phi_i + dphi), 3 * 0.96};
            const auto in = ms::approx::inputs_of(q, ms::AoWeighting::cosine);
            const double expected = std::fabs(std::remainder(dphi, 2 * pi));
            EXPECT_NEAR(in.relative_azimuth, expected, 1e-12) << "phi_i " << phi_i << " dphi " << dphi;
            EXPECT_NEAR(in.n_dot_l, 0.96, 1e-12);
        }
    }
    ms::Query normal_view;  // wi along the normal: no azimuth to speak of
    normal_view.wi = {0, 0, 1};
    normal_view.wo = {0.6, 0, 0.8};
    EXPECT_EQ(ms::approx::inputs_of(normal_view, ms::AoWeighting::cosine).relative_azimuth, 0.0);
}

}  // namespace
