// The `microshadow ibl` commands as jobs that own their runs: each run(spec, callbacks) reads its
// inputs, checks every destination before the work, computes, verifies, and writes all of its files or
// none (a failed verification, an error or a cancellation leaves the previous files, and removes an
// output folder it made), and hands back the result; a summary function gives the lines the command
// prints. The CLI (cli/cmd_ibl.cpp) only turns flags into these specs and prints the summary. The
// numbers come from the jobs beneath: ibl_dfg.hpp, ibl_prefilter.hpp, ibl_irradiance.hpp, ibl_env.hpp.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "env/cubemap.hpp"
#include "jobs/ibl_dfg.hpp"
#include "jobs/ibl_env.hpp"
#include "jobs/ibl_irradiance.hpp"
#include "jobs/ibl_prefilter.hpp"
#include "jobs/job_callbacks.hpp"

namespace ms {

// An environment: one image (equirectangular 2:1, or a 4:3 / 3:4 cross; .exr or .hdr) or six square
// face files +X -X +Y -Y +Z -Z, exactly one of the two (check_environment throws std::invalid_argument).
struct EnvironmentFiles {
    std::string image;
    std::vector<std::string> faces;
};
void check_environment(const EnvironmentFiles& env);
// Its name in provenance: the image, or "faces PX NX PY NY PZ NZ".
std::string environment_name(const EnvironmentFiles& env);

// The output folder of `ibl prefilter` / `ibl irradiance`: checked when made (it is a folder, or can be
// made in a writable parent; else OutputError), created by make() once the inputs are read, and removed
// again on destruction, unless keep() was called, when the run made it (only empty folders go).
class OutputFolder {
public:
    explicit OutputFolder(std::string dir);
    ~OutputFolder();
    OutputFolder(const OutputFolder&) = delete;
    OutputFolder& operator=(const OutputFolder&) = delete;
    void make();
    void keep() { kept_ = true; }

private:
    std::string dir_;
    std::vector<std::string> to_make_, made_;  // deepest first
    bool kept_ = false;
};
// File names (no folder) of the first `count` entries of a set, for the stale-file checks.
std::set<std::string> names_in(const OutputSet& outputs, std::size_t count);

// --- ibl dfg ---------------------------------------------------------------------------------------------
struct DfgJobSpec {
    DfgBakeSpec bake;
    std::string out;                  // the LUT (formats: write_dfg_lut); empty: nothing is written
    std::string preview;              // also a PNG of the channels (write_dfg_preview), or empty
    std::string compare;              // a reference LUT of the same size to compare with, or empty
    std::uint32_t verify = 0;         // texels verify_dfg re-checks; a disagreement fails the run, writing nothing
    bool half = false;                // float16 texels
    std::string symbol = "microshadow_dfg";  // the array of a .h output
};
struct DfgJobResult {
    DfgBakeResult bake;
    nlohmann::json metadata;          // what the files record (with "verify" and "compare" when asked)
    std::optional<DfgVerification> verification;
    std::optional<DfgComparison> comparison;
};
DfgJobResult run_dfg_job(const DfgJobSpec& spec, const JobCallbacks& callbacks = {});
std::string dfg_job_summary(const DfgJobSpec& spec, const DfgJobResult& result);

// --- ibl sh ----------------------------------------------------------------------------------------------
struct ShJobSpec {
    EnvironmentFiles environment;
    std::string out;                  // JSON: coefficients, irradiance coefficients, provenance (required)
    std::string irradiance, preview;  // the irradiance cross (.exr) and its PNG, or empty
    std::string shader;               // shader constants (.glsl / .hlsl, named `symbol`), or empty
    std::string symbol = "microshadow_sh";
    std::uint32_t face_size = 32;
    std::string command_line;         // provenance
};
struct ShJobResult {
    IrradianceResult irradiance;
    std::uint32_t image_width = 0, image_height = 0;  // the image's size (0 for face files)
};
ShJobResult run_sh_job(const ShJobSpec& spec);
std::string sh_job_summary(const ShJobSpec& spec, const ShJobResult& result);

// --- ibl prefilter ---------------------------------------------------------------------------------------
struct PrefilterJobSpec {
    PrefilterSpec prefilter;          // its `source` is set by the run from `environment`
    EnvironmentFiles environment;
    std::uint32_t size = 0;           // base face size, a power of two (0: the source's)
    std::string out;                  // the output folder (created)
    // The specular chain's and the irradiance's files: by default one KTX2 cubemap with every mip (what
    // engines load, as cmgen writes it); "exr" for one cross per mip.
    std::string format = "ktx2", encoding = "float16";
    std::uint32_t verify = 0;         // texels verify_prefilter checks; outside their bars fails the run ...
    bool verify_report = false;       // ... unless the comparison is only to be recorded
    std::uint32_t irradiance_size = 32;
    std::uint32_t dfg_size = 0;       // > 0: also DIR/dfg.<format> (N x N, default settings) and its preview
    double exposure = 1.0;            // previews
};
struct PrefilterJobResult {
    PrefilterResult result;
    std::uint32_t source_size = 0;    // the face size the chain starts from
    nlohmann::json metadata;          // the chain's (ibl.json "specular")
    std::optional<PrefilterVerification> verification;
    IrradianceResult irradiance;      // order-2 SH of the source
    nlohmann::json irradiance_metadata;
    std::optional<DfgBakeResult> dfg;
};
PrefilterJobResult run_prefilter_job(const PrefilterJobSpec& spec, const JobCallbacks& callbacks = {});
std::string prefilter_job_summary(const PrefilterJobSpec& spec, const PrefilterJobResult& result);

// --- ibl irradiance --------------------------------------------------------------------------------------
struct IrradianceJobSpec {
    IrradianceMapSpec map;            // its `source` is set by the run from `environment`
    EnvironmentFiles environment;
    std::string out;                  // the output folder (created)
    std::string format = "exr", encoding = "float16";
    std::uint32_t verify = 0;         // texels verify_irradiance_map checks; one beyond its bound fails the run
    double exposure = 1.0;            // the preview's
};
struct IrradianceJobResult {
    IrradianceMapResult result;
    nlohmann::json metadata;
    std::optional<IrradianceVerification> verification;
    std::string reference;            // what --verify compared with, in words
};
IrradianceJobResult run_irradiance_job(const IrradianceJobSpec& spec, const JobCallbacks& callbacks = {});
std::string irradiance_job_summary(const IrradianceJobSpec& spec, const IrradianceJobResult& result);

}  // namespace ms
