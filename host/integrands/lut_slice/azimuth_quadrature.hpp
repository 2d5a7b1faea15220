// The pure part of a LUT slice: its plan (directions, nodes, exact texels) and the reduction of its
// tallies into texel values, error bars and the adaptive azimuth quadrature's decisions. No device:
// tests drive these with synthetic tallies.
//
// Tallies of one slice, summed over batches: acc[(direction * R + r) * (nv + 1) + j] is the cone count
// of visibility texel j (j < nv) and the hemisphere count (j = nv) of replicate r, direction =
// row * (grid + 1) + node. A row at k intervals uses the nested nodes i * (grid / k), i = 0..k, with
// trapezoid weights (0.5 at the ends) / k; the nodes of k/2 are a subset, so T_k/2 costs nothing.
// A texel's value is the node-weighted mean of the pooled ratios and its error the replicate spread of
// the same mean (core/estimate.hpp's ReplicateRatioMean): the mean of the term over the azimuth, not a
// ratio of means.
//
// Azimuth-stratified plans (cells > 0): a row has `cells` directions, cell c's light at the midpoint
// azimuth 180 (c + 0.5) / cells degrees, and cell c's tallies count only the samples of that cell (a
// disjoint 1/cells of each replicate's points, sampling/point_set.hpp's make_cell_point_set), so
// direction = row * cells + c and every sample is binned once per row. A texel's value is the mean over
// cells of the cell's pooled ratio, weight 1/cells each (the midpoint rule of the mean of ratios: the
// term is smooth, even and periodic in the azimuth, so the rule converges geometrically in the cell
// count), and its error bar the replicate spread of that mean, as for nodes. There is no nested check:
// the quadrature is fixed by the cell count.
#pragma once

#include <cstdint>
#include <vector>

#include "grid/atlas.hpp"
#include "integrands/lut_slice/lut_slice_spec.hpp"

namespace ms::lut_slice {

enum TexelStatus : std::uint8_t { sampled = 0, exact_zero = 1, exact_one = 2 };

struct SlicePlan {
    LutSliceSpec spec;
    std::uint32_t nv = 0, nl = 0, nvv = 0, channels = 0, replicates = 0, points = 0;
    std::uint64_t batch_samples = 0;
    // Azimuth: a grid of `grid` trapezoid intervals (grid + 1 nodes; grid 0: the one fixed angle). A row
    // uses the nested sub-grid of k intervals, k from k_start, doubled while the row's |T_k/2 - T_k|
    // exceeds refine_threshold + refine_z se and k < grid (adaptive), or k = grid (fixed).
    std::uint32_t grid = 0, k_start = 0;
    // Stratified: cells per row (0: nodes or a fixed angle). Then grid = k_start = 0.
    std::uint32_t cells = 0;
    double refine_threshold = 0, refine_z = 0;
    std::vector<double> node_degrees;
    std::vector<float> wo;  // float4 per direction (x, y, z, 0): what the kernel reads
    // Texel status per (row, visibility), the same in every slice.
    std::vector<std::uint8_t> status;

    AtlasShape atlas() const { return {nv, nl, nvv, channels}; }
    std::uint64_t slices() const { return std::uint64_t(channels) * nvv; }
    std::size_t directions() const { return wo.size() / 4; }
    // Directions of one row: grid + 1 nodes, or the cells.
    std::uint32_t row_directions() const { return cells ? cells : grid + 1; }
    std::size_t tally_size() const { return directions() * replicates * (nv + 1); }
    std::uint8_t texel(std::uint32_t il, std::uint32_t iv) const { return status[std::size_t(il) * nv + iv]; }
    bool row_sampled(std::uint32_t il) const;
};
SlicePlan make_slice_plan(const LutSliceSpec& spec);

using SliceTallies = std::vector<double>;

std::uint32_t row_node(const SlicePlan& plan, std::uint32_t k, std::uint32_t i);
double row_weight(std::uint32_t k, std::uint32_t i);

// The texel's node-weighted mean over the row's k-interval nodes, with its replicate error bar
// (stratified plans: the mean over the row's cells, k ignored).
Estimate texel_mean(const SlicePlan& plan, const SliceTallies& acc, std::uint32_t il, std::uint32_t k, std::uint32_t iv);

// Quadrature check of row il at k intervals (k even; 0 otherwise): per sampled texel d = T_k - T_k/2
// (same counts) and its replicate std error se_d. Returns max |d| over the row; `significant` is set
// when some texel has |d| > threshold + z * se_d, a difference the sampling noise of d does not explain.
double row_quadrature(const SlicePlan& plan, const SliceTallies& acc, std::uint32_t il, std::uint32_t k,
                      double threshold = 0, double z = 0, bool* significant = nullptr);

// Values and std errors of a slice's texels, row-major (il * nv + iv), row il over its k[il] intervals
// (stratified: over its cells, k ignored, by a loop that shares each cell's reciprocal denominators
// across the row's texels; texel_mean is its reference); exact texels by rule. Returns the largest std error of a sampled texel.
struct SliceValues {
    std::vector<float> value, std_error;
};
double reduce_slice(const SlicePlan& plan, const SliceTallies& acc, const std::vector<std::uint32_t>& k, SliceValues& out);

}  // namespace ms::lut_slice
