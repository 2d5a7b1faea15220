// Environment jobs of `microshadow ibl`: order-2 SH and the irradiance cubemap of an equirectangular
// environment (host/env/ holds the mappings, SH and file formats).
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/sh.hpp"

namespace ms {

struct IrradianceResult {
    env::Sh9 sh{};                 // radiance coefficients L_lm
    env::Image irradiance_cross;   // E / pi on a horizontal cross (4n x 3n; empty when face_size = 0)
    std::uint32_t face_size = 0;
    // SH irradiance against brute-force irradiance of the same image at 26 normals (cube faces, edges,
    // corners): max |E_sh - E_bf| / max E_bf over channels. Order 2 keeps 0.6% or better of a smooth sky
    // (Ramamoorthi & Hanrahan) but not of a sun; this number says which case a file is.
    double max_relative_sh_error = 0;
};

// Horizontal cross layout: row 0 holds +Y above +Z, row 1 -X +Z +X -Z, row 2 -Y below +Z.
void cross_face_origin(int face, std::uint32_t n, std::uint32_t& x, std::uint32_t& y);

IrradianceResult compute_irradiance(const env::Image& equirect, std::uint32_t face_size);
IrradianceResult compute_irradiance(const env::Cubemap& cube, std::uint32_t face_size);
nlohmann::json irradiance_metadata(const IrradianceResult& r, const std::string& source, const std::string& command_line);

// The order-2 irradiance as shader constants (the form of cmgen's --sh-shader and Filament's
// Irradiance_SphericalHarmonics): E(n) / pi = max(0, sum_k K_k P_k(n)) with the polynomials
// P = (1, y, z, x, xy, yz, 3 z^2 - 1, xz, x^2 - y^2) of the unit normal, K_k = (A_l / pi) c_k L_k, c_k the
// basis normalisations (env/sh.hpp), so a shader needs no constants of its own. [k][channel].
env::Sh9 sh_shader_constants(const env::Sh9& sh);
// A GLSL (".glsl") or HLSL (".hlsl") snippet: the nine constants as `NAME[9]` and a function
// `NAME_irradiance(n)` returning E / pi, with `comment` (provenance) above. The language by `path`'s
// extension; std::invalid_argument for another extension or a name that is not a C identifier.
void check_sh_shader_output(const std::string& path, const std::string& name);
std::string sh_shader_source(const env::Sh9& sh, const std::string& path, const std::string& name, const std::string& comment);

// The outputs of an `ibl` command into a folder are one set (io/atomic_file.hpp's OutputSet): all of
// this run's files, or the previous ones. stale_job_files lists the regular files directly in `dir`
// that `is_job_file` claims for the job and whose names are not in `written` (an earlier run's mips
// beyond this run's count, another format's file); commit_outputs commits the set, unless a signal
// came during the writes (then ms::Cancelled, and nothing changes), and then removes those files.
std::vector<std::string> stale_job_files(const std::string& dir, const std::set<std::string>& written,
                                         const std::function<bool(const std::string&)>& is_job_file);
}  // namespace ms

namespace ms {
class OutputSet;
void commit_outputs(OutputSet& outputs, const std::vector<std::string>& stale = {});

}  // namespace ms
