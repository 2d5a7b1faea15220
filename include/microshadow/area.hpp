// Area lights (included by <microshadow/microshadow.hpp>): the micro-shadowing term averaged over a
// sphere or rectangle light, as `microshadow area eval` computes it (docs/area-lights.md).
#pragma once

#include <array>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

enum class LightShape { sphere, rect };
// The BRDF lobe that weights the light's directions: GGX (Fresnel-free specular at the surface's
// alpha) or Lambert.
enum class Lobe { ggx, lambert };

// One shaded point and its light, in the tangent frame (normal +z): the columns of `area eval`'s CSV
// (light_direction: light_x, light_y, light_z) and the keywords of Python's area_eval.
struct AreaQuery {
    double visibility = 1;
    double alpha_x = 0.5, alpha_y = 0.5;
    Direction wi{0, 0, 1};
    LightShape light = LightShape::sphere;
    Direction light_direction{0, 0, 1};  // sphere: the direction to its centre
    double half_angle_deg = 10;          // sphere: its angular radius in degrees, in (0, 90)
    std::array<Direction, 4> corners{};  // rect: the corners in order, relative to the shaded point
};

struct AreaOptions {
    Lobe lobe = Lobe::ggx;
    // method sampled: the joint kernel on `backend`; exact: the exact inner term at each of `samples`
    // outer light directions on the host's threads (backend and device then do not apply).
    // samples 0: the method's default (sampled 65536, exact 8192); tolerance: the exact inner term's
    // (0: 1e-6), not taken by the sampled method.
    SamplingOptions sampling{Method::sampled, Backend::opencl, "default", 0};
};

struct AreaEstimate {
    double value = 0;
    double std_error = 0;    // the (outer) sampling's standard error
    double inner_error = 0;  // exact method: a bound on the inner values' part of the error; else 0
};

// T_area of each query, in order. std::invalid_argument naming the query index for a bad one.
// `progress` is told (queries done, queries) and may stop the call.
std::vector<AreaEstimate> area_evaluate(const std::vector<AreaQuery>& queries, const AreaOptions& options = {},
                                        const Progress& progress = {});

}  // namespace microshadow
