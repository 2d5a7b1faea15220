#include "jobs/ibl_env.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "core/cancel.hpp"
#include "core/types.hpp"
#include "io/atomic_file.hpp"
#include "platform/files.hpp"

namespace ms {

void cross_face_origin(int face, std::uint32_t n, std::uint32_t& x, std::uint32_t& y) {
    switch (face) {
        case 0: x = 2 * n, y = n; return;  // +X
        case 1: x = 0, y = n; return;      // -X
        case 2: x = n, y = 0; return;      // +Y
        case 3: x = n, y = 2 * n; return;  // -Y
        case 4: x = n, y = n; return;      // +Z
        case 5: x = 3 * n, y = n; return;  // -Z
    }
    throw std::invalid_argument("cross_face_origin: face 0..5");
}

namespace {
template <class Source>
IrradianceResult irradiance_of(const Source& src, const env::Sh9& sh, std::uint32_t face_size) {
    IrradianceResult r;
    r.sh = sh;
    // SH against brute force at 26 normals.
    double worst = 0, scale = 0;
    for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j)
            for (int k = -1; k <= 1; ++k) {
                if (i == 0 && j == 0 && k == 0) continue;
                const double len = std::sqrt(double(i * i + j * j + k * k));
                const env::Dir n{i / len, j / len, k / len};
                const auto a = env::sh_irradiance(r.sh, n);
                const auto b = env::irradiance_brute_force(src, n);
                for (int c = 0; c < 3; ++c) {
                    worst = std::max(worst, std::abs(a[c] - b[c]));
                    scale = std::max(scale, std::abs(b[c]));
                }
            }
    r.max_relative_sh_error = scale > 0 ? worst / scale : worst;
    r.face_size = face_size;
    if (face_size > 0) {
        const std::uint32_t n = face_size;
        r.irradiance_cross = env::Image(4 * n, 3 * n, {"R", "G", "B"});
        for (int f = 0; f < 6; ++f) {
            std::uint32_t ox, oy;
            cross_face_origin(f, n, ox, oy);
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x) {
                    const env::Dir d = env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                    const auto e = env::sh_irradiance(r.sh, d);
                    for (int c = 0; c < 3; ++c) r.irradiance_cross.at(ox + x, oy + y, c) = float(std::max(0.0, e[c]) / kPi);
                }
        }
    }
    return r;
}
}  // namespace

IrradianceResult compute_irradiance(const env::Image& equirect, std::uint32_t face_size) {
    if (equirect.width != 2 * equirect.height)
        throw std::invalid_argument("environment: an equirectangular image is twice as wide as high (this one is " +
                                    std::to_string(equirect.width) + " x " + std::to_string(equirect.height) + ")");
    return irradiance_of(equirect, env::sh_project_equirect(equirect), face_size);
}

IrradianceResult compute_irradiance(const env::Cubemap& cube, std::uint32_t face_size) {
    return irradiance_of(cube, env::sh_project_cubemap(cube), face_size);
}

nlohmann::json irradiance_metadata(const IrradianceResult& r, const std::string& source, const std::string& command_line) {
    nlohmann::json m;
    m["layout"] = "sh9";
    m["source"] = source;
    m["mapping"] = "equirectangular, +Y up, image centre = -Z: dir = (sin t sin p, cos t, -sin t cos p)";
    m["basis"] = "real SH, k = l(l+1)+m: Y00, Y1-1 (y), Y10 (z), Y11 (x), Y2-2 (xy), Y2-1 (yz), Y20 (3z^2-1), Y21 (xz), Y22 (x^2-y^2)";
    nlohmann::json coeffs = nlohmann::json::array(), irr = nlohmann::json::array();
    for (int k = 0; k < 9; ++k) {
        const double a = env::kClampedCosine[k == 0 ? 0 : k < 4 ? 1 : 2];
        coeffs.push_back({r.sh[k][0], r.sh[k][1], r.sh[k][2]});
        irr.push_back({a * r.sh[k][0], a * r.sh[k][1], a * r.sh[k][2]});
    }
    m["radiance_sh"] = coeffs;
    m["irradiance_sh"] = irr;  // E(n) = sum_k irradiance_sh[k] Y_k(n)
    m["clamped_cosine"] = {env::kClampedCosine[0], env::kClampedCosine[1], env::kClampedCosine[2]};
    m["max_relative_sh_error"] = r.max_relative_sh_error;
    if (r.face_size > 0) {
        m["irradiance_cubemap"] = "E / pi per texel, horizontal cross: +Y above +Z; -X +Z +X -Z; -Y below +Z (OpenGL face orientation)";
        m["face_size"] = r.face_size;
    }
    m["version"] = MICROSHADOW_VERSION;
    m["command_line"] = command_line;
    return m;
}

std::vector<std::string> stale_job_files(const std::string& dir, const std::set<std::string>& written,
                                         const std::function<bool(const std::string&)>& is_job_file) {
    std::vector<std::string> stale;
    std::error_code listed;  // a new folder: nothing of an earlier run
    for (std::filesystem::directory_iterator e(dir, listed); !listed && e != std::filesystem::directory_iterator();
         e.increment(listed)) {
        const std::string name = e->path().filename().string();
        if (written.count(name) || !is_job_file(name)) continue;
        const std::string path = dir + "/" + name;
        platform::FileStatus st;
        // Only regular files: a link or a folder of that name is the user's, not an earlier output.
        if (platform::link_status(path, st) == 0 && st.kind == platform::FileKind::regular) stale.push_back(path);
    }
    std::sort(stale.begin(), stale.end());
    return stale;
}

void commit_outputs(OutputSet& outputs, const std::vector<std::string>& stale) {
    // The writes take a while (a chain of mips, previews): a SIGINT / SIGTERM during them stops the run
    // here, before any file is replaced.
    throw_if_cancelled();
    outputs.commit();
    for (const auto& path : stale) platform::remove_file(path);
}

env::Sh9 sh_shader_constants(const env::Sh9& sh) {
    const double pi = kPi;
    // c_k: the basis functions' normalisations in env/sh.hpp's order; band l of index k.
    const double c[9] = {0.5 / std::sqrt(pi),         std::sqrt(3 / (4 * pi)),  std::sqrt(3 / (4 * pi)),
                         std::sqrt(3 / (4 * pi)),     std::sqrt(15 / (4 * pi)), std::sqrt(15 / (4 * pi)),
                         std::sqrt(5 / (16 * pi)),    std::sqrt(15 / (4 * pi)), std::sqrt(15 / (16 * pi))};
    const int band[9] = {0, 1, 1, 1, 2, 2, 2, 2, 2};
    env::Sh9 k{};
    for (int i = 0; i < 9; ++i)
        for (int ch = 0; ch < 3; ++ch) k[i][ch] = env::kClampedCosine[band[i]] / pi * c[i] * sh[i][ch];
    return k;
}

namespace {
std::string lower_extension(const std::string& path) {
    const auto dot = path.find_last_of('.');
    std::string ext = dot == std::string::npos ? "" : path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return char(std::tolower(ch)); });
    return ext;
}
}  // namespace

void check_sh_shader_output(const std::string& path, const std::string& name) {
    const std::string ext = lower_extension(path);
    if (ext != ".glsl" && ext != ".hlsl") throw std::invalid_argument("--shader " + path + ": the extension picks the language: .glsl or .hlsl");
    const bool identifier = !name.empty() && !std::isdigit(static_cast<unsigned char>(name[0])) &&
                            std::all_of(name.begin(), name.end(), [](unsigned char ch) { return std::isalnum(ch) || ch == '_'; });
    if (!identifier) throw std::invalid_argument("--symbol: '" + name + "' is not a C identifier (letters, digits, _; not starting with a digit)");
}

std::string sh_shader_source(const env::Sh9& sh, const std::string& path, const std::string& name, const std::string& comment) {
    check_sh_shader_output(path, name);
    const bool glsl = lower_extension(path) == ".glsl";
    const env::Sh9 k = sh_shader_constants(sh);
    const char* vec = glsl ? "vec3" : "float3";
    std::ostringstream out;
    std::string text = comment;
    for (std::size_t p = text.find("*/"); p != std::string::npos; p = text.find("*/", p)) text.replace(p, 2, "* /");
    out << "/* microshadow order-2 SH irradiance (generated; do not edit)\n" << text << "\n"
        << "   E(n) / pi = max(0, sum_k " << name << "[k] P_k(n)), P = (1, y, z, x, xy, yz, 3z^2 - 1, xz, x^2 - y^2),\n"
        << "   n the unit normal in the environment's frame (+Y up; the latlong centre looks down -Z). */\n";
    out << (glsl ? "const vec3 " : "static const float3 ") << name << "[9] = " << (glsl ? "vec3[9](\n" : "{\n");
    char buf[128];
    for (int i = 0; i < 9; ++i) {
        std::snprintf(buf, sizeof buf, "    %s(%.9g, %.9g, %.9g)%s\n", vec, k[i][0], k[i][1], k[i][2], i < 8 ? "," : "");
        out << buf;
    }
    out << (glsl ? ");\n\n" : "};\n\n");
    out << vec << " " << name << "_irradiance(" << vec << " n) {\n"
        << "    return max(" << vec << "(0.0, 0.0, 0.0),\n"
        << "        " << name << "[0]\n"
        << "        + " << name << "[1] * n.y + " << name << "[2] * n.z + " << name << "[3] * n.x\n"
        << "        + " << name << "[4] * (n.x * n.y) + " << name << "[5] * (n.y * n.z)\n"
        << "        + " << name << "[6] * (3.0 * n.z * n.z - 1.0) + " << name << "[7] * (n.x * n.z)\n"
        << "        + " << name << "[8] * (n.x * n.x - n.y * n.y));\n"
        << "}\n";
    return out.str();
}

}  // namespace ms
