// Enumeration of a sweep's points: a mixed-radix index over the parameter axes, so any chunk of
// points can be produced on its own (streaming, resume and shards need no global state).
#pragma once

#include <cstdint>

#include "core/types.hpp"
#include "jobs/sweep/spec.hpp"

namespace ms::sweep {

struct Point {
    std::uint64_t index = 0;
    Form form = Form::height_correlated;
    AoWeighting weighting = AoWeighting::cosine;
    // roughness: the swept value, or for (alpha_x, alpha_y) sweeps the isotropic equivalent
    // (alpha_x alpha_y)^(1/4), i.e. sqrt of the geometric-mean alpha (which keeps the area of the
    // slope distribution's footprint); LUT lookups, Activision's roughness and the per-roughness summary use it.
    double roughness = 0, alpha_x = 0, alpha_y = 0;
    double n_dot_v = 1, phi_i = 0, phi_o = 0, delta_phi = 0;  // degrees; delta_phi = phi_o - phi_i
    double n_dot_l = 1, visibility = 1;
};

// Axes, outermost first: form, ao_weighting, roughness (or alpha_x, then alpha_y), n_dot_v, phi_i,
// phi_o (or delta_phi), n_dot_l, visibility. Visibility varies fastest, as along a LUT row.
// `form` and `weighting` fill in when the spec leaves those axes empty (the CLI defaults).
class PointGrid {
public:
    PointGrid(const Spec& spec, Form default_form, AoWeighting default_weighting);
    std::uint64_t size() const { return size_; }
    Point at(std::uint64_t index) const;

private:
    const Spec& spec_;
    std::vector<Form> forms_;
    std::vector<AoWeighting> weightings_;
    std::uint64_t size_ = 1;
};

// The query of a point: wi = (sin theta_v cos phi_i, sin theta_v sin phi_i, NdotV),
// wo likewise with NdotL and phi_o.
Query to_query(const Point& p);

}  // namespace ms::sweep
