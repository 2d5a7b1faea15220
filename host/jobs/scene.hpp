// `microshadow scene` as a job: the reference micro-shadowing term of every pixel of a scene
// (host/scene/) under each light, by VNDF sampling to a per-pixel tolerance, the same term from each
// approximation (part 1's analytic terms, the seed's 3D and 2D LUTs baked on the fly, LUT files), and
// the errors as shading sees them.
//
// What is skipped, and counted (per pixel and light):
//   - masked pixels, and pixels whose view is below their shading normal's horizon (nothing to shade);
//   - exact answers classified in double on the host: a light at or below the horizon (0), the zero
//     region NdotL <= 2 cos_t^2 - 1 (0), v = 1 (1);
//   - duplicates: the remaining queries are keyed on a grid (below); each distinct key is sampled once,
//     at the grid point, through evaluate_each on the scheduler.
//
// The key grid. With tolerance E and step q (sampling.dedup_step, default 0.125), per pixel:
//   log alpha_x, log alpha_y   in steps of q E (a relative change of alpha of at most q E / 2);
//   the cone angle acos(cos_t), theta_v = acos(NdotV), theta_l = acos(NdotL), the relative azimuth
//   (anisotropic: the azimuths of wi and wo in the tangent frame)   in steps of s = q E alpha,
//   alpha = sqrt(alpha_x alpha_y) of the key.
// Why alpha in the angular step: the term is an average over the visible normals, whose angular spread
// is about alpha, of indicators whose boundaries move with these angles, so its slope in any of them is
// about C / alpha (C of order 1: the slope of a step smoothed over a width alpha). Moving an angle by
// at most s / 2 = q E alpha / 2 then changes the term by about C q E / 2 = E / 16 for C = 1: much less
// than the tolerance. The term's dependence on log alpha is of order 1, hence the step q E there. A test
// (tests/scene/scene_test.cpp) checks that images with and without deduplication, on the same points, agree
// within E / 4 on a varied scene (roughness 0.1 - 1); measured: max E / 8.5, RMS E / 40 (q = 0.25 gave
// max E / 3.9, so C is about 1.6 to 2: hence the default 0.125).
//
// Per-pixel tolerance: every key is sampled with min_samples, and keys whose error bound (Student t of
// the R replicates at 99.9 %, student_t_999(R), times the standard error) exceeds E are resampled with
// the samples predicted from that bound (at least 2x; scene.cpp), up to max_samples; keys still above
// are counted. R = 16 by default (docs/scenes.md). The first count of a query is predicted from its
// neighbours' final counts (sampling.predict_stride; scene.cpp).
//
// Tiles: pixels are classified, keyed and sampled sampling.tile_pixels at a time, so the working memory
// grows with the tile; the inputs and the output layers are what is held for the whole image.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error_stats.hpp"
#include "core/lookup_domain.hpp"
#include "jobs/eval.hpp"
#include "scene/inputs.hpp"
#include "schedule/cache_key.hpp"
#include "schedule/distributed.hpp"

namespace ms::scene {

struct SceneRunOptions {
    bool skip = true;                  // false: every unmasked pixel's own query is sent to the integrand
    double tolerance = 0;              // > 0 overrides the description's
    // Overrides sampling.method when set (the tolerance then defaults to that method's, unless given).
    bool method_given = false;
    Method method = Method::exact;
    std::vector<std::string> luts;     // more LUT files to compare
    bool bake_seed_luts = true;        // false: ignore comparators.seed_3d / seed_2d (tests)
    std::function<void(const std::string& phase, std::size_t done, std::size_t total)> progress;
    // Called once the comparators' names are known (LUT files opened), before any LUT bake or sampling:
    // the CLI checks its outputs here (check_scene_outputs), so a bad destination costs no work.
    std::function<void(const std::vector<std::string>& comparators)> check_outputs;
    // Refuse (SceneError, before any output) a comparator looked up outside its domain at a lit pixel.
    bool strict_domain = false;
    std::uint64_t memory_limit = 0;    // > 0: refuse (SceneError) when the output images would need more bytes
    // How the work items (scene_work_items) are split, kept and resumed (schedule/distributed.hpp; null:
    // all of them, here). A shard, or an MPI rank other than 0, computes its items into the store or
    // sends them to rank 0 and returns with complete false; the merge computes nothing.
    const schedule::ItemPlan* items = nullptr;
};

struct SkipCounts {
    std::uint64_t pixel_lights = 0;     // pixels x lights
    std::uint64_t masked = 0, view_below_horizon = 0, light_below_horizon = 0, zero_region = 0, v_one = 0;
    std::uint64_t duplicates = 0;       // pixels answered by another pixel's key
    std::uint64_t sampled = 0;          // distinct queries sampled
    std::uint64_t samples_drawn = 0;    // VNDF samples over every pass
    std::uint64_t samples_final = 0;    // the samples of each query's last pass: what a perfect prediction of
                                        // the count each query needs would draw (the passes are not nested)
    std::map<std::uint64_t, std::uint64_t> final_pass_queries;  // samples of the last pass -> sampled queries that stopped there
    std::uint64_t tolerance_missed = 0; // sampled queries whose bound stayed above the tolerance
    double skipped_fraction() const { return pixel_lights ? 1.0 - double(sampled) / double(pixel_lights) : 0; }
};

struct LightImages {
    std::string light;
    std::vector<float> reference, std_error, weight;       // weight = max(N.L, 0) x intensity
    std::vector<std::vector<float>> approximation, error;  // per comparator; error is weighted
    std::vector<std::vector<LitErrorSummary>> stats;       // [comparator][group], at its lit pixels
    double max_error_bound = 0;                            // t x std error, over the pixels
    double t = 5.408;                                      // the Student t factor used (student_t_999)
    double seconds = 0;
};

struct SceneResult {
    std::uint32_t width = 0, height = 0;
    std::vector<float> mask;                 // 1 shaded, 0 masked
    std::vector<std::string> comparators;
    // Per comparator: its domain (none for part 1's formulas), the lit pixel-lights it was looked up at
    // and how many fell outside the domain, and the first of those in words.
    std::vector<std::optional<LookupDomain>> domains;
    std::vector<DomainTally> outside_domain;
    std::vector<std::string> first_outside;
    std::vector<std::string> groups;         // "all", roughness bands, materials
    std::vector<LightImages> lights;
    SkipCounts counts;
    double tolerance = 0;
    double area_tolerance = 0;      // scenes with area lights: the per-pixel bound of T_area (0: none)
    Method method = Method::exact;  // how the per-pixel reference was computed
    double seconds = 0, lut_seconds = 0, sampling_seconds = 0;
    std::string backend;
    // False for a shard or a computing MPI rank (its items are in the store or with rank 0): the images
    // and statistics are then empty and nothing is to be written.
    bool complete = true;
    std::uint64_t loaded_items = 0, computed_items = 0;  // this process's: found in the store, computed
};

// The error bound factor of the reference: Student t at 99.9 % (two-sided) with R - 1 = 7 degrees of freedom.
inline constexpr double kStudentT999R8 = 5.408;
// The same for R = 8, 16, 32 or 64 replicates (sampling.replicates); throws std::invalid_argument otherwise.
double student_t_999(std::uint32_t replicates);

SceneResult run_scene(const SceneInputs& inputs, TermBackend& backend, const SceneRunOptions& options);

// The work items of a scene: one per light and tile of sampling.tile_pixels pixels, light by light
// (item id = light x tiles + tile). An item's result depends on the inputs and options alone, and the
// images and statistics are assembled from the items in id order, so a run split into shards or MPI
// ranks writes the same bytes as one process.
std::uint64_t scene_work_items(const SceneInputs& inputs);
// The cache key of a scene run (schedule/cache_key.hpp): everything that decides its items' bits (the
// description file, every pixel's surface, the options that reach the reference and the comparators,
// the bytes of the comparator files, the kernels' build, the kind of device, the version); the options
// left out, each with the reason: scene_cache_key_exclusions(). scene_store_key: its chunk store's key.
schedule::CacheKey scene_cache_key(const SceneInputs& inputs, const SceneRunOptions& options, TermBackend& backend);
const std::vector<std::string>& scene_cache_key_exclusions();
schedule::StoreKey scene_store_key(const SceneInputs& inputs, const SceneRunOptions& options, TermBackend& backend);

// The key of a query on the grid above, and the query at the key's grid point (tests use both).
struct DedupKey {
    std::int64_t ax = 0, ay = 0, cone = 0, tv = 0, tl = 0, pv = 0, pl = 0;
    bool operator==(const DedupKey& o) const {
        return ax == o.ax && ay == o.ay && cone == o.cone && tv == o.tv && tl == o.tl && pv == o.pv && pl == o.pl;
    }
};
DedupKey dedup_key(const Query& q, AoWeighting weighting, double step);  // step = q E
Query dedup_query(const DedupKey& key, AoWeighting weighting, double step);

// Writes DIR/scene.exr (every image as a layer), DIR/<light>_reference.png, DIR/<light>_<comparator>.png
// (reference | approximation | weighted error), DIR/report.json and DIR/report.md, all or none
// (io/atomic_file.hpp's OutputSet). DIR is created if missing (and removed again if nothing could be
// written to it). A previous run's outputs that this run does not write (other lights or comparators,
// read from the previous report.json) are removed once the new set is in place, so the folder never
// mixes two runs.
void write_scene_outputs(const SceneResult& result, const std::string& dir, const nlohmann::json& provenance);

// The files write_scene_outputs writes in DIR, and the layers of scene.exr, for these lights and
// comparators (names only, in writing order).
std::vector<std::string> scene_output_files(const std::vector<std::string>& lights, const std::vector<std::string>& comparators);
std::vector<std::string> scene_exr_layers(const std::vector<std::string>& lights, const std::vector<std::string>& comparators);
// Refuses (OutputError, exit status 2) before any work: two outputs or layers of the same name, a DIR
// that exists and is not a writable folder, or one that cannot be created (the nearest existing folder
// above it is not writable), an output name that exists as something other than a file. Creates nothing.
void check_scene_outputs(const std::string& dir, const std::vector<std::string>& lights, const std::vector<std::string>& comparators);
// A folder for outputs, as check_scene_outputs checks it: exists and writable, or can be created.
void check_output_folder(const std::string& dir);
nlohmann::json scene_report(const SceneResult& result);

}  // namespace ms::scene
