#include "jobs/sweep/points.hpp"

#include "jobs/compare.hpp"

#include <cmath>
#include <stdexcept>

namespace ms::sweep {

PointGrid::PointGrid(const Spec& spec, Form default_form, AoWeighting default_weighting)
    : spec_(spec),
      forms_(spec.forms.empty() ? std::vector<Form>{default_form} : spec.forms),
      weightings_(spec.weightings.empty() ? std::vector<AoWeighting>{default_weighting} : spec.weightings) {
    for (std::size_t n : {forms_.size(), weightings_.size(),
                          spec.by_roughness ? spec.roughness.size() : spec.alpha_x.size() * spec.alpha_y.size(),
                          spec.n_dot_v.size(), spec.phi_i.size(), spec.phi_o_or_delta.size(), spec.n_dot_l.size(),
                          spec.visibility.size()}) {
        if (n == 0) throw std::invalid_argument("sweep: an empty parameter axis");
        if (size_ > UINT64_MAX / n) throw std::invalid_argument("sweep: the point count overflows 64 bits");
        size_ *= n;
    }
}

Point PointGrid::at(std::uint64_t index) const {
    if (index >= size_) throw std::out_of_range("sweep point index out of range");
    Point p;
    p.index = index;
    // Peel off the fastest axis first (mixed radix, visibility innermost).
    auto take = [&index](std::size_t n) {
        const std::size_t i = std::size_t(index % n);
        index /= n;
        return i;
    };
    p.visibility = spec_.visibility[take(spec_.visibility.size())];
    p.n_dot_l = spec_.n_dot_l[take(spec_.n_dot_l.size())];
    const double phi2 = spec_.phi_o_or_delta[take(spec_.phi_o_or_delta.size())];
    p.phi_i = spec_.phi_i[take(spec_.phi_i.size())];
    p.phi_o = spec_.relative_azimuth ? p.phi_i + phi2 : phi2;
    p.delta_phi = spec_.relative_azimuth ? phi2 : p.phi_o - p.phi_i;
    p.n_dot_v = spec_.n_dot_v[take(spec_.n_dot_v.size())];
    if (spec_.by_roughness) {
        p.roughness = spec_.roughness[take(spec_.roughness.size())];
        p.alpha_x = p.alpha_y = p.roughness * p.roughness;
    } else {
        p.alpha_y = spec_.alpha_y[take(spec_.alpha_y.size())];
        p.alpha_x = spec_.alpha_x[take(spec_.alpha_x.size())];
        p.roughness = approx::isotropic_roughness(p.alpha_x, p.alpha_y);
    }
    p.weighting = weightings_[take(weightings_.size())];
    p.form = forms_[take(forms_.size())];
    return p;
}

Query to_query(const Point& p) {
    constexpr double kDeg = M_PI / 180.0;
    auto dir = [](double cos_theta, double phi) {
        const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
        return Vec3{s * std::cos(phi), s * std::sin(phi), cos_theta};
    };
    Query q;
    q.visibility = p.visibility;
    q.alpha_x = p.alpha_x;
    q.alpha_y = p.alpha_y;
    q.wi = dir(p.n_dot_v, p.phi_i * kDeg);
    q.wo = dir(p.n_dot_l, p.phi_o * kDeg);
    return q;
}

}  // namespace ms::sweep
