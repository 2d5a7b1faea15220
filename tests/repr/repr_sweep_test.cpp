// Representation files as sweep comparators. A spec names a representation file as it
// names a LUT ([[comparators.lut]]); its column must equal what `microshadow eval --method sampled --compare` computes at
// the same points (eval reads the relative azimuth from the query's directions, the sweep from
// delta_phi: they agree to rounding, 1e-9 is far above it and far below any lookup's slope times a
// wrong azimuth), the summary reports it, and resume refuses a re-baked (changed) representation file.
// The representations are built from a synthetic bake (smooth values, no sampling): the test is of the
// wiring, not of the term, so the sweep's term comes from the oracle at few samples.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cli_runner.hpp"
#include "jobs/compare.hpp"
#include "jobs/eval.hpp"
#include "jobs/sweep/points.hpp"
#include "jobs/sweep/runner.hpp"
#include "jobs/sweep/spec.hpp"
#include "repr/representation.hpp"

namespace {

namespace repr = ms::repr;
namespace fs = std::filesystem;

// Smooth in every index and in the azimuth node k, in [0.1, 0.9]; `shift` makes a different file.
repr::AzimuthBake synthetic_bake(double shift) {
    repr::AzimuthBake b;
    b.grid.visibility = 4, b.grid.n_dot_l = 4, b.grid.n_dot_v = 3;
    b.grid.roughness = {0.3, 0.8};
    b.azimuth_nodes = 7;
    b.value.resize(std::size_t(2) * 7 * 3 * 4 * 4);
    for (std::uint32_t r = 0; r < 2; ++r)
        for (std::uint32_t k = 0; k < 7; ++k)
            for (std::uint32_t ivv = 0; ivv < 3; ++ivv)
                for (std::uint32_t il = 0; il < 4; ++il)
                    for (std::uint32_t iv = 0; iv < 4; ++iv)
                        b.value[b.index(r, k, iv, il, ivv)] =
                            float(0.1 + shift + 0.05 * iv + 0.04 * il + 0.03 * ivv + 0.2 * std::cos(0.5 * k) * (0.5 + 0.1 * iv) + 0.05 * r);
    b.std_error.assign(b.value.size(), 0.0f);
    b.metadata = {{"synthetic", true}};
    return b;
}

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) f.push_back(cell);
    return f;
}

std::vector<std::map<std::string, std::string>> read_csv(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    const auto header = split(line);
    std::vector<std::map<std::string, std::string>> rows;
    while (std::getline(in, line)) {
        const auto f = split(line);
        std::map<std::string, std::string> row;
        for (std::size_t i = 0; i < header.size() && i < f.size(); ++i) row[header[i]] = f[i];
        rows.push_back(row);
    }
    return rows;
}

class ReprSweepTest : public ms::testing::ScratchDirTest {
protected:
    ReprSweepTest() : ScratchDirTest("repr_sweep") {}
};

TEST_F(ReprSweepTest, RepresentationColumnsEqualEvalCompareAndResumeRefusesAChangedFile) {
    repr::build_representation("azimuth-harmonics", synthetic_bake(0))->write(path("harm.exr"), true);
    repr::build_representation("azimuth-axis", synthetic_bake(0))->write(path("axis.exr"), false);
    // Points inside and on the edges of the grid: NdotL = 1 and NdotV = 1 (no azimuth), the zero
    // region (v = 0.3, NdotL <= 0.4), two phi_i (the relative azimuth is what counts), delta_phi past 180.
    const std::string toml =
        "[sweep]\nchunk_size = 50\n[parameters]\nvisibility = [0.3, 0.62, 0.97]\n"
        "n_dot_l = [0.2, 0.55, 1.0]\nn_dot_v = [0.35, 0.8, 1.0]\nroughness = [0.3, 0.47, 0.8]\nphi_i = [0, 33]\n"
        "delta_phi = [0, 41, 90, 152, 180, 250]\n"
        "[comparators]\nanalytic = [\"pz-analytic\"]\n"
        "[[comparators.lut]]\nname = \"harm\"\nfile = \"harm.exr\"\n"
        "[[comparators.lut]]\nname = \"axis\"\nfile = \"axis.exr\"\n";
    std::ofstream(path("spec.toml")) << toml;
    const ms::sweep::Spec spec = ms::sweep::parse_spec_file(path("spec.toml"));
    auto backend = ms::make_oracle_backend(1);
    ms::sweep::RunConfig config;
    config.out_dir = path("out");
    config.plan.samples = 64;
    config.plan.replicates = 2;
    config.backend = backend.get();
    const auto result = ms::sweep::run_sweep(spec, config);
    ASSERT_TRUE(result.assembled);

    // The same points as eval queries (full-precision directions from the sweep's own geometry).
    const ms::sweep::PointGrid grid(spec, ms::Form::height_correlated, ms::AoWeighting::cosine);
    {
        std::ofstream q(path("q.csv"));
        q << "visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n";
        q.precision(17);
        for (std::uint64_t i = 0; i < grid.size(); ++i) {
            const ms::Query x = ms::sweep::to_query(grid.at(i));
            q << x.visibility << "," << x.alpha_x << "," << x.alpha_y << "," << x.wi.x << "," << x.wi.y << "," << x.wi.z << ","
              << x.wo.x << "," << x.wo.y << "," << x.wo.z << "\n";
        }
    }
    const auto r = ms::testing::run_shell(std::string(MICROSHADOW_CLI) + " eval --method sampled -q --backend oracle --samples 64 --replicates 2 --in " +
                                          path("q.csv") + " --out " + path("r.csv") + " --compare harm=" + path("harm.exr") +
                                          " --compare axis=" + path("axis.exr") + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto sweep_rows = read_csv(path("out") + "/sweep.csv");
    const auto eval_rows = read_csv(path("r.csv"));
    ASSERT_EQ(sweep_rows.size(), grid.size());
    ASSERT_EQ(eval_rows.size(), grid.size());
    std::size_t varies = 0;  // points where the azimuth changes the value: the test would miss a dropped azimuth otherwise
    for (std::size_t i = 0; i < grid.size(); ++i)
        for (const char* name : {"harm", "axis"}) {
            const double s = std::stod(sweep_rows[i].at(name)), e = std::stod(eval_rows[i].at(name));
            EXPECT_NEAR(s, e, 1e-9) << name << " at sweep point " << i;
            const auto in0 = [&] {
                auto p = grid.at(i);
                ms::approx::Inputs in{p.visibility, p.n_dot_l, p.n_dot_v, p.roughness, p.weighting};
                return in;
            }();
            const auto c = ms::compare::Comparator::open_file(name, path(std::string(name) + ".exr"));
            varies += std::abs(c(in0) - s) > 1e-3;
        }
    EXPECT_GT(varies, grid.size() / 2);

    // The summary reports the representation columns like any comparator.
    const std::string summary = [&] {
        std::ifstream in(path("out") + "/summary.md");
        std::ostringstream s;
        s << in.rdbuf();
        return s.str();
    }();
    EXPECT_NE(summary.find("| harm | all | " + std::to_string(grid.size()) + " |"), std::string::npos) << summary;
    EXPECT_NE(summary.find("| axis | all | "), std::string::npos) << summary;
    // The sweep's description records each file comparator's provenance, a representation's with its cost.
    std::ifstream manifest_in(path("out") + "/sweep-spec.json");
    const auto manifest = nlohmann::json::parse(manifest_in);
    ASSERT_EQ(manifest.at("comparator_files").size(), 2u);
    EXPECT_EQ(manifest["comparator_files"][0].at("representation"), "azimuth-harmonics");
    EXPECT_GT(manifest["comparator_files"][0].at("cost").at("bytes").get<std::uint64_t>(), 0u);

    // A re-baked representation (other texels, same name) is another sweep: resume refuses it.
    EXPECT_EQ(ms::sweep::run_sweep(spec, config).computed, 0u);
    repr::build_representation("azimuth-harmonics", synthetic_bake(0.01))->write(path("harm.exr"), true);
    try {
        ms::sweep::run_sweep(spec, config);
        ADD_FAILURE() << "resume accepted a changed representation file";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("different sweep"), std::string::npos) << e.what();
    }
    config.restart = true;
    EXPECT_TRUE(ms::sweep::run_sweep(spec, config).assembled);
}

}  // namespace
