// Area-light queries and sampling plans shared by the area-light tests: a sphere light by elevation and
// azimuth, the t-quantile bar of two replicate estimates, and whether an OpenCL device is present.
#pragma once

#include <cmath>
#include <cstdint>
#include <exception>

#include "core/area_light.hpp"
#include "core/estimate.hpp"
#include "device/runtime.hpp"

namespace ms::testing {

inline constexpr std::uint32_t kReplicates = 8;

// Half-width of a two-sided 99.9 % family-wise interval for the difference of two replicate means with
// standard errors se_a and se_b, Bonferroni over `comparisons`.
inline double bar(double se_a, double se_b, int comparisons) {
    return student_t_quantile(1.0 - (1.0 - 0.999) / comparisons, int(kReplicates) - 1) * std::hypot(se_a, se_b);
}

inline SamplingPlan plan(std::uint64_t samples, std::uint64_t seed = 1) {
    SamplingPlan p;
    p.samples = samples;
    p.replicates = kReplicates;
    p.seed = seed;
    return p;
}

// The unit direction at elevation_deg above the horizon, azimuth_deg from +x.
inline Vec3 direction_deg(double elevation_deg, double azimuth_deg) {
    const double e = area::radians(elevation_deg), a = area::radians(azimuth_deg);
    return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

// A sphere light of half-angle gamma_deg centred at (elevation, azimuth), seen from NdotV in the xz plane.
inline area::AreaQuery sphere(double v, double alpha, double n_dot_v, double elevation, double azimuth, double gamma_deg,
                              area::Lobe lobe) {
    area::AreaQuery q;
    q.visibility = v;
    q.alpha_x = q.alpha_y = alpha;
    q.wi = {std::sqrt(1 - n_dot_v * n_dot_v), 0, n_dot_v};
    q.light.shape = area::LightShape::sphere;
    q.light.sphere.centre = direction_deg(elevation, azimuth);
    q.light.sphere.half_angle = area::radians(gamma_deg);
    q.lobe = lobe;
    return q;
}

inline bool have_device() {
    try {
        return !ocl::select_devices("default").empty();
    } catch (const std::exception&) {
        return false;
    }
}

}  // namespace ms::testing
