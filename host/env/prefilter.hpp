// GGX prefiltering of environment maps for the split-sum approximation (Karis 2013): with N = V = R,
//     P(n) = integral L(l) (n.l) D(h) dl / integral (n.l) D(h) dl,   h = normalize(n + l), n.l > 0,
// the radiance a GGX lobe of roughness r (alpha = r^2) gathers around direction n.
//
// Estimator: h sampled from D(h) (h.n) (Hammersley points, Owen-scrambled replicates), l = reflect(-n, h),
// pdf(l) = D(h) / 4; the ratio sum L (n.l) / sum (n.l) over replicates gives the value and its error bar.
// Filtered importance sampling (Krivanek & Colbert 2008) reads each sample from the source mip whose
// texels cover the sample's share of the sphere: lod = 1/2 log2(Omega_s / Omega_p) + bias, Omega_s =
// 1 / (N pdf), Omega_p the solid angle of a full-resolution texel where the sample lands (K & C use the
// mean 4 pi / (6 n0^2)); with filtered = false every sample reads the full-resolution
// source (bilinear), the brute-force importance sampling it is compared against.
// The oracle sums every source texel with its exact solid angle (texels near the lobe subdivided 8 x 8 with
// bilinear reads, so the lobe of a small roughness is resolved): deterministic, O(texels) per direction.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "env/cubemap.hpp"
#include "sampling/point_set.hpp"

namespace ms::env {

enum class RoughnessMapping { cmgen, linear };
RoughnessMapping parse_roughness_mapping(const std::string&);  // "cmgen" | "linear"
std::string to_string(RoughnessMapping);
// Perceptual roughness of mip m of a chain of `levels` (t = m / (levels - 1)): cmgen (Filament)
// r = 1 - sqrt(1 - t), i.e. t = r (2 - r); linear r = t.
double mip_roughness(std::uint32_t mip, std::uint32_t levels, RoughnessMapping mapping);

struct PrefilterOptions {
    bool filtered = true;
    double lod_bias = 0.0;  // Krivanek & Colbert add +1; 0 measured better against the oracle (docs/ibl.md)
};

struct PrefilterValue {
    std::array<double, 3> value{}, std_error{};
};

// The ratio estimator's per-replicate tallies of one direction: num[3 r + c] = sum L_c (n.l),
// den[r] = sum (n.l) over replicate r's points. Rounds of samples on independently scrambled point sets
// add replicate by replicate (replicate r of the sum is still independent of replicate r' != r), so a
// texel can be sampled until its error bar is small enough (jobs/ibl_prefilter.hpp, tolerance).
struct PrefilterSums {
    std::vector<double> num, den;
    explicit PrefilterSums(std::uint32_t replicates = 0) : num(3 * std::size_t(replicates), 0.0), den(replicates, 0.0) {}
    std::uint32_t replicates() const { return std::uint32_t(den.size()); }
    void add(const PrefilterSums& other);  // same replicate count
};
// Accumulates one direction's tallies on `points` into `sums` (sums.replicates() == points.replicates).
void prefilter_sums(const std::vector<Cubemap>& chain, const Dir& n, double roughness, const PointSet& points,
                    const PrefilterOptions& options, PrefilterSums& sums);
// The pooled ratio and its replicate standard error per channel, plus a deterministic part added to the value
// (the bright texels' exact share, bright_texel_share).
PrefilterValue prefilter_value(const PrefilterSums& sums, const std::array<double, 3>& exact_part = {});

// One direction, roughness r > 0, on `points` (all replicates). chain: the source's mip chain.
PrefilterValue prefilter_direction(const std::vector<Cubemap>& chain, const Dir& n, double roughness, const PointSet& points,
                                   const PrefilterOptions& options);
// Bright texels summed explicitly. The environment is split exactly,
// L = L_rest + L_bright, where L_bright holds the source texels whose luminance (mean of RGB) exceeds
// `threshold` times the environment's mean radiance (the brightest `max_texels` at most) and L_rest is the
// source with those texels set to 0. Then
//     P(n) = N_rest(n) / Z + sum_{i bright} L_i integral_{T_i} (n.l) D(h) dl / Z,   Z = integral (n.l) D(h) dl,
// the first term by the usual estimator on L_rest's own mip chain (the ratio sum L (n.l) / sum (n.l) estimates
// N_rest / Z, with its replicate error bars), the second deterministically: each bright texel's integral at
// its centre, or, while the lobe is narrow against a texel and near it, over its bilinear tent (the source as
// bilinear reads see it, as the oracle does there) on 16 x 16 points; and Z
// in closed form (ggx_prefilter_normalisation). Neither filtering's blur nor the sampling noise then sees the
// sun: its share is exact up to the sub-texel rule.
struct BrightTexel {
    int face = 0;
    std::uint32_t x = 0, y = 0;
    std::array<float, 3> value{};
};
// The bright texels' geometry for the explicit sum, computed once, as arrays (the sum over them vectorises):
// point 0 is a texel's centre with its exact solid angle, points 1-4 the 2 x 2 midpoint rule that checks it
// (quarter centres with their solid-angle weights).
struct BrightTexelGeometry {
    std::array<std::vector<double>, 5> x, y, z, weight;
};
struct SupportTexel {
    int face = 0;
    std::uint32_t x = 0, y = 0;
    Dir centre;
};
struct BrightSplit {
    std::vector<Cubemap> rest_chain;  // mip chain of L_rest
    Cubemap bright_only;               // L_bright: the bright texels, 0 elsewhere
    std::vector<SupportTexel> support;  // the texels a bilinear read of a bright texel reaches
    std::vector<BrightTexel> texels;
    BrightTexelGeometry geometry;  // [point][i] of texels[i]
    std::uint32_t size = 0;           // the source's face size
    double threshold = 0, mean_radiance = 0, bright_power_fraction = 0;
};
BrightSplit split_bright_texels(const Cubemap& source, double threshold, std::size_t max_texels);
// The split chosen automatically: the k brightest texels (k <= max_texels) that minimise the modelled cost per
// output texel of reaching relative error `tolerance`,
//     cost(k) = CV_rest(k)^2 / tolerance^2 + explicit_cost_ratio * k,
// CV_rest(k)^2 = 4 pi int L_rest^2 dl / (int L_rest dl)^2 - 1 the squared coefficient of variation of the rest
// over the sphere (the variance per sample of an estimator spreading its samples over the whole sphere, the
// widest lobe; narrower lobes see less of the sphere and gain less), and explicit_cost_ratio the cost of one
// texel of the explicit sum against one sample (measured 0.25 on CPU threads: ~40 ns for a bright texel with its 2 x 2 check against ~160 ns for a filtered trilinear sample).
// The threshold recorded is the k-th texel's luminance over the mean radiance (0 when k = 0).
BrightSplit choose_bright_split(const Cubemap& source, double tolerance, std::size_t max_texels, double explicit_cost_ratio = 0.25);
// The bright texels' share of P(n): sum_i L_i integral_{T_i} (n.l) D(h) dl / Z (the deterministic part above).
std::array<double, 3> bright_texel_share(const BrightSplit& split, const Dir& n, double roughness);
// The same share with its error bound: it has no replicate variance, so its bar is the rule's error, estimated
// as the difference from a coarser rule (centre against the 2 x 2 midpoint rule; near a narrow lobe, the oracle's
// m x m bilinear sub-directions against (m/2) x (m/2)), plus the double summation's rounding bound (k + 16) u sum |terms|.
struct BrightShare {
    std::array<double, 3> share{}, bound{};
};
BrightShare bright_texel_share_bounded(const BrightSplit& split, const Dir& n, double roughness);
// Z(alpha) = integral (n.l) D(h) dl over n.l > 0 with l = reflect(-n, h): 4 int_0^u* (2 (1 - u) / (1 + b u) - 1) du,
// b = alpha^2 - 1, u* = 1 / (1 + alpha^2) (the GGX CDF in u = the sampling variable); 1 at alpha = 1.
double ggx_prefilter_normalisation(double alpha);
PrefilterValue prefilter_direction_split(const BrightSplit& split, const Dir& n, double roughness, const PointSet& points,
                                         const PrefilterOptions& options);

// The oracle (brute force over the full-resolution source).
// It normalises by its own rule's sum of (n.l) D dl, which misses the closed form Z by the rule's error (the
// horizon cuts texels; ~0.3% at 16^2 faces, less as faces grow); `weight_sum`, when given, receives that sum.
std::array<double, 3> prefilter_oracle(const Cubemap& source, const Dir& n, double roughness, double* weight_sum = nullptr);
// The GGX NDF, written here in double for the prefilter (alpha = roughness^2).
double ggx_d(double n_dot_h, double alpha);

}  // namespace ms::env
