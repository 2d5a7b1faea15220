// The term by the exact method (host/exact/) as integrands on the scheduler: per query (eval, sweeps,
// scenes, reference sets) and per LUT texel (bakes). Each place evaluates with the C++ evaluator (an
// oracle-backend thread) or the OpenCL kernel kernels/exact/exact_term.cl (a device, in double where it
// has cl_khr_fp64); items are fixed batches, so results do not depend on where they ran.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_kernel.hpp"
#include "integrands/term/term_integrand.hpp"
#include "schedule/integrand.hpp"
#include "schedule/scheduler.hpp"

namespace ms::exact_term {

// One isotropic LUT texel: the term (or its azimuth mean) at these parameters.
using ExactTexel = exact::ExactTexel;

// What one place evaluates with.
class Evaluator {
public:
    virtual ~Evaluator() = default;
    // Terms of normalised, valid queries (the exact cases included: the evaluator answers them).
    virtual void terms(const std::vector<Query>& queries, const std::vector<AoWeighting>& weighting, double tolerance,
                       std::vector<exact::ExactValue>& out) = 0;
    // Azimuth means over [0, pi] (azimuth_mean) or values at one azimuth (radians) of LUT texels.
    virtual void texels(const std::vector<ExactTexel>& texels, AoWeighting weighting, bool azimuth_mean, double azimuth,
                        double tolerance, std::vector<exact::ExactValue>& out) = 0;
};
// The C++ evaluator on the calling thread, or over `threads` threads (the values do not depend on the
// split). Its terms() groups a call's isotropic queries by row (AO weighting, visibility, alpha, NdotL =
// wo.z, all equal) and evaluates each row through one exact::AzimuthGrid at (wi.z, relative_azimuth)
// (on_grid queries; the others by exact::exact_term): each value depends on its query alone.
std::unique_ptr<Evaluator> make_cpu_evaluator(unsigned threads = 1);
// Whether the C++ evaluator takes a query through the azimuth grid: isotropic, alpha at most 1.
bool on_grid(const Query& q);
// The azimuth of wo measured from wi's, in [-pi, pi]: the azimuth grid's phi (it holds the light at
// azimuth 0 and turns the view to -phi). With either vector straight up it is 0 (the term does not
// depend on it then).
double relative_azimuth(const Query& q);
// The OpenCL kernel on a device: double when `double_precision` (the device must have cl_khr_fp64),
// float otherwise.
std::unique_ptr<Evaluator> make_device_evaluator(ocl::Device& device, const ocl::BuildConfig& build);

// How the exact method runs: its tolerance (estimated absolute error of each value) and the kernel
// build (double by default where the device has fp64).
struct ExactConfig {
    double tolerance = exact::kDefaultTolerance;
    ocl::BuildConfig build;          // double_precision is decided per device unless force_float
    bool force_float = false;        // the float kernel even on fp64 devices (what a GPU without fp64 gets)
    // CPU devices run the kernel too (by default their share runs the C++ evaluator on as many threads as
    // the device has compute units: through PoCL the kernel takes ~2x the C++ evaluator's time on a bake, ~5x on eval).
    bool kernel_on_cpu_devices = false;
};
// The evaluator a device's worker uses under `config`: the kernel, or for a CPU device (unless
// kernel_on_cpu_devices or force_float ask for the kernel) the C++ evaluator on its compute units.
std::unique_ptr<Evaluator> make_place_evaluator(ocl::Device& device, const ExactConfig& config);
// Whether make_place_evaluator runs the C++ evaluator in place of `device`'s kernel.
bool runs_host_code(const ocl::DeviceInfo& device, const ExactConfig& config);
// What computes the values under `config` on an OpenCL backend, for provenance records.
std::string describe_engines(const ExactConfig& config);
// The smallest tolerance the evaluator is asked for (below it rounding dominates every estimate).
inline constexpr double kMinTolerance = 1e-13;
// Throws std::invalid_argument unless kMinTolerance <= tolerance <= 0.1.
void validate_tolerance(double tolerance);

struct Stats {
    std::atomic<std::uint64_t> evaluated{0}, exact_zero{0}, exact_one{0}, quadrature_pieces{0};
};

// Per query: the same Source/Sink contract as term::TermIntegrand (estimates with std_error = the
// exact method's estimated error).
class ExactTermIntegrand final : public schedule::Integrand {
public:
    using Source = term::TermIntegrand::Source;
    using Sink = term::TermIntegrand::Sink;
    ExactTermIntegrand(std::uint64_t items, Source source, Sink sink, ExactConfig config);
    std::string name() const override { return "the micro-shadowing term (exact)"; }
    std::uint64_t work_items() const override { return items_; }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override;
    std::unique_ptr<schedule::Worker> oracle_worker() override;
    const Stats& stats() const { return stats_; }
    std::vector<Estimate> evaluate(Evaluator& evaluator, const term::Batch& batch);

private:
    std::uint64_t items_;
    Source source_;
    Sink sink_;
    ExactConfig config_;
    Stats stats_;
};

// Queries per work item: ~20 ms of one CPU thread (about 10 us a query), 4x that on a device.
std::uint64_t queries_per_item(const schedule::Scheduler& scheduler);

// The build a device gets for the exact kernel under `config`.
ocl::BuildConfig device_build(const ocl::DeviceInfo& device, const ExactConfig& config);

}  // namespace ms::exact_term
