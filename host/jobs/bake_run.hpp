// `microshadow bake` as jobs that own their runs: a LUT bake (one process, a shard of a Slurm array, a
// merge of a chunk store, or the ranks of an MPI world) with its memory check, verification, metadata,
// preview and files; and `bake --scene`, the bake of what a scene's lookups touch, with its report.
// Each run checks its destinations before the work and writes nothing when it fails or is cancelled;
// the summary functions give the lines the command prints. The CLI (cli/cmd_bake.cpp) only turns
// flags into these specs and prints; the LUT's file formats are its presentation (cli/bake_outputs.hpp),
// handed to the run as `write_lut`.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "jobs/bake.hpp"
#include "jobs/job_callbacks.hpp"
#include "jobs/scene_bake.hpp"
#include "jobs/verify.hpp"
#include "lut/exr_lut.hpp"
#include "schedule/distributed.hpp"

namespace ms {

struct BakeJobSpec {
    BakeSpec bake;
    std::string out;                    // the LUT (its chunk store defaults to OUT.chunks)
    std::string preview;                // also a PNG of the slices, or empty
    std::uint32_t verify = 0;           // texels verify_bake recomputes; a disagreement fails the run, writing nothing
    Method verify_method = Method::exact;
    schedule::DistributionRequest distribution;  // one process by default
    bool writer = true;                 // false on MPI ranks other than 0: they compute and touch no output
};

struct BakeJobResult {
    BakeResult bake;
    bool written = false;               // false: a shard (or an MPI rank other than 0) that wrote nothing
    std::string shard_note;             // what a finished shard did, and how to merge (when not written)
    nlohmann::json metadata;            // what the LUT records
    std::optional<BakeVerification> verification;
};

struct BakeJobCallbacks : JobCallbacks {
    std::function<void(const std::string&)> warn;  // something in the store set aside (the message says what follows)
};

// Runs the bake; `write_lut` writes the finished LUT file (its formats and shaders), after the preview.
BakeJobResult run_bake_job(const BakeJobSpec& spec, const std::function<void(const LutFile&)>& write_lut,
                           const BakeJobCallbacks& callbacks = {});
std::string bake_job_summary(const BakeJobSpec& spec, const BakeJobResult& result);

struct SceneBakeJobSpec {
    BakeSpec base;                      // the layout and sampling; its AO weighting and form come from the scene
    std::string scene;                  // the scene description (docs/scenes.md)
    std::string out;                    // the LUT (.exr; its coverage record in the metadata)
    std::string report;                 // the folder of the histograms and the report (created if missing)
    scene::SceneBakeOptions options;    // fit, compare, serve_error (progress and items: set by the run)
    schedule::DistributionRequest distribution;
    bool writer = true;
    std::string command_line;           // provenance
};

struct SceneBakeJobCallbacks {
    // (phase, done, total): the phases are the bakes and the reference, in turn.
    std::function<void(const std::string& phase, std::size_t done, std::size_t total)> progress;
    std::function<void(const std::string&)> warn;
};

struct SceneBakeJobResult {
    scene::SceneBakeResult result;
    bool written = false;
    std::string shard_note;
};

SceneBakeJobResult run_scene_bake_job(const SceneBakeJobSpec& spec, const SceneBakeJobCallbacks& callbacks = {});
std::string scene_bake_job_summary(const SceneBakeJobSpec& spec, const SceneBakeJobResult& result);

}  // namespace ms
