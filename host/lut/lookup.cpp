#include "lut/lookup.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace ms {

namespace {

struct Tap {
    std::uint32_t i0, i1;
    double f;  // weight of i1
};

// Texel coordinate of parameter p on an axis, clamp-to-edge, as described in the header.
Tap tap(const LutAxis& a, double p) {
    if (a.count <= 1 || a.max == a.min) return {0, 0, 0};
    const double t = a.texel_coordinate(p);
    const auto i0 = std::uint32_t(std::floor(t));
    const std::uint32_t i1 = std::min(i0 + 1, a.count - 1);
    return {i0, i1, t - i0};
}

}  // namespace

bool lookup_zero_region(AoWeighting weighting, double visibility, double n_dot_l) {
    const float v = float(visibility), l = float(n_dot_l);
    if (l <= 0.0f) return true;
    if (weighting == AoWeighting::cosine) return 2.0f * v + l <= 1.0f;
    const float cos_t = 1.0f - v;
    return l + 1.0f <= 2.0f * cos_t * cos_t;
}

LutLookup::LutLookup(LutFile lut) : lut_(std::move(lut)) {
    if (lut_.axes.size() != 3 || lut_.channels.empty())
        throw std::runtime_error("LUT: need the visibility, n_dot_l and n_dot_v axes and at least one channel");
    order_.resize(lut_.channels.size());
    std::iota(order_.begin(), order_.end(), 0u);
    std::stable_sort(order_.begin(), order_.end(),
                     [&](auto a, auto b) { return lut_.channels[a].roughness < lut_.channels[b].roughness; });
    for (std::size_t k = 1; k < order_.size(); ++k)
        if (lut_.channels[order_[k]].roughness == lut_.channels[order_[k - 1]].roughness)
            throw std::runtime_error("LUT: two channels hold the same roughness");
    // A LUT fitted to one scene's lookups records their ranges as a "refused" domain: outside them
    // clamp-to-edge would answer with an edge texel that no lookup of that scene asked for.
    if (lut_.metadata.is_object() && lut_.metadata.contains("domain")) {
        domain_ = LookupDomain::from_json(lut_.metadata.at("domain"), "LUT");
    } else {
        domain_ = lut_domain(lut_.axes, lut_.channels);
    }
    // The zero region the lookup answers 0 in is the weighting's the LUT was baked with (the shader
    // generator reads the same field and refuses the same values).
    const std::string weighting = lut_.metadata.is_object() ? lut_.metadata.value("ao_weighting", std::string("cosine")) : "cosine";
    if (weighting == "uniform") weighting_ = AoWeighting::uniform;
    else if (weighting != "cosine") throw std::runtime_error("LUT: unknown ao_weighting '" + weighting + "'");
}

LutLookup LutLookup::open(const std::string& path) {
    try {
        return LutLookup(read_lut(path));
    } catch (const std::exception& e) {
        const std::string what = e.what();
        // read_lut already names the file; add it only where a check here failed.
        throw std::runtime_error(what.find(path) == std::string::npos ? path + ": " + what : what);
    }
}

double LutLookup::operator()(double visibility, double n_dot_l, double n_dot_v, double roughness) const {
    if (domain_.refuse_outside && !domain_.contains(visibility, n_dot_l, n_dot_v, roughness))
        throw std::domain_error("LUT lookup at " + domain_.first_outside(visibility, n_dot_l, n_dot_v, roughness) +
                                ", the range of the scene this LUT was fitted to (\"domain\" in its metadata)");
    // The shaders' early-out, before any texel is read (the header says why).
    if (lookup_zero_region(weighting_, visibility, n_dot_l)) return 0;
    const double value = blend(visibility, n_dot_l, n_dot_v, roughness);
    // Only a partial bake's unbaked texels are NaN (read_lut checks them against the file's coverage
    // record): a lookup whose filter footprint touches one is refused, never answered.
    if (std::isnan(value))
        throw std::domain_error("LUT lookup at visibility " + std::to_string(visibility) + ", NdotL " + std::to_string(n_dot_l) +
                                ", NdotV " + std::to_string(n_dot_v) + ", roughness " + std::to_string(roughness) +
                                " touches texels this partial bake did not bake (see \"coverage\" in its metadata)");
    return value;
}

double LutLookup::blend(double visibility, double n_dot_l, double n_dot_v, double roughness) const {
    const Tap tv = tap(lut_.visibility(), visibility);
    const Tap tl = tap(lut_.n_dot_l(), n_dot_l);
    const Tap tz = tap(lut_.n_dot_v(), n_dot_v);  // one slice (2D LUT): always slice 0
    auto sample = [&](std::uint32_t c) {
        auto row = [&](std::uint32_t il, std::uint32_t iz) {
            return (1 - tv.f) * lut_.at(c, tv.i0, il, iz) + tv.f * lut_.at(c, tv.i1, il, iz);
        };
        auto slice = [&](std::uint32_t iz) { return (1 - tl.f) * row(tl.i0, iz) + tl.f * row(tl.i1, iz); };
        return (1 - tz.f) * slice(tz.i0) + tz.f * slice(tz.i1);
    };
    // Roughness: clamp to the channel range, then blend the bracketing channels.
    const auto& ch = lut_.channels;
    if (order_.size() == 1 || roughness <= ch[order_.front()].roughness) return sample(order_.front());
    if (roughness >= ch[order_.back()].roughness) return sample(order_.back());
    std::size_t k = 1;
    while (ch[order_[k]].roughness < roughness) ++k;
    const double r0 = ch[order_[k - 1]].roughness, r1 = ch[order_[k]].roughness;
    const double f = (roughness - r0) / (r1 - r0);
    return (1 - f) * sample(order_[k - 1]) + f * sample(order_[k]);
}

}  // namespace ms
