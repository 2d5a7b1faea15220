// Image-based lighting integrals (included by <microshadow/microshadow.hpp>): the split-sum DFG LUT,
// as `microshadow ibl dfg` bakes it (docs/ibl.md).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "microshadow/types.hpp"

namespace microshadow {

struct DfgOptions {
    std::uint32_t size = 64;                 // texels on both axes unless their own count is set
    std::uint32_t n_dot_v_count = 0, roughness_count = 0;  // 0: size
    std::string texel = "centres";           // "centres" (i + 0.5) / n or "endpoints" i / (n - 1)
    std::uint64_t samples = 65536;           // per texel, rounded up to replicates x a power of two
    std::uint32_t replicates = 8;
    std::uint64_t seed = 0;
    Backend backend = Backend::opencl;       // oracle: the quadrature on CPU threads
    std::string device = "default";
    bool fast_math = false;
};

// The DFG LUT: x = NdotV, y = roughness (alpha = roughness^2); per texel the split-sum scale, bias and
// the single-scattering albedo E = scale + bias, each with its standard error.
class DfgLut {
public:
    std::uint32_t n_dot_v_count() const;
    std::uint32_t roughness_count() const;
    std::vector<double> n_dot_v_values() const;
    std::vector<double> roughness_values() const;
    // [roughness][n_dot_v][3]: scale, bias, E; and their standard errors alike.
    std::vector<double> values() const;
    std::vector<double> std_errors() const;
    std::string metadata_json() const;
    // .exr, .ktx2, .dds (+ .dds.json) or .h, as `ibl dfg --out`; half: float16 texels.
    void save(const std::string& path, bool half = false) const;

    struct Data;
    explicit DfgLut(std::shared_ptr<const Data> data);

private:
    std::shared_ptr<const Data> data_;
};

// `progress` is told (texels done, texels) and may stop the bake.
DfgLut bake_dfg(const DfgOptions& options = {}, const Progress& progress = {});

}  // namespace microshadow
