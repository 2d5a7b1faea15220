#include "integrands/lut_slice/lut_slice_spec.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "sampling/point_set.hpp"

namespace ms {

const std::uint32_t kDefaultAzimuthIntervals = 16;
const std::uint64_t kDefaultBatchSamples = 65536;

namespace {

std::string number(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
}

void check_axis(const Axis& a, double lo, double hi) {
    if (a.count < 1 || a.count > 4096)
        throw std::invalid_argument(a.name + " size must be in 1..4096, not " + std::to_string(a.count));
    if (!std::isfinite(a.min) || !std::isfinite(a.max) || a.min < lo || a.max > hi || a.min > a.max)
        throw std::invalid_argument(a.name + " range must satisfy " + number(lo) + " <= min <= max <= " + number(hi));
    if (a.min == a.max && a.count > 1) throw std::invalid_argument(a.name + " range is empty but has several texels");
}

}  // namespace

std::string to_string(AzimuthQuadrature q) { return q == AzimuthQuadrature::stratified ? "stratified" : "nodes"; }

AzimuthQuadrature parse_azimuth_quadrature(const std::string& s) {
    if (s == "nodes") return AzimuthQuadrature::nodes;
    if (s == "stratified") return AzimuthQuadrature::stratified;
    throw std::invalid_argument("azimuth quadrature must be nodes or stratified, not '" + s + "'");
}

void validate(const LutSliceSpec& s) {
    check_axis(s.visibility, 0, 1);
    check_axis(s.n_dot_l, 0, 1);
    check_axis(s.n_dot_v, 0, 1);
    if (s.visibility.min == s.visibility.max)
        throw std::invalid_argument("visibility range must not be empty (min < max)");
    if (s.visibility.name != "visibility" || s.n_dot_l.name != "n_dot_l" || s.n_dot_v.name != "n_dot_v")
        throw std::invalid_argument("axes must be named visibility, n_dot_l, n_dot_v");
    for (const Axis* a : {&s.visibility, &s.n_dot_l, &s.n_dot_v})
        if (a->spacing != Spacing::linear) throw std::invalid_argument(a->name + ": LUT axes are linear");
    if (std::uint64_t(s.n_dot_l.count) * s.n_dot_v.count > 1u << 24)
        throw std::invalid_argument("n_dot_l count x n_dot_v count is too large for one image");
    if (s.roughness.empty() || s.roughness.size() > 4)
        throw std::invalid_argument("1 to 4 roughness values are needed (channels R, G, B, A)");
    for (double r : s.roughness)
        if (!std::isfinite(r) || !(r > 0) || r > 1) throw std::invalid_argument("roughness must be in (0, 1], not " + number(r));
    if (!s.azimuth_mean && (!std::isfinite(s.azimuth_degrees) || s.azimuth_degrees < 0 || s.azimuth_degrees > 180))
        throw std::invalid_argument("azimuth must be 'mean' or a number of degrees in [0, 180]");
    if (s.azimuth_intervals > 256) throw std::invalid_argument("azimuth intervals must be in 1..256");
    auto pow2 = [](std::uint32_t k) { return k >= 2 && k <= 256 && (k & (k - 1)) == 0; };
    if (!pow2(s.azimuth_min_intervals) || !pow2(s.azimuth_max_intervals) || s.azimuth_min_intervals > s.azimuth_max_intervals)
        throw std::invalid_argument("adaptive azimuth intervals must be powers of two with 2 <= min <= max <= 256");
    if (!std::isfinite(s.azimuth_refine_threshold) || s.azimuth_refine_threshold < 0 || !std::isfinite(s.azimuth_refine_z) ||
        s.azimuth_refine_z < 0)
        throw std::invalid_argument("azimuth refine threshold and z must be >= 0");
    if (!pow2(s.azimuth_cells)) throw std::invalid_argument("azimuth cells must be a power of two in 2..256");
    if (s.azimuth_quadrature == AzimuthQuadrature::stratified && s.azimuth_intervals)
        throw std::invalid_argument("azimuth intervals apply to the nodes quadrature, not to stratified");
    if (s.replicates < 2 || s.replicates > 1024) throw std::invalid_argument("replicates must be in 2..1024");
    if (s.samples != 0 && (s.samples < 16 || s.samples > (std::uint64_t(1) << 30)))
        throw std::invalid_argument("samples must be in 16..2^30");
    if (!std::isfinite(s.tolerance) || s.tolerance < 0) throw std::invalid_argument("tolerance must be >= 0");
    if (s.tolerance > 0 && s.tolerance < 1e-7) throw std::invalid_argument("tolerance below 1e-7 is below float resolution");
    if (s.max_batches < 1 || s.max_batches > 4096) throw std::invalid_argument("max batches must be in 1..4096");
    if (!s.baked_rows.empty() &&
        s.baked_rows.size() != std::uint64_t(s.n_dot_l.count) * s.n_dot_v.count * s.roughness.size())
        throw std::invalid_argument("baked rows: need one flag per (channel, NdotV slice, NdotL row)");
}

std::uint32_t effective_azimuth_cells(const LutSliceSpec& spec) {
    if (!spec.azimuth_mean || spec.azimuth_quadrature != AzimuthQuadrature::stratified) return 0;
    const std::uint64_t points = round_up_samples(spec.samples ? spec.samples : kDefaultBatchSamples, spec.replicates) / spec.replicates;
    std::uint32_t cells = spec.azimuth_cells;
    while (cells > 1 && std::uint64_t(cells) * 16 > points) cells /= 2;
    return cells;
}

void azimuth_nodes(const LutSliceSpec& spec, std::vector<double>& degrees, std::vector<double>& weights) {
    degrees.clear();
    weights.clear();
    if (!spec.azimuth_mean) {
        degrees.push_back(spec.azimuth_degrees);
        weights.push_back(1.0);
        return;
    }
    if (const std::uint32_t cells = effective_azimuth_cells(spec)) {
        for (std::uint32_t c = 0; c < cells; ++c) {
            degrees.push_back(180.0 * (double(c) + 0.5) / double(cells));
            weights.push_back(1.0 / double(cells));
        }
        return;
    }
    const std::uint32_t k = spec.azimuth_intervals ? spec.azimuth_intervals : kDefaultAzimuthIntervals;
    for (std::uint32_t i = 0; i <= k; ++i) {
        degrees.push_back(180.0 * double(i) / double(k));
        weights.push_back((i == 0 || i == k ? 0.5 : 1.0) / double(k));
    }
}

Query texel_query(const LutSliceSpec& spec, std::uint32_t channel, std::uint32_t iv, std::uint32_t il, std::uint32_t ivv,
                  double azimuth_degrees) {
    Query q;
    q.visibility = spec.visibility.value(iv);
    const double r = spec.roughness.at(channel);
    q.alpha_x = q.alpha_y = r * r;
    const double nv = std::max(spec.n_dot_v.value(ivv), kMinNdotV);
    q.wi = {std::sqrt(std::max(0.0, 1 - nv * nv)), 0, nv};
    const double nl = std::max(spec.n_dot_l.value(il), kMinNdotL);
    const double sl = std::sqrt(std::max(0.0, 1 - nl * nl));
    const double phi = azimuth_degrees * kPi / 180.0;
    q.wo = {sl * std::cos(phi), sl * std::sin(phi), nl};
    return q;
}

}  // namespace ms
