// The scalar double oracle of the area-light term (core/area_light.hpp), written apart from the kernel
// (kernels/area_light/area_light.cl) with a different estimator, so that one mistake cannot pass both:
//
//     T_area ~= sum_j W_j T_j / sum_j W_j,
//
// an outer set of light directions wo_j drawn plainly from the light (uniform in solid angle on a
// sphere light's cone, uniform in area on a rectangle, no lobe sampling), W_j = f cos / density, and
// each T_j = T(wo_j) estimated on its own by this oracle's term (oracle.hpp: weights of the chosen
// Smith form kept, libm, compensated sums) over a set of inner VNDF points. Replicate r uses replicate
// r of both point sets, so the replicate spread covers the light and the normals alike. The inner
// ratio's bias is second order in the inner standard error (~1e-6 at 2^10 points), far below the bars.
#pragma once

#include "core/area_light.hpp"
#include "core/types.hpp"
#include "sampling/point_set.hpp"

namespace ms::oracle {

struct AreaTerm {
    Estimate term;           // T_area and its replicate standard error
    Estimate lobe_integral;  // Int_light f cos dwo over the directions above the horizon
};

// light_points and normal_points must have the same replicate count. Throws std::invalid_argument
// for invalid input (area::validate's rules).
AreaTerm area_term(const area::AreaQuery& q, const TermOptions& options, const PointSet& light_points,
                   const PointSet& normal_points);

// f(wi, wo) cos(wo) of the lobe (0 for wo at or below the horizon).
double lobe_weight(const area::AreaQuery& q, const Vec3& wo);

}  // namespace ms::oracle
