// The closed-form approximation (fit/closed_form.hpp) as a design candidate: its fit to a cached
// reference set and its cost, bake and shader.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "fit/closed_form.hpp"
#include "jobs/design.hpp"
#include "jobs/reference_set.hpp"

namespace ms::design {

// Fits the order's coefficients to the set, minimising sum_i w_i (S(z_i) - term_i)^2 with
// w_i = weight_i x max(NdotL_i, 0): a linear least-squares start on S^-1 of the term (clamped to
// [0.005, 0.995], where S^-1 is finite) refined by at most 50 Gauss-Newton steps. The provenance
// records the set (name, hash, points), the fit's weighted RMS and max error on it, and the steps.
// Points in the provable zero region (fit::closed_form_zero_region) are left out: the form answers 0
// there exactly. The provenance also records the form's domain (the training region, region_of, as
// core/lookup_domain.hpp's "domain") and its max error over that region found by search
// (search_max_error, below), which is what "max_abs" states; fit_max_abs is the max over the training
// points only.
fit::ClosedForm fit_closed_form(const ReferenceSet& training, unsigned order);

// The region a closed form is judged over: box ranges of its inputs (relative azimuth in radians).
struct SearchRegion {
    double visibility_min = 0, visibility_max = 1, n_dot_l_min = 0, n_dot_l_max = 1;
    double n_dot_v_min = 0, n_dot_v_max = 1, roughness_min = 0.1, roughness_max = 1;
    double azimuth_min = 0, azimuth_max = 3.14159265358979323846;
};
// A generated set's region (its definition's ranges, when every point lies in them), else the bounding
// box of its points.
SearchRegion region_of(const ReferenceSet& set);

struct SearchedMax {
    double max_abs = 0;  // the largest |form - term| found
    double visibility = 0, n_dot_l = 0, n_dot_v = 0, roughness = 0, relative_azimuth = 0, term = 0;
    std::size_t starts = 0, evaluations = 0;
};
// The largest |form - term| over the region, found by local optimisation (Nelder-Mead on the five
// inputs scaled to the unit box, clamped to it) from `starts` points: the `starts / 4` points of `seeds`
// where the error is largest, the rest uniform in the region (fixed seed). The term is the exact
// evaluator's at tolerance 1e-9, far below any error a closed form makes. A lower bound of the true
// max, but one that follows the error between training points, where a max over them cannot look.
SearchedMax search_max_error(const fit::ClosedForm& form, const SearchRegion& region, const std::vector<ReferencePoint>& seeds,
                             std::size_t starts = 256, std::uint64_t seed = 1);
// The same search for any lookup of (visibility, NdotL, NdotV, roughness, relative azimuth), judged
// against the exact term of `weighting` (a representation's lookup, say).
using LookupFunction = std::function<double(double visibility, double n_dot_l, double n_dot_v, double roughness, double azimuth)>;
SearchedMax search_max_error(const LookupFunction& lookup, AoWeighting weighting, const SearchRegion& region,
                             const std::vector<ReferencePoint>& seeds, std::size_t starts = 256, std::uint64_t seed = 1);

// The candidate "closed-form-K": 0 bytes, 0 fetches, ALU counted from its GLSL; bake() writes the
// coefficients JSON and the GLSL and HLSL. `file` (when read from one) goes into the provenance.
Candidate closed_form_candidate(const fit::ClosedForm& form, const std::string& file);

}  // namespace ms::design
