// The scheduler contract, in process: the one replicate reduction, the azimuth quadrature of a LUT slice
// on synthetic tallies, the scheduler with toy integrands, the LUT slice integrand on the oracle backend
// against the kernel routine, and the term and bake kernels counting alike on the same points (tiny
// cones included).
//
// Tolerances: statistical comparisons use the two-sided Student-t quantile with replicates - 1 degrees
// of freedom at confidence 1 - 0.001 / comparisons (Bonferroni: a correct estimator fails a test by
// chance with probability <= 0.001); deterministic arithmetic gets a bound derived from the number of
// roundings; kernel-against-kernel counts on identical points may differ only by the samples whose
// decision lies within float rounding of a boundary, which the test counts on the host.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <mutex>
#include <numeric>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/cancel.hpp"
#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "core/seeds.hpp"
#include "device/runtime.hpp"
#include "integrands/lut_slice/azimuth_quadrature.hpp"
#include "integrands/lut_slice/lut_slice_integrand.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"
#include "schedule/integrand.hpp"
#include "schedule/scheduler.hpp"

namespace {

using namespace ms;
using Clock = std::chrono::steady_clock;

using ms::kPi;
constexpr double kFamilyAlpha = 0.001;  // family-wise false-alarm probability of a statistical test

double bonferroni_t(std::size_t comparisons, std::uint32_t replicates) {
    return student_t_quantile(1 - kFamilyAlpha / double(std::max<std::size_t>(1, comparisons)), int(replicates) - 1);
}

// ms::cancel_requested() is process-wide: every test that sets it puts it back.
struct CancelFlagReset {
    CancelFlagReset() { cancel_requested() = false; }
    ~CancelFlagReset() { cancel_requested() = false; }
};

// The default OpenCL device, or nothing (the in-process device tests then skip).
std::vector<ocl::DeviceInfo> default_device() {
    try {
        return ocl::select_devices("default");
    } catch (const std::exception&) {
        return {};
    }
}

// ===================================================================================================
// 5. One replicate reduction (core/estimate.hpp) on synthetic tallies.

TEST(ReplicateReduction, PooledRatioAndStdErrorByHand) {
    // x_r = 1/4, 2/4, 3/6; pooled 6/14; mean x 5/12; sum (x - mean)^2 = 1/24; se = sqrt(1/24 / (3 * 2)) = 1/12.
    const double cone[] = {1, 2, 3}, hemi[] = {4, 4, 6};
    const Estimate e = reduce_replicates(cone, hemi, 3);
    EXPECT_DOUBLE_EQ(e.term, 3.0 / 7.0);
    EXPECT_DOUBLE_EQ(e.std_error, 1.0 / 12.0);
    ReplicateRatioMean m(3);
    m.add(1.0, cone, hemi);
    EXPECT_DOUBLE_EQ(m.value(), 3.0 / 7.0);
    EXPECT_DOUBLE_EQ(m.std_error(), 1.0 / 12.0);
    // The same tallies interleaved with stride 2.
    const double c2[] = {1, -9, 2, -9, 3}, h2[] = {4, -9, 4, -9, 6};
    ReplicateRatioMean strided(3);
    strided.add(1.0, c2, h2, 2);
    EXPECT_EQ(strided.value(), m.value());
    EXPECT_EQ(strided.std_error(), m.std_error());
    // Pooled, not the mean of the ratios (5/12): the two differ here.
    EXPECT_GT(std::abs(e.term - 5.0 / 12.0), 0.01);
}

TEST(ReplicateReduction, ZeroDenominatorReplicatesCountAsZero) {
    // Replicate 0 reaches no hemisphere sample: its ratio is 0, not NaN, and it still counts in the
    // spread. x = 0, 1/2, 1/2: mean 1/3, sum of squares 1/6, se = sqrt(1/6 / 6) = 1/6; pooled 5/10.
    const double cone[] = {0, 2, 3}, hemi[] = {0, 4, 6};
    const Estimate e = reduce_replicates(cone, hemi, 3);
    EXPECT_DOUBLE_EQ(e.term, 0.5);
    EXPECT_DOUBLE_EQ(e.std_error, 1.0 / 6.0);
    // No replicate reaches the hemisphere: exactly 0 +- 0.
    const double zero[] = {0, 0, 0};
    const Estimate z = reduce_replicates(zero, zero, 3);
    EXPECT_EQ(z.term, 0.0);
    EXPECT_EQ(z.std_error, 0.0);
    EXPECT_FALSE(std::isnan(z.term));
}

TEST(ReplicateReduction, NegativeWeightsGiveTheStdErrorOfTheDifference) {
    // Node A: x = 1/4, 1/2, 1/2 (se 1/12); node B: x = 1/2, 1/4, 1/4 (se 1/12). d_r = x_A - x_B =
    // -1/4, 1/4, 1/4: mean 1/12, sum of squares 1/6, se = 1/6; value 3/7 - 3/10 = 9/70. The nodes are
    // anti-correlated, so the difference's se (1/6) exceeds the independent sqrt(2)/12 = 0.118: the
    // spread must be taken of the per-replicate differences.
    const double ca[] = {1, 2, 3}, ha[] = {4, 4, 6};
    const double cb[] = {1, 1, 1}, hb[] = {2, 4, 4};
    EXPECT_DOUBLE_EQ(reduce_replicates(cb, hb, 3).std_error, 1.0 / 12.0);
    ReplicateRatioMean d(3);
    d.add(1.0, ca, ha);
    d.add(-1.0, cb, hb);
    EXPECT_NEAR(d.value(), 9.0 / 70.0, 4 * DBL_EPSILON);
    EXPECT_NEAR(d.std_error(), 1.0 / 6.0, 4 * DBL_EPSILON);
    // A node minus itself: exactly 0 +- 0.
    ReplicateRatioMean self(3);
    self.add(1.0, ca, ha);
    self.add(-1.0, ca, ha);
    EXPECT_EQ(self.value(), 0.0);
    EXPECT_EQ(self.std_error(), 0.0);
}

TEST(ReplicateReduction, WeightsSummingToOneOverIdenticalNodesGiveTheSingleNode) {
    const double cone[] = {17, 30, 22, 25, 19, 28, 21, 26}, hemi[] = {100, 110, 95, 105, 98, 120, 101, 99};
    const Estimate one = reduce_replicates(cone, hemi, 8);
    for (const std::vector<double>& weights : {std::vector<double>{0.5, 0.25, 0.25}, std::vector<double>{0.1, 0.2, 0.3, 0.4},
                                               std::vector<double>{1.0 / 3, 1.0 / 3, 1.0 / 3}}) {
        ReplicateRatioMean m(8);
        for (double w : weights) m.add(w, cone, hemi);
        // Each of the n additions rounds once more: a few ulps of the value per node.
        const double n = double(weights.size());
        EXPECT_NEAR(m.value(), one.term, 4 * n * DBL_EPSILON * one.term) << weights.size() << " nodes";
        EXPECT_NEAR(m.std_error(), one.std_error, 64 * n * DBL_EPSILON * one.term) << weights.size() << " nodes";
    }
}

// ===================================================================================================
// 6. Azimuth quadrature of a LUT slice (integrands/lut_slice/azimuth_quadrature.hpp) without a device.

// A slice plan with exact and sampled texels: visibility endpoints 0, 1/3, 2/3, 1 (v = 0 exact 0,
// v = 1 exact 1, v = 1/3 in the zero region of the NdotL = 0.25 row), NdotL 0.25 and 0.75, adaptive
// azimuth (grid 32, k_start 4), 4 replicates.
LutSliceSpec quadrature_spec() {
    LutSliceSpec s;
    s.visibility = {"visibility", 0, 1, 4, TexelConvention::endpoints};
    s.n_dot_l = {"n_dot_l", 0, 1, 2, TexelConvention::centres};
    s.n_dot_v = {"n_dot_v", 0, 1, 1, TexelConvention::centres};
    s.roughness = {0.5};
    s.azimuth_mean = true;
    s.azimuth_intervals = 0;
    s.azimuth_min_intervals = 4;
    s.azimuth_max_intervals = 32;
    s.replicates = 4;
    s.samples = 4096;
    return s;
}

// Synthetic tallies: at node phi (degrees) of row il, texel iv, replicate r
//     hemisphere h_r = {1000, 3000, 1000, 3000}[r],   cone = (f(il, iv, phi) + e_r g(phi)) h_r,
// with e_r = {3, -1, 3, -1}[r] * s. sum_r e_r h_r = 0, so every node's pooled ratio is f exactly (up to
// rounding); replicate r's own estimate of a weighted node sum S[.] is S[f] + e_r S[g], so the std error
// of S is |S[g]| * se(e), se(e) = sqrt(sum (e_r - mean e)^2 / (R (R - 1))) = sqrt(16 s^2 / 12).
// Exact texels get tallies that would give garbage if they were read.
struct SyntheticSlice {
    double s = 1e-3;                            // perturbation scale
    std::vector<double> a{0.2, 0.5}, b{0.0, 0.0};  // per row: f = a + 0.01 iv + b cos(4 phi) + 0.02 exp(cos phi - 1)
    static double g(double phi_deg) { return 0.3 + std::cos(4 * phi_deg * kPi / 180); }
    double f(std::uint32_t il, std::uint32_t iv, double phi_deg) const {
        const double phi = phi_deg * kPi / 180;
        return a[il] + 0.01 * iv + b[il] * std::cos(4 * phi) + 0.02 * std::exp(std::cos(phi) - 1);
    }
    double se_e() const { return std::sqrt(16 * s * s / 12); }
    static constexpr double h[4] = {1000, 3000, 1000, 3000};
    static constexpr double e[4] = {3, -1, 3, -1};

    lut_slice::SliceTallies fill(const lut_slice::SlicePlan& plan) const {
        lut_slice::SliceTallies acc(plan.tally_size(), 0.0);
        const std::size_t stride = plan.nv + 1;
        for (std::uint32_t il = 0; il < plan.nl; ++il)
            for (std::uint32_t node = 0; node <= plan.grid; ++node) {
                const double phi = plan.node_degrees[node];
                for (std::uint32_t r = 0; r < plan.replicates; ++r) {
                    double* row = &acc[((std::size_t(il) * (plan.grid + 1) + node) * plan.replicates + r) * stride];
                    row[plan.nv] = h[r];
                    for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
                        const bool sampled = plan.texel(il, iv) == lut_slice::sampled;
                        // Exact texels: a wildly varying ratio that would show if it were used.
                        const double ratio = sampled ? f(il, iv, phi) + e[r] * s * g(phi) : 0.37 + 0.3 * std::sin(7.0 * node + r);
                        row[iv] = ratio * h[r];
                    }
                }
            }
        return acc;
    }
};

// The trapezoid rule on [0, 180] with k intervals, written out on its own.
template <class F>
double trapezoid(std::uint32_t k, F f) {
    double sum = 0;
    for (std::uint32_t i = 0; i <= k; ++i) sum += (i == 0 || i == k ? 0.5 : 1.0) * f(180.0 * double(i) / double(k));
    return sum / double(k);
}

TEST(AzimuthQuadrature, PlanOfTheAdaptiveSpec) {
    const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(quadrature_spec());
    EXPECT_EQ(plan.grid, 32u);
    EXPECT_EQ(plan.k_start, 4u);
    ASSERT_EQ(plan.node_degrees.size(), 33u);
    EXPECT_EQ(plan.directions(), 2u * 33u);
    for (std::uint32_t k : {2u, 4u, 8u, 16u, 32u}) {
        double w = 0;
        for (std::uint32_t i = 0; i <= k; ++i) {
            // Node i of k is node i * 32 / k of the grid, at exactly 180 i / k degrees.
            EXPECT_EQ(plan.node_degrees[lut_slice::row_node(plan, k, i)], 180.0 * double(i) / double(k));
            w += lut_slice::row_weight(k, i);
        }
        EXPECT_NEAR(w, 1.0, 4 * DBL_EPSILON * k);
    }
    using lut_slice::exact_one;
    using lut_slice::exact_zero;
    using lut_slice::sampled;
    EXPECT_EQ(plan.texel(0, 0), exact_zero);
    EXPECT_EQ(plan.texel(0, 1), exact_zero);  // 2/3 + 0.25 <= 1
    EXPECT_EQ(plan.texel(0, 2), sampled);
    EXPECT_EQ(plan.texel(0, 3), exact_one);
    EXPECT_EQ(plan.texel(1, 0), exact_zero);
    EXPECT_EQ(plan.texel(1, 1), sampled);
    EXPECT_EQ(plan.texel(1, 2), sampled);
    EXPECT_EQ(plan.texel(1, 3), exact_one);
}

TEST(AzimuthQuadrature, TexelMeanIsTheTrapezoidRuleOfTheNodeRatios) {
    const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(quadrature_spec());
    const SyntheticSlice syn;
    const lut_slice::SliceTallies acc = syn.fill(plan);
    std::size_t checked = 0;
    for (std::uint32_t il = 0; il < plan.nl; ++il)
        for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
            if (plan.texel(il, iv) != lut_slice::sampled) continue;
            for (std::uint32_t k : {2u, 4u, 8u, 16u, 32u}) {
                const Estimate e = lut_slice::texel_mean(plan, acc, il, k, iv);
                const double expected = trapezoid(k, [&](double phi) { return syn.f(il, iv, phi); });
                // Per node: the pooled ratio's R + 2 roundings, the weight's and the sum's (values < 1).
                const double rounding = 16.0 * (k + 1) * DBL_EPSILON;
                EXPECT_NEAR(e.term, expected, rounding) << "row " << il << " texel " << iv << " k " << k;
                const double expected_se = std::abs(trapezoid(k, SyntheticSlice::g)) * syn.se_e();
                EXPECT_NEAR(e.std_error, expected_se, 1e-9 * expected_se + rounding) << "row " << il << " texel " << iv << " k " << k;
                ++checked;
            }
        }
    EXPECT_EQ(checked, 3u * 5u);
}

TEST(AzimuthQuadrature, RowCheckIsTheLargestDifferenceAndFlagsOnlyWhatNoiseCannotExplain) {
    const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(quadrature_spec());
    // Row 1 (texels 1 and 2 sampled): f = a + b cos(4 phi) + ...; at k = 4 the trapezoid rule of cos(4 phi)
    // is 0 and at k = 2 it is 1, so T_4 - T_2 = -b + (the smooth part's difference), and d_r adds
    // e_r (T_4[g] - T_2[g]) = -e_r: se_d = se(e) = 2 s / sqrt(3).
    const double threshold = 1e-3, z = 3;
    SyntheticSlice syn;
    syn.s = 1e-3;
    const double se_d = syn.se_e();
    const std::uint32_t il = 1;
    auto smooth_d = [&](std::uint32_t iv) {
        SyntheticSlice flat = syn;
        flat.b = {0, 0};
        return trapezoid(4, [&](double p) { return flat.f(il, iv, p); }) - trapezoid(2, [&](double p) { return flat.f(il, iv, p); });
    };
    // The largest |d| of the row (texel 2 and 1 share b; their smooth parts are equal, 0.01 iv is constant).
    const double base = smooth_d(2);
    ASSERT_LT(std::abs(base), 1e-4);  // 0.02 * 2 (I_8(1) - I_4(1)) / e = -4.0e-5
    struct Case {
        double b;
        bool significant;
        const char* why;
    };
    const double bound = threshold + z * se_d;  // 4.46e-3
    for (const Case& c : {Case{bound + 1e-3, true, "above threshold + z se"},
                          Case{bound - 1e-3, false, "above the threshold but within z se: noise explains it"},
                          Case{threshold / 2, false, "below the threshold"}}) {
        syn.b = {0.0, c.b};
        const lut_slice::SliceTallies acc = syn.fill(plan);
        bool significant = !c.significant;
        const double worst = lut_slice::row_quadrature(plan, acc, il, 4, threshold, z, &significant);
        const double d = std::abs(base - c.b);
        EXPECT_NEAR(worst, d, 1e-12) << c.why;
        EXPECT_EQ(significant, c.significant) << c.why << ": |d| " << d << ", threshold + z se_d " << bound;
        // The difference's own std error, as the check computes it.
        lut_slice::SliceTallies copy = acc;
        ReplicateRatioMean diff(plan.replicates);
        const std::size_t stride = plan.nv + 1;
        for (std::uint32_t k : {4u, 2u})
            for (std::uint32_t i = 0; i <= k; ++i) {
                const std::size_t item0 = (std::size_t(il) * (plan.grid + 1) + lut_slice::row_node(plan, k, i)) * plan.replicates;
                diff.add((k == 4 ? 1 : -1) * lut_slice::row_weight(k, i), &copy[item0 * stride + 2], &copy[item0 * stride + plan.nv],
                         stride);
            }
        EXPECT_NEAR(diff.std_error(), se_d, 1e-9);
        // Without a threshold and z, any difference is significant; without the out-parameter, no crash.
        lut_slice::row_quadrature(plan, acc, il, 4, 0, 0, &significant);
        EXPECT_TRUE(significant);
        EXPECT_EQ(lut_slice::row_quadrature(plan, acc, il, 4), worst);
    }
    // Row 0 has one sampled texel, which the large perturbations of the exact texels must not affect.
    syn.b = {0.0, 0.0};
    const lut_slice::SliceTallies acc = syn.fill(plan);
    const double d0 = trapezoid(4, [&](double p) { return syn.f(0, 2, p); }) - trapezoid(2, [&](double p) { return syn.f(0, 2, p); });
    EXPECT_NEAR(lut_slice::row_quadrature(plan, acc, 0, 4), std::abs(d0), 1e-12);
    // k odd or < 2: no check, not significant.
    bool significant = true;
    EXPECT_EQ(lut_slice::row_quadrature(plan, acc, 1, 1, 0, 0, &significant), 0.0);
    EXPECT_FALSE(significant);
    significant = true;
    EXPECT_EQ(lut_slice::row_quadrature(plan, acc, 1, 3, 0, 0, &significant), 0.0);
    EXPECT_FALSE(significant);
}

TEST(AzimuthQuadrature, ReduceSliceGivesExactTexelsByRuleAndTheLargestStdError) {
    const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(quadrature_spec());
    const SyntheticSlice syn;
    const lut_slice::SliceTallies acc = syn.fill(plan);
    const std::vector<std::uint32_t> k{8, 16};
    lut_slice::SliceValues out;
    out.value.assign(std::size_t(plan.nl) * plan.nv, -1.0f);
    out.std_error.assign(out.value.size(), -1.0f);
    const double max_se = lut_slice::reduce_slice(plan, acc, k, out);
    double expected_max = 0;
    for (std::uint32_t il = 0; il < plan.nl; ++il)
        for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
            const std::size_t at = std::size_t(il) * plan.nv + iv;
            switch (plan.texel(il, iv)) {
                case lut_slice::exact_zero:
                    EXPECT_EQ(out.value[at], 0.0f) << il << " " << iv;
                    EXPECT_EQ(out.std_error[at], 0.0f);
                    break;
                case lut_slice::exact_one:
                    EXPECT_EQ(out.value[at], 1.0f) << il << " " << iv;
                    EXPECT_EQ(out.std_error[at], 0.0f);
                    break;
                default: {
                    const Estimate e = lut_slice::texel_mean(plan, acc, il, k[il], iv);
                    EXPECT_EQ(out.value[at], float(e.term));
                    EXPECT_EQ(out.std_error[at], float(e.std_error));
                    expected_max = std::max(expected_max, e.std_error);
                }
            }
        }
    EXPECT_EQ(max_se, expected_max);
    EXPECT_GT(max_se, 0.0);
}

// ===================================================================================================
// 7. The scheduler (schedule/scheduler.hpp) with toy integrands.

// A toy integrand: item id "computes" by recording its id. Hooks decide per attempt whether to sleep
// or throw. Counts are per id: attempts (worker->run called) and completions (run returned).
class Toy final : public schedule::Integrand {
public:
    explicit Toy(std::uint64_t items) : items_(items), attempts_(items), completions_(items) {}
    std::string name() const override { return "toy"; }
    std::uint64_t work_items() const override { return items_; }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device&) override { return std::make_unique<W>(*this); }
    std::unique_ptr<schedule::Worker> oracle_worker() override { return std::make_unique<W>(*this); }

    // (id, attempt number from 0) -> what to do; run on the worker's thread.
    std::function<void(std::uint64_t, int)> hook;
    std::chrono::microseconds work{0};

    int attempts(std::uint64_t id) const { return attempts_[id].load(); }
    int completions(std::uint64_t id) const { return completions_[id].load(); }
    int total_attempts() const {
        int n = 0;
        for (const auto& a : attempts_) n += a.load();
        return n;
    }

private:
    struct W final : schedule::Worker {
        Toy& toy;
        explicit W(Toy& t) : toy(t) {}
        void run(std::uint64_t id) override {
            const int attempt = toy.attempts_[id]++;
            if (toy.work.count()) std::this_thread::sleep_for(toy.work);
            if (toy.hook) toy.hook(id, attempt);
            ++toy.completions_[id];
        }
    };
    std::uint64_t items_;
    std::vector<std::atomic<int>> attempts_, completions_;
};

TEST(SchedulerTest, EveryItemRunsExactlyOnceAndProgressEndsAtTheTotal) {
    Toy toy(200);
    toy.work = std::chrono::microseconds(200);
    schedule::Scheduler s(schedule::Backend::oracle(3));
    EXPECT_EQ(s.places(), 3u);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> progress;
    schedule::RunCallbacks cb;
    cb.progress = [&](std::uint64_t done, std::uint64_t total) { progress.emplace_back(done, total); };
    const schedule::RunReport r = s.run(toy, {}, cb);
    EXPECT_EQ(r.selected, 200u);
    EXPECT_EQ(r.done, 200u);
    EXPECT_EQ(r.rerun, 0u);
    EXPECT_TRUE(r.failed_places.empty());
    for (std::uint64_t id = 0; id < 200; ++id) {
        EXPECT_EQ(toy.attempts(id), 1) << id;
        EXPECT_EQ(toy.completions(id), 1) << id;
    }
    ASSERT_FALSE(progress.empty());
    EXPECT_EQ(progress.back(), std::make_pair(std::uint64_t(200), std::uint64_t(200)));
    for (std::size_t i = 1; i < progress.size(); ++i) EXPECT_LE(progress[i - 1].first, progress[i].first);
}

TEST(SchedulerTest, ShardsPartitionTheIds) {
    const std::uint64_t n = 101;
    for (std::uint64_t count : {1u, 3u, 7u}) {
        std::vector<int> runs(n, 0);
        for (std::uint64_t index = 0; index < count; ++index) {
            Toy toy(n);
            schedule::Scheduler s(schedule::Backend::oracle(3));
            schedule::WorkSelection sel;
            sel.shard_index = index;
            sel.shard_count = count;
            const schedule::RunReport r = s.run(toy, sel);
            std::uint64_t mine = 0;
            for (std::uint64_t id = 0; id < n; ++id) {
                runs[id] += toy.attempts(id);
                if (toy.attempts(id)) {
                    EXPECT_EQ(id % count, index) << "shard " << index << "/" << count << " ran " << id;
                }
                mine += id % count == index;
            }
            EXPECT_EQ(r.selected, mine);
            EXPECT_EQ(r.done, mine);
        }
        for (std::uint64_t id = 0; id < n; ++id) EXPECT_EQ(runs[id], 1) << "id " << id << " with " << count << " shards";
    }
    Toy toy(4);
    schedule::Scheduler s(schedule::Backend::oracle(2));
    schedule::WorkSelection bad;
    bad.shard_index = 3;
    bad.shard_count = 3;
    EXPECT_THROW(s.run(toy, bad), std::invalid_argument);
    bad.shard_index = 0;
    bad.shard_count = 0;
    EXPECT_THROW(s.run(toy, bad), std::invalid_argument);
    EXPECT_EQ(toy.total_attempts(), 0);
}

TEST(SchedulerTest, AlreadyDoneIsSkippedAndMaxItemsStopsEarlyInIdOrder) {
    const std::uint64_t n = 50;
    {
        Toy toy(n);
        schedule::Scheduler s(schedule::Backend::oracle(3));
        schedule::WorkSelection sel;
        sel.already_done = [](std::uint64_t id) { return id % 2 == 0 || id == 7; };
        const schedule::RunReport r = s.run(toy, sel);
        EXPECT_EQ(r.selected, 24u);
        EXPECT_EQ(r.done, 24u);
        for (std::uint64_t id = 0; id < n; ++id) EXPECT_EQ(toy.attempts(id), (id % 2 == 0 || id == 7) ? 0 : 1) << id;
    }
    {
        // max_items with skipping and sharding: the first 5 selected ids (odd ids of shard 1/2 except 7).
        Toy toy(n);
        schedule::Scheduler s(schedule::Backend::oracle(3));
        schedule::WorkSelection sel;
        sel.shard_index = 1;
        sel.shard_count = 2;
        sel.already_done = [](std::uint64_t id) { return id == 7; };
        sel.max_items = 5;
        const schedule::RunReport r = s.run(toy, sel);
        EXPECT_EQ(r.selected, 5u);
        EXPECT_EQ(r.done, 5u);
        const std::set<std::uint64_t> expected{1, 3, 5, 9, 11};
        for (std::uint64_t id = 0; id < n; ++id) EXPECT_EQ(toy.attempts(id), expected.count(id) ? 1 : 0) << id;
    }
}

TEST(SchedulerTest, OnDoneIsCalledOncePerItemAndNeverConcurrently) {
    Toy toy(300);
    toy.work = std::chrono::microseconds(100);
    schedule::Scheduler s(schedule::Backend::oracle(3));
    std::atomic<int> inside{0}, overlaps{0};
    std::vector<int> calls(300, 0);  // written only inside on_done: the call serialisation protects it
    schedule::RunCallbacks cb;
    cb.on_done = [&](std::uint64_t id) {
        if (inside.fetch_add(1) != 0) ++overlaps;
        ++calls.at(id);
        EXPECT_EQ(toy.completions(id), 1) << "on_done(" << id << ") before the item completed";
        std::this_thread::sleep_for(std::chrono::microseconds(200));  // widens any overlap window
        --inside;
    };
    const schedule::RunReport r = s.run(toy, {}, cb);
    EXPECT_EQ(r.done, 300u);
    EXPECT_EQ(overlaps.load(), 0);
    for (std::uint64_t id = 0; id < 300; ++id) EXPECT_EQ(calls[id], 1) << id;
}

TEST(SchedulerTest, AnExceptionInOneItemStopsTheRunAndIsRethrown) {
    Toy toy(2000);
    toy.work = std::chrono::microseconds(500);
    toy.hook = [](std::uint64_t id, int) {
        if (id == 10) throw std::runtime_error("toy item 10 broke");
    };
    schedule::Scheduler s(schedule::Backend::oracle(3));
    const auto t0 = Clock::now();
    try {
        s.run(toy);
        ADD_FAILURE() << "run() returned";
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "toy item 10 broke");
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    // Stopped: items in flight finish, nothing new starts (all 2000 would take ~0.33 s on 3 places).
    EXPECT_LT(toy.total_attempts(), 40) << seconds << " s";
    // On the oracle an ocl::Error is an ordinary error (no device to blame, no rerun).
    Toy cl_toy(50);
    cl_toy.hook = [](std::uint64_t id, int) {
        if (id == 3) throw ocl::Error("toy", -1, "not a device");
    };
    EXPECT_THROW(s.run(cl_toy), ocl::Error);
    EXPECT_EQ(cl_toy.attempts(3), 1);
}

TEST(SchedulerTest, CancellationFromOnDoneOrProgressStopsPromptly) {
    for (const bool from_progress : {false, true}) {
        CancelFlagReset reset;
        Toy toy(3000);
        toy.work = std::chrono::microseconds(1000);  // all items: ~1 s on 3 places
        schedule::Scheduler s(schedule::Backend::oracle(3));
        std::atomic<int> done{0};
        schedule::RunCallbacks cb;
        if (from_progress)
            cb.progress = [&](std::uint64_t d, std::uint64_t) {
                if (d >= 30) cancel_requested() = true;
            };
        else
            cb.on_done = [&](std::uint64_t) {
                if (++done == 30) cancel_requested() = true;
            };
        const auto t0 = Clock::now();
        EXPECT_THROW(s.run(toy, {}, cb), Cancelled) << (from_progress ? "progress" : "on_done");
        const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        // Progress is reported every 100 ms or on a completion: the flag is seen within ~one report.
        EXPECT_LT(seconds, 0.3) << (from_progress ? "progress" : "on_done");
        EXPECT_LT(toy.total_attempts(), 300) << (from_progress ? "progress" : "on_done");
        EXPECT_GE(toy.total_attempts(), 30);
    }
    // Requested before the run: the run stops at once instead of working through the queue (100 items
    // of 5 ms are 250 ms on 2 places). The places do not read the flag themselves; the calling thread
    // does and stops them, so items in flight may still finish (with items of no work at all, every one
    // of 100 ran before the calling thread looked: "at once" is as fast as that thread wakes).
    CancelFlagReset reset;
    cancel_requested() = true;
    Toy toy(100);
    toy.work = std::chrono::milliseconds(5);
    schedule::Scheduler s(schedule::Backend::oracle(2));
    EXPECT_THROW(s.run(toy), Cancelled);
    EXPECT_LT(toy.total_attempts(), 50);
}

// Device failover in process: two places on the one default device (each place has its own context and
// queue; the toy never touches them), failures injected by the scheduler or thrown by the toy.
class SchedulerFailover : public ::testing::Test {
protected:
    void SetUp() override {
        devices_ = default_device();
        if (devices_.empty()) GTEST_SKIP() << "no OpenCL device";
        devices_.push_back(devices_.front());
    }
    // Runs with a watchdog: a run still going after `limit` is cancelled (the scheduler honours the flag
    // even when it waits for places that are gone) and reported as a hang.
    schedule::RunReport run_guarded(schedule::Scheduler& s, Toy& toy, double limit, bool* hung) {
        CancelFlagReset reset;
        auto f = std::async(std::launch::async, [&] { return s.run(toy); });
        *hung = f.wait_for(std::chrono::duration<double>(limit)) != std::future_status::ready;
        if (*hung) cancel_requested() = true;
        return f.get();
    }
    std::vector<ocl::DeviceInfo> devices_;
};

TEST_F(SchedulerFailover, InjectedFailureRerunsTheItemElsewhereOnce) {
    Toy toy(40);
    toy.work = std::chrono::milliseconds(2);
    schedule::Scheduler s(schedule::Backend::opencl(devices_));
    ASSERT_EQ(s.places(), 2u);
    s.set_fault_injection({0, 3});  // place 0 fails when it starts its fourth item
    bool hung = false;
    const schedule::RunReport r = run_guarded(s, toy, 10, &hung);
    ASSERT_FALSE(hung);
    EXPECT_EQ(r.done, 40u);
    EXPECT_EQ(r.rerun, 1u);
    ASSERT_EQ(r.failed_places.size(), 1u);
    EXPECT_NE(r.failed_places[0].find("(device 0)"), std::string::npos) << r.failed_places[0];
    EXPECT_NE(r.failed_places[0].find("injected failure"), std::string::npos) << r.failed_places[0];
    for (std::uint64_t id = 0; id < 40; ++id) EXPECT_EQ(toy.completions(id), 1) << id;
}

TEST_F(SchedulerFailover, ADeviceErrorMidItemRerunsItOnTheOtherPlace) {
    Toy toy(30);
    toy.work = std::chrono::milliseconds(2);
    toy.hook = [](std::uint64_t id, int attempt) {
        if (id == 4 && attempt == 0) throw ocl::Error("clEnqueueNDRangeKernel", -5 /* CL_OUT_OF_RESOURCES */);
    };
    schedule::Scheduler s(schedule::Backend::opencl(devices_));
    bool hung = false;
    const schedule::RunReport r = run_guarded(s, toy, 10, &hung);
    ASSERT_FALSE(hung);
    EXPECT_EQ(r.done, 30u);
    EXPECT_EQ(r.rerun, 1u);
    EXPECT_EQ(r.failed_places.size(), 1u);
    EXPECT_EQ(toy.attempts(4), 2);
    for (std::uint64_t id = 0; id < 30; ++id) EXPECT_EQ(toy.completions(id), 1) << id;
}

// The failing place gives its item back after the other place found the queue empty and left: the
// item must still be rerun. Item 0 fails slowly on its first
// attempt; item 1 is quick, so the other place is out of work before the failure.
TEST_F(SchedulerFailover, FailoverWhenTheOtherPlacesHaveFinished) {
    Toy toy(2);
    toy.hook = [](std::uint64_t id, int attempt) {
        if (id == 0 && attempt == 0) {
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
            throw ocl::Error("clFinish", -5 /* CL_OUT_OF_RESOURCES */);
        }
    };
    schedule::Scheduler s(schedule::Backend::opencl(devices_));
    bool hung = false;
    schedule::RunReport r;
    try {
        r = run_guarded(s, toy, 2, &hung);
    } catch (const std::exception& e) {
        ADD_FAILURE() << "run() threw " << e.what() << (hung ? " after the watchdog cancelled it" : "");
    }
    EXPECT_FALSE(hung) << "run() was still waiting 2 s after item 0's device failed (item 0 rerun: "
                       << (toy.attempts(0) > 1 ? "yes" : "no") << "); the other place had already left";
    EXPECT_EQ(toy.completions(0), 1);
    EXPECT_EQ(toy.completions(1), 1);
    if (!hung) {
        EXPECT_EQ(r.rerun, 1u);
    }
}

TEST_F(SchedulerFailover, EveryPlaceFailingNamesEveryFailure) {
    Toy toy(10);
    toy.hook = [](std::uint64_t, int) { throw ocl::Error("clEnqueueReadBuffer", -5 /* CL_OUT_OF_RESOURCES */); };
    schedule::Scheduler s(schedule::Backend::opencl(devices_));
    bool hung = false;
    try {
        run_guarded(s, toy, 10, &hung);
        ADD_FAILURE() << "run() returned";
    } catch (const ocl::Error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("every selected device failed"), std::string::npos) << what;
        EXPECT_NE(what.find("(device 0)"), std::string::npos) << what;
        EXPECT_NE(what.find("(device 1)"), std::string::npos) << what;
        EXPECT_NE(what.find("nothing was written"), std::string::npos) << what;
    }
    EXPECT_FALSE(hung);
    for (std::uint64_t id = 0; id < 10; ++id) EXPECT_EQ(toy.completions(id), 0);
}

// ===================================================================================================
// 3. The LUT slice integrand on the oracle backend agrees with the kernel routine.

BakeSpec small_custom_spec(bool azimuth_mean) {
    BakeSpec s = default_bake_spec(LutLayout::custom, 4);
    s.visibility = {"visibility", 0, 1, 4, TexelConvention::endpoints};  // 0 (exact 0) .. 1 (exact 1)
    s.n_dot_l = {"n_dot_l", 0.2, 1, 3, TexelConvention::endpoints};
    s.n_dot_v = {"n_dot_v", 0.3, 1, 2, TexelConvention::endpoints};
    s.roughness = {0.3, 0.8};
    s.azimuth_mean = azimuth_mean;
    s.azimuth_degrees = 60;
    s.samples = 4096;
    s.seed = 21;
    s.backend.threads = 2;
    return s;
}

TEST(BakeOnTheOracle, AgreesWithTheKernelRoutineTexelByTexel) {
    if (default_device().empty()) GTEST_SKIP() << "no OpenCL device";
    for (const bool mean : {false, true}) {
        BakeSpec spec = small_custom_spec(mean);
        const BakeResult cl = bake_lut(spec);
        spec.backend.kind = schedule::Backend::Kind::oracle;
        const BakeResult oracle = bake_lut(spec);
        ASSERT_EQ(cl.value.size(), oracle.value.size());
        ASSERT_EQ(cl.value.size(), 4u * 3 * 2 * 2);
        const lut_slice::SlicePlan plan = lut_slice::make_slice_plan(spec);
        const AtlasShape shape = plan.atlas();
        std::size_t sampled = 0, exact = 0;
        for (std::uint32_t il = 0; il < plan.nl; ++il)
            for (std::uint32_t iv = 0; iv < plan.nv; ++iv) sampled += plan.texel(il, iv) == lut_slice::sampled;
        sampled *= plan.slices();
        ASSERT_GT(sampled, 0u);
        const double t = bonferroni_t(sampled, spec.replicates);
        double worst_z = 0, worst_diff = 0;
        for (std::uint32_t ivv = 0; ivv < plan.nvv; ++ivv)
            for (std::uint32_t c = 0; c < plan.channels; ++c)
                for (std::uint32_t il = 0; il < plan.nl; ++il)
                    for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
                        const std::size_t at = shape.index(c, iv, il, ivv);
                        const double a = cl.value[at], b = oracle.value[at];
                        const double sa = cl.std_error[at], sb = oracle.std_error[at];
                        const std::string where = std::string(mean ? "mean" : "60 deg") + " c " + std::to_string(c) + " v " +
                                                  std::to_string(iv) + " l " + std::to_string(il) + " nv " + std::to_string(ivv);
                        if (plan.texel(il, iv) != lut_slice::sampled) {
                            EXPECT_EQ(a, b) << where;
                            EXPECT_EQ(a, plan.texel(il, iv) == lut_slice::exact_one ? 1.0 : 0.0) << where;
                            EXPECT_EQ(sa, 0.0);
                            EXPECT_EQ(sb, 0.0);
                            ++exact;
                            continue;
                        }
                        // Both are stored as float: 2^-24 of rounding each on top of the sampling error.
                        const double se = std::sqrt(sa * sa + sb * sb);
                        const double diff = std::abs(a - b);
                        worst_diff = std::max(worst_diff, diff);
                        if (se > 0) worst_z = std::max(worst_z, diff / se);
                        EXPECT_LE(diff, t * se + FLT_EPSILON) << where << ": opencl " << a << " +- " << sa << ", oracle " << b
                                                                       << " +- " << sb;
                    }
        EXPECT_GT(exact, 0u);
        std::printf("[bake oracle] azimuth %s: %zu sampled texels, max |opencl - oracle| %.3g, max z %.3g (bound %.3g)\n",
                    mean ? "mean" : "60", sampled, worst_diff, worst_z, t);
    }
}

// ===================================================================================================
// 4. The term kernel and the bake kernel count alike on the same points, tiny cones included.

TEST(KernelsOnTheSamePoints, TermAndBakeAgreeUpToBoundarySamplesAndMatchTheOracle) {
    const auto devices = default_device();
    if (devices.empty()) GTEST_SKIP() << "no OpenCL device";
    const std::uint32_t R = 8;
    const std::uint64_t samples = std::uint64_t(1) << 20;
    const std::uint64_t seed = 77;
    const double ndotv = 0.5, roughness = 0.5, azimuth = 60;
    const std::vector<double> visibilities{1e-7, 1e-5, 1e-3, 0.3, 0.9};
    // NdotL near 1: the zero region of v is NdotL <= 1 - 2 v, so v = 1e-7 needs NdotL > 1 - 2e-7.
    const std::vector<double> n_dot_ls{1 - 1e-7, 0.999999, 0.99};

    // The bake of one (v, NdotL): visibility texels v (sampled) and 1 (exact), one NdotL row, one slice,
    // a fixed azimuth, one batch: batch 0's points are eval's points for the same seed and samples.
    auto spec_for = [&](double v, double nl) {
        BakeSpec s = default_bake_spec(LutLayout::custom, 2);
        s.visibility = {"visibility", v, 1, 2, TexelConvention::endpoints};
        s.n_dot_l = {"n_dot_l", nl, nl, 1, TexelConvention::endpoints};
        s.n_dot_v = {"n_dot_v", ndotv, ndotv, 1, TexelConvention::endpoints};
        s.roughness = {roughness};
        s.azimuth_mean = false;
        s.azimuth_degrees = azimuth;
        s.replicates = R;
        s.samples = samples;
        s.seed = seed;
        s.tolerance = 0;
        return s;
    };
    SamplingPlan plan;
    plan.samples = samples;
    plan.replicates = R;
    plan.seed = batch_seed(seed, 0);
    ASSERT_EQ(plan.seed, seed);
    const PointSet points = make_point_set(plan);

    struct Case {
        double v, nl;
        Query q;
        bool zero;
    };
    std::vector<Case> cases;
    std::vector<Query> queries;
    for (double v : visibilities)
        for (double nl : n_dot_ls) {
            const BakeSpec s = spec_for(v, nl);
            const Query q = texel_query(s, 0, 0, 0, 0, azimuth);
            ASSERT_EQ(q.visibility, v);
            const bool zero = in_zero_region(cone_cos_theta(v, AoWeighting::cosine), q.wo.z);
            cases.push_back({v, nl, q, zero});
            if (!zero) queries.push_back(q);
        }
    ASSERT_GE(queries.size(), 9u);

    // Term kernel: raw tallies of the sampled queries on the shared points.
    auto backend = make_opencl_backend(devices);
    const Tallies tallies = backend->tally(queries, TermOptions{}, points);

    // Host, in double: the samples whose decision lies within float rounding of a boundary. Both kernels
    // take m from the same float sampler; the host's double m differs from it by the sampler's float
    // error, a few 2^-24 in each component of a unit vector, and each cone test rounds its own few ulps.
    // A sample can be decided differently only if its sine (of the larger angle to z and to wo) or its
    // hemisphere cosines lie within that distance of the boundary: delta = 2e-6 (~34 ulps of 1) covers both.
    const double delta = 2e-6;
    std::vector<Vec3> m(points.total());
    {
        const Query& q0 = queries.front();
        for (std::size_t i = 0; i < m.size(); ++i) {
            const Vec3 s = oracle::sample_vndf(q0.wi, q0.alpha_x, q0.alpha_y, points.u1[i], points.u2[i]);
            const double len = std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
            m[i] = {s.x / len, s.y / len, s.z / len};
        }
    }

    schedule::Scheduler bake_scheduler(schedule::Backend::opencl(devices));
    std::size_t sampled_index = 0, oracle_checks = 0;
    for (const Case& c : cases) if (!c.zero && c.v <= 1e-5) ++oracle_checks;
    const double t_oracle = bonferroni_t(oracle_checks, R);
    for (const Case& c : cases) {
        const BakeSpec spec = spec_for(c.v, c.nl);
        const BakeResult lut = bake_lut(spec, bake_scheduler);
        ASSERT_EQ(lut.value.size(), 2u);
        EXPECT_EQ(lut.value[1], 1.0f);  // v = 1
        char where_buf[64];
        std::snprintf(where_buf, sizeof where_buf, "v %g NdotL %.9g", c.v, c.nl);
        const std::string where = where_buf;
        if (c.zero) {
            EXPECT_EQ(lut.value[0], 0.0f) << where;
            EXPECT_EQ(lut.std_error[0], 0.0f) << where;
            continue;
        }
        const std::size_t k = sampled_index++;
        ASSERT_EQ(queries[k].visibility, c.v);
        const Estimate eval = reduce_replicates(&tallies.cone[k * R], &tallies.hemisphere[k * R], R);
        double cone = 0, hemi = 0;
        for (std::uint32_t r = 0; r < R; ++r) cone += tallies.cone[k * R + r], hemi += tallies.hemisphere[k * R + r];

        const Vec3 wo = c.q.wo;
        const double sin_t = std::sqrt(cone_sin2_theta(c.v, AoWeighting::cosine));
        std::uint64_t boundary = 0;
        for (const Vec3& n : m) {
            const double dot = n.x * wo.x + n.y * wo.y + n.z * wo.z;
            const double cx = n.y * wo.z - n.z * wo.y, cy = n.z * wo.x - n.x * wo.z, cz = n.x * wo.y - n.y * wo.x;
            const double key = std::max(n.x * n.x + n.y * n.y, cx * cx + cy * cy + cz * cz);
            const bool hemisphere_edge = std::abs(n.z) <= delta || std::abs(dot) <= delta;
            const bool cone_edge = n.z > 0 && dot > 0 && std::abs(std::sqrt(key) - sin_t) <= delta;
            boundary += hemisphere_edge || cone_edge;
        }
        // lut = C_b / H_b, eval = C_e / H_e with |C_b - C_e|, |H_b - H_e| <= n and C <= H:
        // |lut - eval| <= 2 n / (H_e - n); plus the float rounding of the stored LUT value.
        const double n = double(boundary);
        const double allowed = (n > 0 ? 2 * n / std::max(1.0, hemi - n) : 0.0) + FLT_EPSILON / 2 * eval.term;
        const double diff = std::abs(double(lut.value[0]) - eval.term);
        EXPECT_LE(diff, allowed) << where << ": lut " << lut.value[0] << ", eval " << eval.term << " (" << cone << " / " << hemi
                                 << "), " << boundary << " boundary samples";
        if (boundary == 0) {
            // Same counts in every replicate: the same per-replicate spread too.
            EXPECT_NEAR(lut.std_error[0], eval.std_error, FLT_EPSILON * eval.std_error + FLT_MIN) << where;
        }
        std::printf("[same points] %s: lut %.9g eval %.9g (cone %.0f of %.0f), |diff| %.3g, boundary samples %llu, allowed %.3g\n",
                    where.c_str(), double(lut.value[0]), eval.term, cone, hemi, diff, (unsigned long long)boundary, allowed);

        if (c.v <= 1e-5) {
            // The tiny cones against the oracle on independent points (Bonferroni over these texels).
            SamplingPlan other = plan;
            other.seed = 990 + k;
            const Estimate ref = oracle::generic_m_g(c.q, TermOptions{}, make_point_set(other));
            const double se = std::sqrt(double(lut.std_error[0]) * lut.std_error[0] + ref.std_error * ref.std_error);
            const double d = std::abs(double(lut.value[0]) - ref.term);
            EXPECT_LE(d, t_oracle * se + FLT_EPSILON / 2 * ref.term) << where << ": lut " << lut.value[0] << " +- " << lut.std_error[0]
                                                                     << ", oracle " << ref.term << " +- " << ref.std_error;
            std::printf("[same points] %s: oracle %.6g +- %.3g, lut %.6g +- %.3g, z %.3g (bound %.3g)\n", where.c_str(), ref.term,
                        ref.std_error, double(lut.value[0]), double(lut.std_error[0]), se > 0 ? d / se : 0.0, t_oracle);
        }
    }
}

}  // namespace
