// `microshadow repr bake` as a job that owns its run: a representation baked (in one process, or split
// by roughness node over shards, a merge or an MPI world: docs/cluster.md), built, and written with its
// shaders, all or nothing. The CLI (cli/cmd_repr.cpp) turns flags into this spec and prints; the
// library's repr_bake (api/microshadow.cpp) runs it without outputs and keeps the representation.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "jobs/job_callbacks.hpp"
#include "jobs/repr_bake.hpp"
#include "lut/formats/texture_writer.hpp"
#include "jobs/tolerance_check.hpp"
#include "schedule/distributed.hpp"

namespace ms::repr {

// The representation file formats, by the path's extension (any case; lut/formats/texture_format.hpp):
// the OpenEXR atlas (what `eval --compare` and sweeps open), or the 3D texture alone as an engine loads
// it (KTX2, DDS + `<file>.json`). std::invalid_argument naming the path otherwise.
using ReprFormat = lutfmt::TextureFormat;
ReprFormat repr_format(const std::string& path);

// The outputs of one representation file in `outputs` (a DDS adds its metadata sidecar `<path>.json`).
class ReprFileOutput {
public:
    ReprFileOutput(OutputSet& outputs, const std::string& path);
    ReprFormat format() const { return files_.format; }
    // Writes the file into its temporary (16-bit channels when `half`, else 32-bit); all appear
    // together at outputs.commit().
    void write(OutputSet& outputs, const Representation& r, bool half) const;

private:
    lutfmt::TextureFiles files_;
};

struct ReprBakeJobSpec {
    std::string preset;                 // a named layout (repr/presets.hpp): kind, grid, nodes and domain; or empty
    std::string kind;                   // a custom layout's kind (representation_kinds())
    AzimuthBakeSpec bake;               // a custom layout's grid and nodes; the plan, the term and the provenance always
    std::uint32_t roughness_count = 0;  // > 0: keep this many of the grid's roughness nodes, chosen by error
    std::vector<double> domain_visibility{0, 1}, domain_n_dot_v{0, 1};  // a custom layout's domain
    // Outputs: none when `out` is empty (the library keeps the representation in memory).
    std::string out;
    std::string shader_glsl, shader_hlsl, shader_wgsl, shader_prefix;
    bool half_exr = false;              // EXR: HALF channels
    bool float_texture = false;         // KTX2, DDS: RGBA32F in place of RGBA16F
    bool distributed = false;           // split by roughness node through `distribution` (and OUT.chunks)
    schedule::DistributionRequest distribution;
    bool writer = true;                 // false on MPI ranks other than 0: they compute and touch no output
    std::function<std::unique_ptr<TermBackend>()> make_backend;
};

struct ReprBakeJobCallbacks : JobCallbacks {
    std::function<void(const std::string&)> warn;  // a stored item set aside (the message says what follows)
};

struct ReprBakeJobResult {
    AzimuthBake bake;                   // the texels and the metadata the file records
    std::shared_ptr<const Representation> representation;  // null when not complete here (a shard)
    bool written = false;
    std::string shard_note;             // what a finished shard did (when nothing was built)
    std::vector<double> chosen_roughness;  // roughness_count: the nodes kept
    double roughness_blend_rms = 0;     // roughness_count: the N.L-weighted RMS of their blend over the dense nodes
    // The stored texel x node values' estimated errors against the tolerance asked of them (the exact
    // method's, always; the sampled method's when given), recorded in the file's metadata as
    // tolerance_met and queries_over_tolerance. Empty (tolerance 0) on a shard that built nothing.
    ToleranceCheck tolerance;
};

// The checks of a spec before any work (std::invalid_argument with the reason).
void validate(const ReprBakeJobSpec& spec);
ReprBakeJobResult run_repr_bake_job(ReprBakeJobSpec spec, const ReprBakeJobCallbacks& callbacks = {});
// The lines the command prints unless --quiet (after any shard note); the last says whether the
// tolerance was met.
std::string repr_bake_job_summary(const ReprBakeJobSpec& spec, const ReprBakeJobResult& result);
// "R, N bytes (K KiB), F fetches and about A ALU operations per light" for summaries and `repr info`.
std::string cost_line(const Representation& r);

}  // namespace ms::repr
