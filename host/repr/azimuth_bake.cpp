// The bake that keeps the relative azimuth (its nodes and roughness subsets; the bake itself is the job
// jobs/repr_bake.cpp), and the roughness placement by error.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "repr/representation.hpp"

namespace ms::repr {

double AzimuthBake::azimuth_at(std::uint32_t k) const {
    return azimuth_nodes <= 1 ? 0.0 : M_PI * double(k) / double(azimuth_nodes - 1);
}

AzimuthBake AzimuthBake::with_roughness(const std::vector<std::uint32_t>& keep) const {
    AzimuthBake out = *this;
    out.grid.roughness.clear();
    out.value.clear();
    out.std_error.clear();
    const std::size_t block = std::size_t(azimuth_nodes) * grid.visibility * grid.n_dot_l * grid.n_dot_v;
    for (auto r : keep) {
        if (r >= grid.roughness.size()) throw std::invalid_argument("with_roughness: index out of range");
        out.grid.roughness.push_back(grid.roughness[r]);
        out.value.insert(out.value.end(), value.begin() + r * block, value.begin() + (r + 1) * block);
        out.std_error.insert(out.std_error.end(), std_error.begin() + r * block, std_error.begin() + (r + 1) * block);
    }
    return out;
}

std::vector<std::uint32_t> choose_roughness_nodes(const AzimuthBake& bake, std::uint32_t count, double* rms_out) {
    const auto& g = bake.grid;
    const std::uint32_t dense = std::uint32_t(g.roughness.size());
    if (count < 2 || count > dense) throw std::invalid_argument("choose_roughness_nodes: need 2 <= count <= the bake's roughness nodes");
    for (std::uint32_t m = 1; m < dense; ++m)
        if (!(g.roughness[m] > g.roughness[m - 1])) throw std::invalid_argument("choose_roughness_nodes: roughness must increase");
    // The blend compares the same texel across roughness nodes: under edge-roughness a texel's NdotL
    // differs from node to node, so there is no common point to compare.
    if (g.warps.n_dot_l == NdotLWarp::edge_roughness)
        throw std::invalid_argument("choose_roughness_nodes: not with the edge-roughness NdotL warp (each node has its own NdotL texels)");
    const std::size_t block = std::size_t(bake.azimuth_nodes) * g.visibility * g.n_dot_l * g.n_dot_v;
    if (bake.value.size() != block * dense) throw std::invalid_argument("choose_roughness_nodes: the bake's size does not match its grid");
    // N.L weight of each texel of a block (the same in every roughness and node block).
    std::vector<double> weight(block);
    double weight_sum = 0;
    for (std::uint32_t k = 0; k < bake.azimuth_nodes; ++k)
        for (std::uint32_t ivv = 0; ivv < g.n_dot_v; ++ivv)
            for (std::uint32_t il = 0; il < g.n_dot_l; ++il)
                for (std::uint32_t iv = 0; iv < g.visibility; ++iv)
                    weight_sum += weight[bake.index(0, k, iv, il, ivv)] = g.n_dot_l_at(iv, il);
    // Weighted mean squared error at dense node m of the linear blend between kept nodes a < m < b,
    // memoised: a search asks for the same (a, m, b) many times.
    std::vector<double> memo(std::size_t(dense) * dense * dense, -1);
    auto mse = [&](std::uint32_t a, std::uint32_t m, std::uint32_t b) {
        double& cached = memo[(std::size_t(a) * dense + m) * dense + b];
        if (cached >= 0) return cached;
        const double f = (g.roughness[m] - g.roughness[a]) / (g.roughness[b] - g.roughness[a]);
        double s = 0;
        for (std::size_t i = 0; i < block; ++i) {
            const double e = (1 - f) * bake.value[a * block + i] + f * bake.value[b * block + i] - bake.value[m * block + i];
            s += weight[i] * e * e;
        }
        return cached = s / weight_sum;
    };
    // The objective: the N.L-weighted RMS over every dense node (kept nodes contribute 0), i.e. over a
    // roughness drawn uniformly from the dense nodes, as a sweep uniform in roughness sees it.
    auto objective = [&](const std::vector<std::uint32_t>& kept) {
        double s = 0;
        for (std::size_t j = 0; j + 1 < kept.size(); ++j)
            for (std::uint32_t m = kept[j] + 1; m < kept[j + 1]; ++m) s += mse(kept[j], m, kept[j + 1]);
        return std::sqrt(s / dense);
    };
    std::vector<std::uint32_t> best;
    double best_value = std::numeric_limits<double>::infinity();
    if (dense <= 2 || count == dense) {
        for (std::uint32_t m = 0; m < dense; ++m) best.push_back(m);
        best.resize(std::min(count, dense));
        best_value = objective(best);
    } else {
        // Every subset with both ends when there are few (C(dense - 2, count - 2) <= 20000: 13 dense
        // nodes and 8 kept is 462), else greedy insertion followed by single-node exchanges until none helps.
        double subsets = 1;
        for (std::uint32_t i = 0; i < count - 2; ++i) subsets = subsets * (dense - 2 - i) / (i + 1);
        if (subsets <= 20000) {
            std::vector<std::uint32_t> inner(count - 2);
            for (std::uint32_t i = 0; i < inner.size(); ++i) inner[i] = i + 1;
            while (true) {
                std::vector<std::uint32_t> kept{0};
                kept.insert(kept.end(), inner.begin(), inner.end());
                kept.push_back(dense - 1);
                const double v = objective(kept);
                if (v < best_value) best_value = v, best = kept;
                // Next combination of count - 2 inner nodes out of 1..dense-2, in lexicographic order.
                int i = int(inner.size()) - 1;
                while (i >= 0 && inner[i] == dense - 2 - (inner.size() - 1 - i)) --i;
                if (i < 0) break;
                ++inner[i];
                for (std::size_t j = i + 1; j < inner.size(); ++j) inner[j] = inner[j - 1] + 1;
            }
        } else {
            best = {0, dense - 1};
            while (best.size() < count) {
                double b = std::numeric_limits<double>::infinity();
                std::vector<std::uint32_t> next;
                for (std::uint32_t m = 1; m + 1 < dense; ++m) {
                    if (std::find(best.begin(), best.end(), m) != best.end()) continue;
                    auto trial = best;
                    trial.insert(std::upper_bound(trial.begin(), trial.end(), m), m);
                    const double v = objective(trial);
                    if (v < b) b = v, next = trial;
                }
                best = next;
            }
            best_value = objective(best);
            for (bool improved = true; improved;) {
                improved = false;
                for (std::size_t j = 1; j + 1 < best.size(); ++j)
                    for (std::uint32_t m = best[j - 1] + 1; m < best[j + 1]; ++m) {
                        auto trial = best;
                        trial[j] = m;
                        const double v = objective(trial);
                        if (v < best_value - 1e-15) best_value = v, best = trial, improved = true;
                    }
            }
        }
    }
    if (rms_out) *rms_out = best_value;
    return best;
}

}  // namespace ms::repr
