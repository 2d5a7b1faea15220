// Image-based lighting integrals (included by <microshadow/microshadow.hpp>), as `microshadow ibl`
// computes them (docs/ibl.md): the split-sum DFG LUT, the GGX-prefiltered specular cubemap, the
// irradiance cubemap by direct convolution and order-2 spherical harmonics.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

// `ibl dfg`'s options, with its defaults.
struct DfgOptions {
    std::uint32_t size = 64;                 // texels on both axes unless their own count is set
    std::uint32_t n_dot_v_count = 0, roughness_count = 0;  // 0: size
    std::string texel = "centres";           // "centres" (i + 0.5) / n or "endpoints" i / (n - 1)
    // "exact" (Gauss-Legendre, ~1e-12, host threads), "sampled" (the VNDF kernel with replicate error
    // bars) or "quadrature" (the independent check). backend = oracle is the older spelling of
    // "quadrature" (with method left "sampled").
    std::string method = "sampled";
    // 1-4 of scale, bias, E (= scale + bias), sheen (the cloth Charlie albedo), in the file's order.
    std::string channels = "scale,bias,E";
    std::string parameterization = "linear"; // the x axis: "linear" (NdotV) or "sqrt-n-dot-v" (x = sqrt(NdotV))
    std::uint64_t samples = 65536;           // sampled: per texel, rounded up to replicates x a power of two
    std::uint32_t replicates = 8;            // sampled
    std::uint64_t seed = 0;
    Backend backend = Backend::opencl;
    std::string device = "default";
    unsigned threads = 0;                    // exact / quadrature: host threads (0: all)
    bool fast_math = false;                  // sampled: the kernel built with relaxed math
};

// The DFG LUT: x = NdotV (or sqrt(NdotV)), y = roughness (alpha = roughness^2); per texel the channels
// asked for (default: the split-sum scale, bias and the single-scattering albedo E = scale + bias), each
// with its standard error (sampled) or error estimate (exact, quadrature).
class DfgLut {
public:
    std::uint32_t n_dot_v_count() const;
    std::uint32_t roughness_count() const;
    // The NdotV of each column (with sqrt-n-dot-v, the square of the texel coordinate) and the roughness
    // of each row.
    std::vector<double> n_dot_v_values() const;
    std::vector<double> roughness_values() const;
    // The channels' names in order ("scale", "bias", "E", "sheen").
    std::vector<std::string> channels() const;
    // [roughness][n_dot_v][channel]; and their standard errors alike.
    std::vector<double> values() const;
    std::vector<double> std_errors() const;
    std::string metadata_json() const;
    // .exr, .ktx2, .dds (+ .dds.json), .png (16-bit), .h or .inc, as `ibl dfg --out`; half: float16
    // texels; symbol: the array name of a .h file.
    void save(const std::string& path, bool half = false, const std::string& symbol = "microshadow_dfg") const;

    struct Data;
    explicit DfgLut(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

// `progress` is told (texels done, texels) and may stop the bake.
DfgLut bake_dfg(const DfgOptions& options = {}, const Progress& progress = {});

// An environment: one image (`image`: equirectangular 2:1, or a 4:3 / 3:4 cross; OpenEXR or Radiance
// .hdr) or six square face files (`faces`: +X -X +Y -Y +Z -Z), exactly one of the two.
struct EnvironmentSource {
    std::string image;
    std::vector<std::string> faces;
};

// A cubemap of RGB floats: faces +X -X +Y -Y +Z -Z, each size x size texels from the top row,
// laid out [face][y][x][3].
struct CubeImage {
    std::uint32_t size = 0;
    std::vector<float> texels;
};

// `ibl prefilter`'s options, with its defaults.
struct PrefilterOptions {
    EnvironmentSource environment;
    std::uint32_t size = 0;          // base face size, a power of two (0: the source's)
    std::uint32_t levels = 0;        // mips (0: down to 4 x 4 faces)
    std::string mapping = "cmgen";   // roughness per mip: "cmgen" or "linear"
    // Sample rounds until every texel's relative 95% error bar is at most this (docs/ibl.md); 0: `samples` per texel.
    double tolerance = 0.02;
    std::uint64_t samples = 256;     // GGX samples per texel (all replicates; the first round's with a tolerance), rounded up to replicates x 2^k
    std::uint64_t max_samples = 1u << 16;  // with a tolerance, at most this many per texel
    std::uint32_t replicates = 16;
    std::uint64_t seed = 0;
    bool fis = true;                 // filtered importance sampling; false (`--no-fis`): every sample read from the full-resolution source
    double lod_bias = 0;
    std::string bright = "auto";    // "auto": bright texels summed explicitly, chosen for the tolerance; "off"
    double bright_threshold = 0;     // > 0: sum texels brighter than this x the mean radiance explicitly (instead of bright's choice)
    double bright_min_roughness = 0;
    std::uint32_t wide_samples_factor = 1;
    std::uint64_t bright_max = 4096;
    std::string device;              // empty (Python: None, CLI: no --device): C++ on CPU threads; else OpenCL devices
    unsigned threads = 0;            // CPU threads (0: all)
    std::uint32_t verify = 0;        // > 0: compare this many random texels with the brute-force oracle; throws when one is outside its bars
    std::uint32_t irradiance_size = 32;  // the SH irradiance cubemap's face size
};

// The prefiltered chain (mip 0 is the source itself, roughness 0) and the SH irradiance beside it.
class PrefilteredEnvironment {
public:
    std::vector<double> mip_roughness() const;
    std::size_t mip_count() const;
    CubeImage mip(std::size_t m) const;
    CubeImage irradiance() const;        // E / pi from order-2 SH
    std::vector<double> sh() const;      // [9][3] radiance coefficients
    std::string metadata_json() const;   // ibl.json: {"specular": ..., "irradiance": ...}
    // Writes the command's files into DIR (created if missing), all or none: the chain (format "exr":
    // specular_m<m>.exr; "ktx2" / "dds": specular.<format>, encoding "float16" or "float32"),
    // irradiance.<format>, irradiance_preview.png, specular_preview.png, sh.json and ibl.json.
    void save(const std::string& dir, const std::string& format = "exr", const std::string& encoding = "float16",
              double exposure = 1.0) const;

    struct Data;
    explicit PrefilteredEnvironment(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

// `progress` is told (texels done, texels) and may stop the call.
PrefilteredEnvironment prefilter(const PrefilterOptions& options, const Progress& progress = {});

// `ibl irradiance`'s options, with its defaults.
struct IrradianceOptions {
    EnvironmentSource environment;
    std::uint32_t face_size = 32;      // output faces
    std::uint32_t source_size = 128;   // the reduced source the kernel convolves
    Backend backend = Backend::opencl; // oracle: the exact convolution of the full source, in double
    std::string device = "default";
    unsigned threads = 0;              // oracle threads (0: all)
    std::uint32_t verify = 0;          // > 0: check this many random texels against their bound (fails: runtime_error)
};

class IrradianceMap {
public:
    CubeImage map() const;     // E / pi
    CubeImage bound() const;   // a bound on |map - the exact E / pi of the full-resolution source|
    std::string metadata_json() const;  // irradiance.json
    // DIR/irradiance.<format> ("exr": a horizontal cross; "ktx2" / "dds": one cubemap level, encoding
    // "float16" or "float32"), irradiance.json and irradiance_preview.png, all or none.
    void save(const std::string& dir, const std::string& format = "exr", const std::string& encoding = "float16",
              double exposure = 1.0) const;

    struct Data;
    explicit IrradianceMap(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

IrradianceMap irradiance(const IrradianceOptions& options, const Progress& progress = {});

// `ibl sh`: order-2 spherical harmonics of an environment and the irradiance cubemap they give.
class ShIrradiance {
public:
    std::vector<double> sh() const;     // [9][3] radiance coefficients L_lm
    CubeImage irradiance() const;       // E / pi, face_size texels a side (none for face_size 0)
    std::string metadata_json() const;  // the command's JSON: coefficients, irradiance coefficients, provenance
    // The command's files, all or none: `json_path` (required) and, where given, the irradiance cross
    // (.exr), its preview (.png) and the shader constants (.glsl or .hlsl, named `symbol`).
    void save(const std::string& json_path, const std::string& irradiance_path = "", const std::string& preview_path = "",
              const std::string& shader_path = "", const std::string& symbol = "microshadow_sh") const;

    struct Data;
    explicit ShIrradiance(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

ShIrradiance spherical_harmonics(const EnvironmentSource& environment, std::uint32_t face_size = 32);

}  // namespace microshadow
