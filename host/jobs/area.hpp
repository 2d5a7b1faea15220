// `microshadow area eval | sweep` as jobs: the area-light integrand (integrands/area_light/) over a list
// of queries, and the study of what engines do instead (the term at one direction of the light) against
// it, with the tap approximation (below).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/area_light.hpp"
#include "core/types.hpp"
#include "integrands/area_light/area_light_integrand.hpp"
#include "jobs/eval.hpp"

namespace ms::area {

// Query files of `area eval`: the surface columns, then the light's.
extern const std::vector<std::string> kSphereColumns;  // visibility,alpha_x,alpha_y,wi_x,wi_y,wi_z,light_x,light_y,light_z,half_angle_deg
extern const std::vector<std::string> kRectColumns;    // ... p0_x,p0_y,p0_z,p1_x,...,p3_z
// Reads and validates every row (CsvError naming the file, line and column). lobe applies to every row.
// raw (optional): each row's numbers as written, for outputs that repeat the input columns.
std::vector<AreaQuery> read_area_csv(const std::string& path, LightShape shape, Lobe lobe,
                                     std::vector<std::vector<double>>* raw = nullptr);

struct AreaEvalStats {
    std::size_t sampled = 0, below_horizon = 0, zero_region = 0, visibility_one = 0, rerun = 0;
    double seconds = 0;
};

// T_area of every query on the backend's places (validated first; std::invalid_argument names a bad one).
std::vector<AreaEstimate> evaluate_area(TermBackend& backend, const std::vector<AreaQuery>& queries,
                                        const TermOptions& options, const SamplingPlan& plan,
                                        AreaRoutineConfig config = {}, AreaEvalStats* stats = nullptr,
                                        const std::function<void(std::size_t, std::size_t)>& progress = {});

// The exact inner term: T(wo) by the deterministic evaluator (exact/exact_term.hpp) to `tolerance`, with
// its estimated error, for AreaRoutineConfig::inner_term. The outer integral over the light stays
// sampled (the light sampler of the kernel, randomised replicates): T(wo) is continuous over a light
// but has kinks and square-root onsets (where the cone round wo meets the horizon or the view's cone,
// the zero region's edge), so a deterministic outer rule would converge slowly there and the
// difference of two rules would not bound its error, while the replicates' Student-t error stays
// honest whatever the integrand. With no inner noise the outer needs far fewer samples than the joint
// kernel (docs/area-lights.md, "The exact inner term").
InnerTerm exact_inner_term(AoWeighting weighting, double tolerance);
// Defaults of `area eval --method exact`: outer light directions per query and the inner tolerance.
inline constexpr std::uint64_t kExactOuterSamples = 8 * 1024;
inline constexpr double kExactInnerTolerance = 1e-6;

// The tap approximation of a sphere light: the point term at seven directions of a tap cone (Radon's
// degree-5 rule on the disc, mapped onto the cone by equal area: the centre with weight 1/4 and six
// directions at sqrt(2/3) of the cone's area radius, 1/8 each), each weighted by the rule's weight times
// the lobe's f cos there (0 below the horizon):  T_taps = sum_k w_k W_k T(wo_k) / sum_k w_k W_k.
// The tap cone is the light itself, except for a GGX lobe narrower than the light (reflected lobe
// radius 2 atan(2 alpha), which holds about 80 % of it, or, when the mirror direction R misses the light,
// the angle from R to the light, over which the lobe's tail falls off): then a cone of that radius around Karis's
// representative point, moved towards the light's centre until it lies inside the light. A renderer
// evaluates it with seven point lookups (LUT fetches) and the f cos it already computes.
struct Tap {
    Vec3 wo;
    double weight = 0;
};
struct TapCone {
    Vec3 centre;
    double half_angle = 0;
};
TapCone tap_cone(const AreaQuery& q);
std::vector<Tap> sphere_taps(const AreaQuery& q);
// The tap approximation of a rectangle light: the 3 x 3 Gauss-Legendre rule (degree 5 in each of the
// rectangle's two parameters) on a tap rectangle, each node weighted by the rule's weights, the solid
// angle per unit area there (|n.wo| / d^2) and the lobe's f cos: nine point lookups. The tap rectangle is
// the light itself, except for a GGX lobe narrower than the light (the lobe angle of tap_cone against the
// angle from the light's centre to its furthest corner): then a part of the light around Karis's
// representative point, of half-extent d tan(lobe) along each side (d the point's distance), moved to lie
// inside the light.
std::vector<Tap> rect_taps(const AreaQuery& q);

// One point of the representative-point study.
struct StudyPoint {
    AreaQuery query;
    double n_dot_v = 1, elevation_deg = 90, azimuth_deg = 0, roughness = 0.5, half_angle_deg = 10;  // as given
};
struct StudyRow {
    StudyPoint point;
    AreaEstimate area;
    Estimate centre, representative, taps;  // taps.std_error: from the taps' own errors (propagated)
    // taps: sphere lights sphere_taps, rectangles rect_taps.
};
// A grid (every combination) of sphere lights: the centre at elevation e and azimuth phi (from wi's
// azimuth 0), the view at NdotV, isotropic alpha = roughness^2.
struct StudyGrid {
    std::vector<Lobe> lobes{Lobe::lambert, Lobe::ggx};
    std::vector<double> half_angles_deg{1, 2, 5, 10, 15, 20, 30};
    std::vector<double> roughness{0.1, 0.3, 0.5, 0.7, 1.0};
    std::vector<double> visibility{0.3, 0.5, 0.7, 0.9};
    std::vector<double> n_dot_v{0.5};
    std::vector<double> elevations_deg{10, 30, 60, 90};
    std::vector<double> azimuths_deg{180};
};
std::vector<StudyPoint> grid_points(const StudyGrid& grid);
// Random sphere-light queries for the approximation's error: lobe, half-angle uniform in (0, max],
// roughness in [0.1, 1], visibility in [0.05, 0.98], NdotV in [0.1, 1], light elevation in [-max, 90]
// degrees (so some lights straddle the horizon), azimuth in [0, 360).
std::vector<StudyPoint> random_points(std::size_t count, double max_half_angle_deg, std::uint64_t seed);
// Random rectangle-light queries, the surface drawn as random_points draws it: the rectangle's centre at
// unit distance, elevation in [-gamma, 90] degrees, any azimuth; its normal tilted from the direction to
// it by up to 60 degrees (any way) and spun in its plane; sides in a ratio from 1:1 to 1:3; scaled so that
// the largest angle from its centre direction to a corner is gamma (half_angle_deg), uniform in (0, max].
std::vector<StudyPoint> random_rect_points(std::size_t count, double max_half_angle_deg, std::uint64_t seed);
// T_area, the point term at the centre and at the representative point, and the taps, for every point.
std::vector<StudyRow> run_study(TermBackend& backend, const std::vector<StudyPoint>& points, const TermOptions& options,
                                const SamplingPlan& plan, const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace ms::area
