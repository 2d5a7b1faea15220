// The jobs behind `ibl dfg | prefilter | irradiance` and `bake` called directly, as a library would:
// each run reports its progress to the caller, a cancel callback stops it with ms::Cancelled and
// nothing written (an output folder it made is gone again, the cancel flag is lowered), and the same
// run then completes and writes its files. Also the batched-integrand base a new per-target integral
// derives from.
#include <gtest/gtest.h>

#include <filesystem>

#include "cli_runner.hpp"
#include "core/cancel.hpp"
#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/sphere.hpp"
#include "jobs/bake_run.hpp"
#include "jobs/ibl_run.hpp"
#include "lut/exr_lut.hpp"
#include "schedule/batched_integrand.hpp"
#include "schedule/scheduler.hpp"

namespace {

using namespace ms;

class IblJobRun : public ms::testing::ScratchDirTest {
protected:
    IblJobRun() : ScratchDirTest("ibl_job_run") {}
    // A 4:3 cross of n^2 faces: a sky gradient, brighter upwards.
    std::string write_sky(std::uint32_t n) {
        env::Cubemap c(n);
        for (int face = 0; face < 6; ++face)
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x) {
                    const env::Dir d = env::cube_direction(face, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                    c.texel(face, x, y)[0] = float(1 + d.y), c.texel(face, x, y)[1] = 1, c.texel(face, x, y)[2] = 0.5f;
                }
        env::write_exr(path("sky.exr"), env::cross_image(c), {{"note", "test"}});
        return path("sky.exr");
    }
};

// Progress seen by a caller: the last report, and how many came.
struct Seen {
    std::uint64_t reports = 0, done = 0, total = 0;
    JobCallbacks callbacks(bool cancel) {
        JobCallbacks cb;
        cb.progress = [this](std::uint64_t d, std::uint64_t t) { ++reports, done = d, total = t; };
        if (cancel) cb.cancel = [] { return true; };
        return cb;
    }
};

TEST_F(IblJobRun, IrradianceReportsProgressAndACancelStopsItWritingNothing) {
    IrradianceJobSpec spec;
    spec.environment.image = write_sky(8);
    spec.out = path("out/irradiance");  // two folders to make, both removed again on a cancel
    spec.map.face_size = 4;
    spec.map.source_size = 8;
    spec.map.backend.kind = schedule::Backend::Kind::oracle;
    spec.map.backend.threads = 2;
    Seen cancelled;
    EXPECT_THROW(run_irradiance_job(spec, cancelled.callbacks(true)), Cancelled);
    EXPECT_GE(cancelled.reports, 1u);
    EXPECT_FALSE(std::filesystem::exists(path("out"))) << "a cancelled run leaves no folder it made";
    EXPECT_FALSE(cancel_requested().load()) << "the run lowers the flag it raised";

    Seen seen;
    spec.verify = 3;
    const IrradianceJobResult r = run_irradiance_job(spec, seen.callbacks(false));
    EXPECT_GT(seen.total, 0u);
    EXPECT_EQ(seen.done, seen.total);
    ASSERT_TRUE(r.verification);
    EXPECT_EQ(r.verification->failed, 0u);
    EXPECT_EQ(r.result.map.size, 4u);
    for (const char* f : {"irradiance.exr", "irradiance.json", "irradiance_preview.png"})
        EXPECT_TRUE(std::filesystem::exists(path(std::string("out/irradiance/") + f))) << f;
    EXPECT_NE(irradiance_job_summary(spec, r).find("ibl irradiance: 4^2 faces from 8^2"), std::string::npos) << irradiance_job_summary(spec, r);
}

TEST_F(IblJobRun, PrefilterReportsProgressAndACancelStopsItWritingNothing) {
    PrefilterJobSpec spec;
    spec.environment.image = write_sky(8);
    spec.out = path("pf");
    spec.prefilter.levels = 2;
    spec.prefilter.tolerance = 0;
    spec.prefilter.plan.samples = 64;
    spec.prefilter.backend.threads = 2;
    spec.irradiance_size = 4;
    Seen cancelled;
    EXPECT_THROW(run_prefilter_job(spec, cancelled.callbacks(true)), Cancelled);
    EXPECT_FALSE(std::filesystem::exists(path("pf")));
    EXPECT_FALSE(cancel_requested().load());

    Seen seen;
    const PrefilterJobResult r = run_prefilter_job(spec, seen.callbacks(false));
    EXPECT_GT(seen.total, 0u);
    EXPECT_EQ(seen.done, seen.total);
    EXPECT_EQ(r.result.mips.size(), 2u);
    EXPECT_EQ(r.source_size, 8u);
    for (const char* f : {"specular.ktx2", "specular_preview.png", "irradiance.ktx2", "irradiance_preview.png", "sh.json", "ibl.json"})
        EXPECT_TRUE(std::filesystem::exists(path(std::string("pf/") + f))) << f;
    EXPECT_NE(prefilter_job_summary(spec, r).find("ibl prefilter: 2 mips from 8^2 faces"), std::string::npos);
}

TEST_F(IblJobRun, DfgReportsProgressAndACancelStopsItWritingNothing) {
    DfgJobSpec spec;
    spec.bake.method = DfgMethod::exact;
    spec.bake.n_dot_v.count = spec.bake.roughness.count = 4;
    spec.bake.backend.threads = 2;
    spec.out = path("dfg.exr");
    spec.preview = path("dfg.png");
    Seen cancelled;
    EXPECT_THROW(run_dfg_job(spec, cancelled.callbacks(true)), Cancelled);
    EXPECT_FALSE(std::filesystem::exists(path("dfg.exr")));
    EXPECT_FALSE(std::filesystem::exists(path("dfg.png")));
    EXPECT_FALSE(cancel_requested().load());

    Seen seen;
    const DfgJobResult r = run_dfg_job(spec, seen.callbacks(false));
    EXPECT_EQ(seen.done, seen.total);
    EXPECT_EQ(r.bake.width, 4u);
    EXPECT_TRUE(std::filesystem::exists(path("dfg.exr")));
    EXPECT_TRUE(std::filesystem::exists(path("dfg.png")));
    EXPECT_NE(dfg_job_summary(spec, r).find("ibl dfg: 4 x 4 (NdotV x roughness), exact"), std::string::npos) << dfg_job_summary(spec, r);
}

TEST_F(IblJobRun, BakeJobReportsProgressAndACancelStopsItWritingNothing) {
    BakeJobSpec spec;
    spec.bake = default_bake_spec(LutLayout::custom, 4);
    spec.bake.roughness = {0.5};
    spec.bake.backend.kind = schedule::Backend::Kind::oracle;
    spec.bake.backend.threads = 2;
    spec.bake.samples = 256;
    spec.out = path("lut.exr");
    std::uint64_t writes = 0;
    const auto write = [&](const LutFile& lut) {
        ++writes;
        write_lut(spec.out, lut.axes, lut.channels, lut.data, lut.metadata, false);
    };
    BakeJobCallbacks cancel;
    cancel.cancel = [] { return true; };
    EXPECT_THROW(run_bake_job(spec, write, cancel), Cancelled);
    EXPECT_EQ(writes, 0u);
    EXPECT_FALSE(cancel_requested().load());

    BakeJobCallbacks callbacks;
    std::uint64_t done = 0, total = 0;
    callbacks.progress = [&](std::uint64_t d, std::uint64_t t) { done = d, total = t; };
    const BakeJobResult r = run_bake_job(spec, write, callbacks);
    EXPECT_TRUE(r.written);
    EXPECT_EQ(writes, 1u);
    EXPECT_GT(total, 0u);
    EXPECT_EQ(done, total);
    EXPECT_TRUE(std::filesystem::exists(spec.out));
    EXPECT_NE(bake_job_summary(spec, r).find("bake: 4 x 4 x 4 x 1"), std::string::npos) << bake_job_summary(spec, r);
}

// A per-target integral on the batched base: its oracle alone (x -> x^2, two slots a target), no device.
class SquaresIntegrand final : public schedule::BatchedIntegrand<double, double> {
public:
    SquaresIntegrand(std::vector<double> xs, std::size_t per_item) : BatchedIntegrand(std::move(xs), per_item, 2) {}
    std::string name() const override { return "squares"; }

private:
    std::unique_ptr<DeviceRoutine> make_device_routine(ocl::Device&) override { throw std::logic_error("no kernel"); }
    void oracle(const double& x, double* slots) override { slots[0] = x * x, slots[1] = -x; }
};

TEST(BatchedIntegrand, BatchesCoverEveryTargetOnceAndAnItemsBytesRestoreItsSlots) {
    std::vector<double> xs;
    for (int i = 0; i < 10; ++i) xs.push_back(i + 0.5);
    SquaresIntegrand a(xs, 4);
    EXPECT_EQ(a.work_items(), 3u);  // 4 + 4 + 2
    schedule::Scheduler scheduler(schedule::Backend::oracle(2));
    scheduler.run(a);
    for (std::size_t i = 0; i < xs.size(); ++i) {
        EXPECT_EQ(a.slots()[2 * i], xs[i] * xs[i]) << i;
        EXPECT_EQ(a.slots()[2 * i + 1], -xs[i]) << i;
    }
    // The last, short item's bytes hold its two targets' slots and nothing more.
    EXPECT_EQ(a.save_item(2).size(), 2 * 2 * sizeof(double));
    SquaresIntegrand b(xs, 4);
    for (std::uint64_t id = 0; id < a.work_items(); ++id) b.load_item(id, a.save_item(id));
    EXPECT_EQ(b.slots(), a.slots());
    EXPECT_THROW(b.load_item(0, "short"), std::runtime_error);
}

}  // namespace
