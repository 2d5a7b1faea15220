// Running a sweep: chunked streaming to disk, resume, shards and merge, and the summary table.
//
// Output directory layout: the shared item store of every resumable job (schedule/chunk_store.hpp),
// chunk c of the sweep its item c (jobs/sweep/store.hpp):
//   items/item-XXXXXXXXXX.bin    finished chunks (their CSV rows, without header, sealed with the sweep's
//                                spec hash and digest), each written atomically; kept after assembly as the
//                                evidence sweep.csv was built from
//   items/rejected/              chunks found damaged (wrong seal, rows, point indices, fields or values),
//                                set aside and never read again; the run computes them anew
//   manifest.shard-I-of-N.json   the store's record of each shard (spec hash, chunk count, finished or not)
//   sweep-spec.json              what the chunks are: the spec, the CSV header, the counts, the sampling
//   sweep.csv                    every point, assembled from the chunks once all are finished
//   sweep.json                   provenance (command line, spec, sampling, backend, tolerance met)
//   summary.csv, summary.md      each comparator's error against the generic term
// Every shard writes into the same folder; `merge` (or sweep --merge) assembles it. Folders of the
// format before the item store are upgraded in place when read (jobs/sweep/store.hpp).
//
// Determinism: every point is evaluated with the same randomised point set (the plan's seed), so a
// point's value depends only on its parameters, the plan and the backend; never on the chunk it
// falls in, the chunk size or the shard layout. Chunks are written in one fixed text format, so
// the assembled sweep.csv is the same bytes whether the run was interrupted, resumed or sharded.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "core/error_stats.hpp"
#include "core/types.hpp"
#include "jobs/eval.hpp"
#include "jobs/tolerance_check.hpp"
#include "jobs/sweep/spec.hpp"
#include "schedule/cache_key.hpp"
#include "schedule/distributed.hpp"

namespace ms::sweep {

// This run does chunks c with c % count == index (the chunk store's shard).
using Shard = schedule::Shard;
// Parses "I/N" (0 <= I < N); throws std::invalid_argument.
Shard parse_shard(const std::string& text);

struct RunConfig {
    std::string out_dir;
    SamplingPlan plan;
    TermOptions defaults;  // form and weighting for specs that do not sweep them
    // Where the points are evaluated; its kind of place and its kernels' build are recorded and keyed
    // (other backends, --fast-math, --double-kernels give other bits).
    TermBackend* backend = nullptr;
    Shard shard;
    std::uint64_t max_chunks = 0;  // > 0: compute at most this many chunks in this run, then stop (resumable)
    bool restart = false;          // discard a previous run's manifest and chunks of another spec
    bool strict_domain = false;    // refuse (std::invalid_argument, nothing written) a comparator file looked up outside its domain
    std::string command_line;
    // Told of each damaged chunk as it is set aside (also listed in RunResult::warnings).
    std::function<void(const std::string&)> warn;
    // Called after each chunk: (chunks done in this shard, chunks of this shard).
    std::function<void(std::uint64_t, std::uint64_t)> progress;
    // An MPI world (schedule/distributed.hpp): rank 0 hands the unfinished chunks out, writes each one
    // that comes back and assembles sweep.csv; the other ranks compute and touch no file. Not with shards.
    schedule::ItemTransport* transport = nullptr;
};

struct RunResult {
    std::uint64_t points = 0, chunks = 0;          // of the whole sweep
    std::uint64_t shard_chunks = 0;                // of this shard
    std::uint64_t computed = 0, skipped = 0;       // chunks computed in this run, found finished
    bool complete = false;                         // every chunk of this shard is finished
    std::vector<std::string> warnings_outside_domain;  // per comparator file with lookups outside its domain
    bool assembled = false;                        // sweep.csv written (unsharded runs)
    std::string spec_hash;
    std::vector<std::string> warnings;             // chunks found damaged, set aside and computed again
    ToleranceCheck tolerance;                      // of the assembled points' estimated errors (assembled runs)
};

// The CSV header of a sweep's output.
std::string csv_header(const Spec& spec);

// Opens every [[comparators.lut]] file as the sweep will: std::invalid_argument naming the spec, the
// comparator and the file when one cannot be used (call it before starting a backend).
void check_comparator_files(const Spec& spec);

// Runs (or resumes) the sweep. Throws ms::Cancelled when ms::cancel_requested() is set (finished
// chunks stay on disk), std::invalid_argument for a spec/out-dir mismatch, std::runtime_error on I/O.
RunResult run_sweep(const Spec& spec, const RunConfig& config);

// The sweep's cache key (schedule/cache_key.hpp), recorded in its manifests as spec_hash: every value
// of the spec and the run that decides a chunk's bits (the points, the comparators and their files'
// bytes, the chunk size, the sampling plan, the default term options, the backend's kind of place and
// kernel build, the version); the fields left out, each with the reason: sweep_cache_key_exclusions().
// A run whose key differs from a manifest's in its folder is refused (or, with restart, starts over).
schedule::CacheKey sweep_cache_key(const Spec& spec, const RunConfig& config);
const std::vector<std::string>& sweep_cache_key_exclusions();

struct MergeResult {
    std::string spec_hash;
    std::uint64_t points = 0, chunks = 0;
    ToleranceCheck tolerance;  // of the merged points' estimated errors
};

// Assembles the sweep whose shards ran into `shard_dirs` (one folder every shard shared, or one folder a
// shard; old-format folders are upgraded first) into out_dir/sweep.csv plus summary, byte-identical to an
// unsharded run, through the shared item store's merge: `microshadow merge` and `sweep --merge` both call
// it. Several folders are gathered into out_dir's own store first (their sound chunks copied there).
// expected_spec_hash (sweep --merge): the folders must hold that sweep. Throws std::invalid_argument when
// shards are missing, duplicated, unfinished, damaged or of different sweeps: then no output is written
// (and an out_dir the merge created is removed).
MergeResult merge_shards(const std::vector<std::string>& shard_dirs, const std::string& out_dir, const std::string& command_line,
                         const std::string& expected_spec_hash = "", const std::function<void(const std::string&)>& warn = {});

// Each comparator's error against the generic term (comparator - term), unweighted: count, max |e|,
// mean |e|, RMS and bias (core/error_stats.hpp), over all points and per roughness.
struct Summary {
    std::vector<std::string> comparators;
    GroupedErrorStats errors;                        // [comparator][group]: group 0 all points, then each roughness
    std::map<double, std::size_t> roughness_groups;  // roughness -> its group, ascending
    double max_std_error = 0;
    std::uint64_t points = 0;
    ToleranceCheck tolerance;  // each point's std_error against the tolerance (none: 0)
};

// Streams a sweep CSV (header + rows) into the summary; bounded memory. tolerance > 0: each point's
// estimated error is held to it (Summary::tolerance).
Summary summarise(std::istream& csv, const std::string& name, double tolerance = 0);
// Markdown table (stdout, summary.md) and CSV (summary.csv) forms.
std::string summary_markdown(const Summary& s);
std::string summary_csv(const Summary& s);

}  // namespace ms::sweep
