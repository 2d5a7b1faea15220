// The reference data set of `microshadow design`: the generic term with its standard error
// at a weighted set of (visibility, NdotL, NdotV, roughness, relative azimuth) points, computed once
// and cached in a file keyed by a hash of its definition.
//
// A definition is either a region sampled by a randomly shifted Halton sequence (a low-discrepancy
// set: the RMS of an error over the region converges faster than with random points), or the points
// of a CSV file with a weight column (a scene's parameter histogram, a study grid). Errors are then
// weighted by weight x NdotL (the lighting multiplies the term by NdotL).
//
// Cache layout in the cache directory (a definition's hash H is FNV-1a 64 of canonical_text()):
//   reference-H.csv          the finished set: the points and term,std_error (written with its sidecar
//   reference-H.json         atomically, together or not at all; the JSON holds the definition text
//                            and the CSV's row count and digest)
//   reference-H.chunks/      while computing: chunk-NNNNNN.csv, each written atomically once its
//                            points are evaluated, its last line the digest of its rows; a resumed run
//                            computes only the missing chunks and the folder is removed once the
//                            finished set is written.
//   reference-H.lock         held (flock) by the run computing the set (not by shards: they share the
//                            chunk folder, each with its manifest.shard-I-of-N.json, the chunk store's).
//   rejected/                damaged files, set aside with the reason as a suffix.
// A changed definition (points, region, sampling, form, AO weighting, backend) has another hash, so a
// cache never answers for another definition.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "jobs/eval.hpp"
#include "schedule/cache_key.hpp"
#include "schedule/distributed.hpp"

namespace ms::design {

struct ReferencePoint {
    double visibility = 1, n_dot_l = 1, n_dot_v = 1, roughness = 0.5;
    double relative_azimuth = 0;  // radians in [0, pi]
    double weight = 1;            // the point's weight before NdotL (a histogram count, a cell area)
};

struct Interval {
    double lo = 0, hi = 1;
};

struct ReferenceDefinition {
    std::string name = "reference";
    // Generated region (used when points_csv is empty). NdotL is drawn in (lo, hi]: a light on the
    // horizon has weight 0 anyway.
    Interval visibility{0.5, 0.98}, roughness{0.3, 0.9}, n_dot_v{0.2, 1}, n_dot_l{0, 1}, azimuth_deg{0, 180};
    std::uint64_t count = 4096;
    std::uint64_t point_seed = 1;
    // Or the points of a CSV file: visibility,n_dot_l,n_dot_v,roughness,relative_azimuth_deg,weight.
    std::string points_csv;
    std::vector<ReferencePoint> csv_points;  // read by parse_reference_spec
    SamplingPlan plan;
    TermOptions options;
    std::string backend_label = "opencl";  // other backends give other bits: part of the hash
    ocl::BuildConfig build;                // the kernels' build (--fast-math, --double-kernels): part of the hash

    // The set's cache key (schedule/cache_key.hpp): every field above that decides the cached values
    // (the CSV's points by their exact values); the fields left out, each with the reason:
    // cache_key_exclusions(). hash(): the key's 16 hex digits, which name the cached file.
    schedule::CacheKey cache_key() const;
    static const std::vector<std::string>& cache_key_exclusions();
    std::string canonical_text() const;
    std::string hash() const;
};

// Throws std::invalid_argument naming the file and key (unknown keys, bad ranges, bad CSV rows with
// line and column). The CSV path is relative to the spec's folder.
ReferenceDefinition parse_reference_spec(const std::string& toml_text, const std::string& source_name,
                                         const std::string& base_dir);
ReferenceDefinition parse_reference_spec_file(const std::string& path);
// The points of a CSV (columns above, any order); throws CsvError / std::invalid_argument with line and column.
std::vector<ReferencePoint> read_reference_points_csv(const std::string& path);

// The definition's points, in a fixed order.
std::vector<ReferencePoint> reference_points(const ReferenceDefinition& def);
// The query of a point: isotropic alpha = roughness^2, wi = (sin theta_v, 0, NdotV), wo at the
// relative azimuth from wi's plane.
Query query_of(const ReferencePoint& p);

struct ReferenceSet {
    ReferenceDefinition definition;
    std::vector<ReferencePoint> points;
    std::vector<Estimate> values;
    std::string file;  // the cached CSV
    double max_std_error = 0, rms_std_error = 0;
};

struct CacheConfig {
    std::string dir;
    TermBackend* backend = nullptr;  // needed only when something is missing
    std::size_t chunk_points = 1024;
    std::uint64_t max_chunks = 0;  // > 0: compute at most this many chunks, then throw IncompleteReference
    std::string command_line;
    std::function<void(std::size_t, std::size_t)> progress;  // (points done, points)
    // Opens a backend when `backend` is null and something has to be computed after all (a damaged
    // cache file set aside); null: then that is an error naming the file.
    std::function<TermBackend*()> open_backend;
    // Damaged files set aside and waits for another run's lock, as they happen.
    std::function<void(const std::string&)> warn;
    // Beyond one process (docs/cluster.md): the chunks of one shard (kept in the chunk folder, which
    // every shard of the definition shares), the merge of the shards' chunks, or an MPI world (rank 0
    // hands the chunks out and writes the set; the other ranks compute and touch no file).
    schedule::Shard shard;
    bool merge = false;
    schedule::ItemTransport* transport = nullptr;
};

struct CacheReport {
    bool from_cache = false;                // the finished file was there
    std::size_t chunks_found = 0, chunks_computed = 0;
    double seconds = 0;
    std::vector<std::string> warnings;  // damaged files set aside (each named, with where it went)
    // false: this process holds only some chunks (a shard, or an MPI rank other than 0): the set is not
    // whole here and was not written.
    bool complete = true;
    std::string chunk_folder;           // where the chunks were kept
};

// Stopped by CacheConfig::max_chunks before the set was complete (the chunks so far are kept).
class IncompleteReference : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Loads the cached set, or computes what is missing (resuming from finished chunks) and caches it.
// Every file read is checked first: its digest (the finished CSV's is in its JSON sidecar, a chunk's is
// its last line), every row being the definition's point, term and std_error in [0, 1]. A damaged
// file is moved to DIR/rejected/ (named in the report's warnings) and its points computed again.
// While computing, DIR/reference-H.lock is held: a second run on the same definition waits for the
// first and then reads its finished file. Throws std::invalid_argument before touching the cache for
// a sampling plan that cannot be used, ms::Cancelled when interrupted (finished chunks stay).
void check_plan(const ReferenceDefinition& def);
ReferenceSet load_or_compute(const ReferenceDefinition& def, const CacheConfig& config, CacheReport* report = nullptr);

// The cache file of a definition in `dir`.
std::string cache_file(const ReferenceDefinition& def, const std::string& dir);

}  // namespace ms::design
