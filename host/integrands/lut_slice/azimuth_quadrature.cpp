#include "integrands/lut_slice/azimuth_quadrature.hpp"

#include <algorithm>
#include <cmath>

#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "sampling/point_set.hpp"

namespace ms::lut_slice {

bool SlicePlan::row_sampled(std::uint32_t il) const {
    for (std::uint32_t iv = 0; iv < nv; ++iv)
        if (texel(il, iv) == sampled) return true;
    return false;
}

SlicePlan make_slice_plan(const LutSliceSpec& spec) {
    SlicePlan p;
    p.spec = spec;
    p.nv = spec.visibility.count;
    p.nl = spec.n_dot_l.count;
    p.nvv = spec.n_dot_v.count;
    p.channels = std::uint32_t(spec.roughness.size());
    p.replicates = spec.replicates;
    p.batch_samples = round_up_samples(spec.samples ? spec.samples : kDefaultBatchSamples, spec.replicates);
    p.points = std::uint32_t(p.batch_samples / spec.replicates);
    p.cells = effective_azimuth_cells(spec);
    if (!spec.azimuth_mean || p.cells) {
        p.grid = p.k_start = 0;
    } else if (spec.azimuth_intervals) {
        p.grid = p.k_start = spec.azimuth_intervals;
    } else {
        p.grid = spec.azimuth_max_intervals;
        p.k_start = spec.azimuth_min_intervals;
        p.refine_threshold = spec.azimuth_refine_threshold;
        p.refine_z = spec.azimuth_refine_z;
    }
    if (p.cells) {
        std::vector<double> weights;
        azimuth_nodes(spec, p.node_degrees, weights);  // the cells' midpoints
    } else if (p.grid == 0) {
        p.node_degrees = {spec.azimuth_mean ? 0.0 : spec.azimuth_degrees};
    } else {
        // As azimuth_nodes(): 180 i / grid; node i * (grid / k) of the grid is bit for bit node i of k.
        for (std::uint32_t i = 0; i <= p.grid; ++i) p.node_degrees.push_back(180.0 * double(i) / double(p.grid));
    }
    for (std::uint32_t il = 0; il < p.nl; ++il)
        for (std::size_t node = 0; node < p.node_degrees.size(); ++node) {
            const Query q = texel_query(spec, 0, 0, il, 0, p.node_degrees[node]);
            // w: the cell whose points the kernel bins for this direction (0: all points).
            p.wo.insert(p.wo.end(), {float(q.wo.x), float(q.wo.y), float(q.wo.z), p.cells ? float(node) : 0.0f});
        }
    p.status.resize(std::size_t(p.nl) * p.nv);
    for (std::uint32_t il = 0; il < p.nl; ++il)
        for (std::uint32_t iv = 0; iv < p.nv; ++iv) {
            const double v = spec.visibility.value(iv);
            const double nl = std::max(spec.n_dot_l.value(il), kMinNdotL);
            p.status[std::size_t(il) * p.nv + iv] =
                in_zero_region(cone_cos_theta(v, spec.term.ao_weighting), nl) ? exact_zero : v == 1.0 ? exact_one : sampled;
        }
    return p;
}

std::uint32_t row_node(const SlicePlan& plan, std::uint32_t k, std::uint32_t i) { return k ? i * (plan.grid / k) : 0; }
double row_weight(std::uint32_t k, std::uint32_t i) { return k ? (i == 0 || i == k ? 0.5 : 1.0) / double(k) : 1.0; }

namespace {
// Adds row il's nodes at k intervals, each weight multiplied by `sign`, for texel iv.
void add_row_nodes(ReplicateRatioMean& mean, const SlicePlan& plan, const SliceTallies& acc, std::uint32_t il,
                   std::uint32_t k, std::uint32_t iv, double sign) {
    const std::uint32_t R = plan.replicates;
    const std::size_t stride = plan.nv + 1;
    for (std::uint32_t i = 0; i <= k; ++i) {
        const std::size_t item0 = (std::size_t(il) * (plan.grid + 1) + row_node(plan, k, i)) * R;
        mean.add(sign * row_weight(k, i), &acc[item0 * stride + iv], &acc[item0 * stride + plan.nv], stride);
    }
}
}  // namespace

Estimate texel_mean(const SlicePlan& plan, const SliceTallies& acc, std::uint32_t il, std::uint32_t k, std::uint32_t iv) {
    ReplicateRatioMean mean(plan.replicates);
    if (plan.cells) {
        const std::size_t stride = plan.nv + 1;
        for (std::uint32_t c = 0; c < plan.cells; ++c) {
            const std::size_t item0 = (std::size_t(il) * plan.cells + c) * plan.replicates;
            mean.add(1.0 / double(plan.cells), &acc[item0 * stride + iv], &acc[item0 * stride + plan.nv], stride);
        }
        return mean.estimate();
    }
    add_row_nodes(mean, plan, acc, il, k, iv, 1.0);
    return mean.estimate();
}

namespace {
// reduce_slice's stratified row: the arithmetic of ReplicateRatioMean (pooled ratio per cell, per-replicate
// ratios for the spread, a zero denominator counting as 0), with each (cell, replicate)'s 1 / h computed
// once for the row's texels instead of one division per texel.
void reduce_stratified_row(const SlicePlan& plan, const SliceTallies& acc, std::uint32_t il, SliceValues& out, double& max_se) {
    const std::uint32_t R = plan.replicates, nv = plan.nv, K = plan.cells;
    const std::size_t stride = nv + 1;
    const double w = 1.0 / double(K);
    std::vector<double> x(std::size_t(R) * nv, 0.0), value(nv, 0.0), cone_sum(nv);
    for (std::uint32_t c = 0; c < K; ++c) {
        const double* item = &acc[(std::size_t(il) * K + c) * R * stride];
        std::fill(cone_sum.begin(), cone_sum.end(), 0.0);
        double hemi_sum = 0;
        for (std::uint32_t r = 0; r < R; ++r) {
            const double* row = item + std::size_t(r) * stride;
            const double h = row[nv];
            hemi_sum += h;
            const double scale = h > 0 ? w / h : 0.0;
            double* xr = &x[std::size_t(r) * nv];
            for (std::uint32_t iv = 0; iv < nv; ++iv) {
                cone_sum[iv] += row[iv];
                xr[iv] += scale * row[iv];
            }
        }
        if (hemi_sum > 0)
            for (std::uint32_t iv = 0; iv < nv; ++iv) value[iv] += w * (cone_sum[iv] / hemi_sum);
    }
    for (std::uint32_t iv = 0; iv < nv; ++iv) {
        const std::size_t at = std::size_t(il) * nv + iv;
        const std::uint8_t status = plan.texel(il, iv);
        if (status != sampled) {
            out.value[at] = status == exact_one ? 1.0f : 0.0f;
            out.std_error[at] = 0.0f;
            continue;
        }
        double mean = 0;
        for (std::uint32_t r = 0; r < R; ++r) mean += x[std::size_t(r) * nv + iv];
        mean /= double(R);
        double ss = 0;
        for (std::uint32_t r = 0; r < R; ++r) {
            const double d = x[std::size_t(r) * nv + iv] - mean;
            ss += d * d;
        }
        const double se = std::sqrt(ss / (double(R) * double(R - 1)));
        out.value[at] = float(value[iv]);
        out.std_error[at] = float(se);
        max_se = std::max(max_se, se);
    }
}
}  // namespace

double row_quadrature(const SlicePlan& plan, const SliceTallies& acc, std::uint32_t il, std::uint32_t k, double threshold,
                      double z, bool* significant) {
    if (significant) *significant = false;
    if (k < 2 || k % 2) return 0;
    double worst = 0;
    for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
        if (plan.texel(il, iv) != sampled) continue;
        const double d = texel_mean(plan, acc, il, k, iv).term - texel_mean(plan, acc, il, k / 2, iv).term;
        worst = std::max(worst, std::abs(d));
        if (!significant || *significant || std::abs(d) <= threshold) continue;
        // The difference's own error bar: each replicate's T_k - T_k/2 from its own ratios.
        ReplicateRatioMean difference(plan.replicates);
        add_row_nodes(difference, plan, acc, il, k, iv, 1.0);
        add_row_nodes(difference, plan, acc, il, k / 2, iv, -1.0);
        if (std::abs(d) > threshold + z * difference.std_error()) *significant = true;
    }
    return worst;
}

double reduce_slice(const SlicePlan& plan, const SliceTallies& acc, const std::vector<std::uint32_t>& k, SliceValues& out) {
    double max_se = 0;
    for (std::uint32_t il = 0; il < plan.nl; ++il) {
        if (plan.cells && plan.row_sampled(il)) {
            reduce_stratified_row(plan, acc, il, out, max_se);
            continue;
        }
        for (std::uint32_t iv = 0; iv < plan.nv; ++iv) {
            const std::size_t at = std::size_t(il) * plan.nv + iv;
            const std::uint8_t status = plan.texel(il, iv);
            if (status != sampled) {
                out.value[at] = status == exact_one ? 1.0f : 0.0f;
                out.std_error[at] = 0.0f;
                continue;
            }
            const Estimate e = texel_mean(plan, acc, il, k[il], iv);
            out.value[at] = float(e.term);
            out.std_error[at] = float(e.std_error);
            max_se = std::max(max_se, e.std_error);
        }
    }
    return max_se;
}

}  // namespace ms::lut_slice
