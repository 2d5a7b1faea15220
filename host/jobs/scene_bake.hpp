// `microshadow bake --scene SCENE.toml` as a job: the scene's domain decides the bake.
//
// 1. The domain. Every shaded pixel (inside the mask, view above its normal's horizon) lit by a light
//    (N.L > 0) is one lookup a renderer makes, at (visibility, NdotL, NdotV, roughness) with roughness
//    (alpha_x alpha_y)^(1/4) as LutLookup takes it; the relative azimuth is recorded too (the LUT
//    averages over it). Histograms of the five, per light, are what a person reads to see the domain.
// 2. The layout. Either the base layout (the seed-3d axes and roughness channels, or --layout custom)
//    with only what the lookups touch baked, or (fit, the default) a layout fitted to the data:
//      - roughness channels: the scene's distinct roughness values when there are at most 4 (a lookup
//        then hits a channel exactly: no blending error), else 4 evenly over [min, max] of the data;
//      - visibility, NdotL, NdotV: the endpoints convention over [min, max] of the data (both ends
//        sampled, so no lookup is clamped to a half texel), the base counts; an axis whose data are
//        constant gets one texel at that value.
// 3. What is baked. Every lookup's filter footprint, exactly as lookup.cpp computes it (the two taps of
//    each axis, the two bracketing roughness channels, even where a weight is 0, since 0 x NaN is NaN),
//    marks its (channel, NdotV slice, NdotL row). Only marked rows are sampled (LutSliceSpec::baked_rows);
//    a slice with none costs nothing. Rows are the unit because every texel of a row comes from the same
//    histogram pass of the lut_slice integrand: part of a row costs as much as the row.
// 4. Unbaked texels are NaN, and the file's "microshadow" metadata holds a coverage record
//    {"unbaked": "NaN", "rows": [[channel, n_dot_v index, first row, end row], ...], counts}. read_lut
//    checks that exactly the unrecorded rows are NaN, and LutLookup refuses (std::domain_error) any
//    lookup whose footprint touches one. Nothing unbaked can be blended in silently.
// 5. The comparison (optional, on by default): the full bake of the same layout (the time ratio, same
//    run, same scheduler), the default seed-3d LUT at the same samples, and the reference term by VNDF
//    sampling on a deterministic sample of the lookups: the error of both LUTs as shading sees it
//    (times N.L and the light's intensity), the azimuth-mean floor (what any LUT of the azimuth mean
//    misses on those lookups), and the verdict whether the default LUT serves the scene within a stated
//    error.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/error_stats.hpp"
#include "jobs/bake.hpp"
#include "jobs/eval.hpp"
#include "scene/inputs.hpp"

namespace ms::scene {

// Azimuth nodes of the azimuth-mean floor (trapezoid on [0, 180] degrees: 16 intervals).
inline constexpr std::uint32_t kAzimuthFloorNodes = 17;

// One lookup of a renderer: a shaded, lit pixel under one light.
struct SceneLookup {
    std::uint32_t pixel = 0;
    double visibility = 0, n_dot_l = 0, n_dot_v = 0, roughness = 0;  // exactly as the scene job looks LUTs up
    double azimuth_degrees = 0; // relative azimuth of V and L about the normal, [0, 180]
    double weight = 0;          // max(N.L, 0) x the light's intensity (point lights: / d^2)
};

struct Histogram {
    std::string name, unit;
    double min = 0, max = 1;                // the bins' range
    std::vector<std::uint64_t> counts;      // equal bins over [min, max]; the last bin includes max
    double data_min = 0, data_max = 0;      // of the values counted
    std::uint64_t total() const;
};

struct LightDomain {
    std::string light;
    std::vector<SceneLookup> lookups;
    std::uint64_t shaded = 0;               // shaded pixels (mask, view above the horizon)
    std::vector<Histogram> histograms;      // visibility, roughness, n_dot_v, n_dot_l, azimuth
};

// Every light's lookups and histograms (`bins` bins each).
std::vector<LightDomain> scene_domain(const SceneInputs& inputs, std::uint32_t bins = 32);

struct SceneBakePlan {
    BakeSpec spec;                          // with baked_rows set (empty: every row is touched)
    bool fitted = false;
    std::uint64_t rows = 0, baked_rows = 0; // (channel, slice, row) triples: all, and those baked
    std::uint64_t texels = 0, baked_texels = 0, touched_texels = 0;  // x channels; touched: in some footprint
    std::uint64_t slices = 0, baked_slices = 0;
    std::vector<std::uint32_t> channels_touched;   // channel indices some lookup reads
    // The lookups' ranges (visibility, NdotL, NdotV, roughness): a fitted LUT records them as its
    // "domain" and refuses lookups outside (lut/lookup.hpp).
    double domain_min[4] = {0, 0, 0, 0}, domain_max[4] = {0, 0, 0, 0};
};

// The layout and the rows to bake (see above). `base` gives the counts, the sampling and (fit false)
// the axes and channels. Throws std::invalid_argument when the scene has no lit pixel.
SceneBakePlan plan_scene_bake(const std::vector<LightDomain>& domain, const BakeSpec& base, bool fit);

// The coverage record of a partial bake for the file's metadata (read_lut's format).
nlohmann::json coverage_record(const SceneBakePlan& plan);
// The LUT's metadata: bake_metadata, the coverage record of a partial bake and, for a fitted layout,
// the "domain" record.
nlohmann::json scene_lut_metadata(const SceneBakePlan& plan, const BakeResult& bake);

struct SceneBakeOptions {
    bool fit = true;
    bool compare = true;                    // full bake, default LUT and reference on a sample
    std::uint32_t error_lookups = 2048;     // per light, the sample of lookups the reference is taken at
    std::uint64_t reference_samples = 65536;
    std::uint64_t azimuth_floor_samples = 16384;  // per azimuth node (0: no azimuth floor)
    double serve_error = 0.01;              // the verdict's threshold on the weighted error
    std::function<void(const std::string& phase, std::size_t done, std::size_t total)> progress;
    // How the scene bake's slices are split (schedule/distributed.hpp; null: all here): a shard or an
    // MPI rank other than 0 bakes its slices into the plan's store and returns with bake.complete false
    // (no comparison, nothing to write). Its store key: scene_bake_store_key().
    const schedule::ItemPlan* items = nullptr;
};

struct SceneBakeResult {
    SceneBakePlan plan;
    BakeResult bake;                        // the partial (scene) bake
    std::vector<LutChannel> channels;
    double full_seconds = 0;                // the full bake of the same layout (compare)
    // Work counts of the full bake (load-independent, unlike seconds on a shared machine): histogram
    // updates (samples x rows x azimuth nodes) and batches (one normals pass of every sample each).
    std::uint64_t full_histogram_updates = 0, full_batches = 0;
    double default_seconds = 0;             // the default seed-3d LUT (compare)
    double reference_seconds = 0;
    // Per light (compare): the errors of the scene LUT and the default LUT on the sampled lookups,
    // and the reference's own bound there (Student t at 99.9 % x its std error, max).
    struct LightErrors {
        std::string light;
        LitErrorSummary scene_lut, default_lut;
        double reference_bound = 0;
        // The azimuth-mean floor: |mean over the azimuth of the term - the term at the pixel's azimuth|,
        // at the same (v, alpha, NdotV, NdotL), on the isotropic sampled lookups: the error of a perfect
        // LUT that stores the azimuth mean (as every LUT here does), whatever its resolution. The mean is
        // the trapezoid rule on kAzimuthFloorNodes nodes over [0, 180] degrees, each node sampled with
        // azimuth_floor_samples; its bound is the largest t x (weighted sum of the nodes' std errors).
        LitErrorSummary azimuth_floor;
        double azimuth_floor_bound = 0;
    };
    std::vector<LightErrors> errors;
    std::uint64_t default_size = 32;
    bool default_serves = false;            // every light: default max + reference bound <= serve_error
    double serve_error = 0;
};

// Plans, bakes and compares on `backend`'s scheduler (the reference uses the backend's term routine).
SceneBakeResult run_scene_bake(const SceneInputs& inputs, const std::vector<LightDomain>& domain, const BakeSpec& base,
                               TermBackend& backend, const SceneBakeOptions& options);

// The chunk store key of the scene bake of `plan` (the slices of its partial bake).
schedule::StoreKey scene_bake_store_key(const SceneBakePlan& plan, const schedule::Scheduler& scheduler);

// The report as JSON and Markdown.
nlohmann::json scene_bake_report(const SceneBakeResult& result, const std::vector<LightDomain>& domain);
std::string scene_bake_markdown(const SceneBakeResult& result, const std::vector<LightDomain>& domain);

// Writes the LUT (OpenEXR, the coverage record in its metadata) and, in `report_dir` (created if
// missing), histograms.json, histograms.csv, histograms_<light>.png, report.json and report.md: all or
// none (io/atomic_file.hpp's OutputSet). A report folder this creates is removed again if nothing could
// be written; histograms_<light>.png of a previous run's other lights are removed after the new set is in place.
void write_scene_bake_outputs(const SceneBakeResult& result, const std::vector<LightDomain>& domain, const std::string& lut_path,
                              const std::string& report_dir, const nlohmann::json& provenance);

}  // namespace ms::scene
