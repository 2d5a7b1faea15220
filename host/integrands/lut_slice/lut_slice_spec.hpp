// What a LUT bake integrates: the axes, the roughness channels, the azimuth policy, the sampling and
// the error control. The LUT slice integrand (lut_slice_integrand.hpp) and the bake job read it.
//
// A texel is GenericM_g(v, alpha, wi, wo) with alpha = roughness^2, wi = (sqrt(1 - NdotV^2), 0, NdotV)
// and wo = (sin_l cos phi, sin_l sin phi, NdotL) for a relative azimuth phi: either one fixed angle, or
// the mean of the term over phi in [0, 180] degrees by the trapezoid rule. The term is an even,
// 360-periodic, smooth function of phi, so the trapezoid rule on [0, 180] is the rectangle rule on the
// full circle, which converges geometrically.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "grid/axis.hpp"

namespace ms {

// How `azimuth_mean` integrates over the relative azimuth. nodes: every sample of the slice at every
// trapezoid node of a row (adaptive or fixed K, below). stratified: the azimuth as a third, independently
// scrambled dimension of the points, cut into azimuth_cells cells of [0, 180] degrees; each sample is
// binned once per row, at its cell's midpoint azimuth, and the texel is the mean over cells of the
// cell's pooled ratio (the midpoint rule of the mean of ratios; azimuth_quadrature.hpp).
enum class AzimuthQuadrature { nodes, stratified };
std::string to_string(AzimuthQuadrature);
AzimuthQuadrature parse_azimuth_quadrature(const std::string&);  // "nodes" | "stratified"; std::invalid_argument

struct LutSliceSpec {
    // Axes, in file order: visibility (x), n_dot_l (rows within a slice), n_dot_v (slices).
    Axis visibility{"visibility", 0, 1, 32, TexelConvention::centres};
    Axis n_dot_l{"n_dot_l", 0, 1, 32, TexelConvention::centres};
    Axis n_dot_v{"n_dot_v", 0, 1, 32, TexelConvention::centres};
    // Isotropic roughness of each channel, alpha = roughness^2; 1 to 4 values in (0, 1].
    std::vector<double> roughness{0.1, 0.4, 0.7, 1.0};

    // Relative azimuth: the mean over [0, 180] degrees, or one fixed angle in degrees.
    bool azimuth_mean = true;
    double azimuth_degrees = 0;
    // azimuth_intervals > 0: that fixed K for every texel. 0 (the default): adaptive, per (slice, NdotL
    // row): start at azimuth_min_intervals and double K (nested nodes, same points) while some sampled
    // texel of the row has |T_K - T_K/2| > azimuth_refine_threshold + azimuth_refine_z * (its replicate
    // std error), up to azimuth_max_intervals (powers of two; docs/lab-notes/bake-defaults.md).
    std::uint32_t azimuth_intervals = 0;
    std::uint32_t azimuth_min_intervals = 4, azimuth_max_intervals = 32;
    double azimuth_refine_threshold = 1e-4, azimuth_refine_z = 3;
    AzimuthQuadrature azimuth_quadrature = AzimuthQuadrature::nodes;
    // Stratified: cells over [0, 180] degrees (a power of two, 2..256); a batch with fewer than 16 points
    // per cell and replicate uses the largest count that has 16 (SlicePlan::cells records it).
    std::uint32_t azimuth_cells = 32;

    TermOptions term;
    Sequence sequence = Sequence::sobol;
    std::uint32_t replicates = 8;
    // Samples per batch and slice (all replicates together), rounded up like eval's --samples.
    std::uint64_t samples = 0;  // 0: kDefaultBatchSamples
    std::uint64_t seed = 0;
    // Error control: tolerance > 0 adds batches to a slice until every texel's std error <= tolerance
    // (or max_batches is reached); tolerance == 0 runs exactly one batch of `samples`.
    double tolerance = 0;
    std::uint32_t max_batches = 64;

    ocl::BuildConfig build;  // the kernel routine's build (the oracle ignores it)

    // sampled: everything above. exact: every texel by the deterministic evaluator (host/exact/), to
    // `tolerance` (0: kDefaultExactBakeTolerance) estimated error per texel; sequence, samples, replicates,
    // seed and the azimuth quadrature settings are then unused.
    Method method = Method::sampled;
    bool exact_single_precision = false;  // exact on OpenCL devices: the float kernel even with fp64
    bool exact_kernel_on_cpu = false;     // exact: the kernel on CPU devices too (default: the C++ evaluator)

    // Which NdotL rows to bake (a partial bake: `microshadow bake --scene`, jobs/scene_bake.hpp). Empty
    // (the default): every row of every slice, as every bake before it. Otherwise one flag per (slice,
    // row), index slice * n_dot_l.count + row with slice = NdotV index * channels + channel (the
    // integrand's work-item order); rows flagged 0 are not sampled and hold NaN (value and std error),
    // and a slice with no row flagged costs nothing. Rows are the unit because every texel of a row
    // comes from the same histogram: part of a row costs as much as all of it.
    std::vector<std::uint8_t> baked_rows;
    bool row_baked(std::uint64_t slice, std::uint32_t row) const {
        return baked_rows.empty() || baked_rows[slice * n_dot_l.count + row] != 0;
    }
};

// Defaults chosen by measurement (docs/lab-notes/bake-defaults.md).
extern const std::uint32_t kDefaultAzimuthIntervals;  // the reference grid of azimuth_nodes() (16)
extern const std::uint64_t kDefaultBatchSamples;      // 65536
// The exact bake's default tolerance per texel (docs/exact-method.md: the accuracy at which it is faster
// than the sampled default bake, which reaches ~5e-4).
inline constexpr double kDefaultExactBakeTolerance = 1e-6;
// NdotV = 0 (the endpoint convention's first slice) has wi on the horizon, where the VNDF sampler and
// eval's input check (wi_z > 0) are undefined; such texels are evaluated at this NdotV instead.
inline constexpr double kMinNdotV = 1e-4;
// NdotL = 0 (the endpoints convention's first row) is a light exactly on the horizon, where the term
// is 0 by definition, but its limit from above is not (0.50 at v = 0.89 for roughness 1): a row of
// zeros would drag the whole first NdotL interval of a bilinear lookup towards a wrong 0 (docs/study.md,
// section 3). The row stores the limit instead, evaluated at this NdotL.
inline constexpr double kMinNdotL = 1e-4;

// The cells a stratified bake of this spec uses: azimuth_cells, halved while a cell would hold fewer
// than 16 points per replicate in a batch; 0 for the nodes quadrature or a fixed angle.
std::uint32_t effective_azimuth_cells(const LutSliceSpec& spec);

// Throws std::invalid_argument naming the problem (sizes 1..4096, roughness in (0, 1], ranges, ...).
void validate(const LutSliceSpec& spec);

// The (alpha, wi, wo) query of one texel at one azimuth (degrees), as `microshadow eval` would take it.
Query texel_query(const LutSliceSpec& spec, std::uint32_t channel, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv,
                  double azimuth_degrees);
// The azimuth nodes (degrees) and trapezoid weights (summing to 1) a fixed-K bake uses; for the adaptive
// default (azimuth_intervals 0) the reference grid of kDefaultAzimuthIntervals, which the adaptive rows
// approximate to within the recorded quadrature estimate (verify and the benchmarks use it). Stratified:
// the midpoints of the azimuth_cells cells, weight 1 / cells each (the rule the bake estimates).
void azimuth_nodes(const LutSliceSpec& spec, std::vector<double>& degrees, std::vector<double>& weights);

}  // namespace ms
