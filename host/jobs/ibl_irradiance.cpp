#include "jobs/ibl_irradiance.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>

#include "core/error_stats.hpp"
#include "core/types.hpp"
#include "env/preview.hpp"
#include "env/sh.hpp"
#include "integrands/irradiance/irradiance_integrand.hpp"
#include "io/atomic_file.hpp"
#include "env/cubemap_file.hpp"
#include "jobs/ibl_env.hpp"
#include "lut/formats/texture.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

namespace {

struct V3 {
    double x, y, z;
};
V3 v3(const env::Dir& d) { return {d.x, d.y, d.z}; }
double dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(const V3& a, const V3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double norm(const V3& a) { return std::sqrt(dot(a, a)); }
double angle(const V3& a, const V3& b) { return std::atan2(norm(cross(a, b)), dot(a, b)); }

// The direction at the centre of output texel (x, y) of `face`.
env::Dir centre(int face, std::uint32_t x, std::uint32_t y, std::uint32_t n) {
    return env::cube_direction(face, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
}
}  // namespace

irradiance::Source pack_irradiance_source(const env::ReducedCubemap& reduced) {
    const std::uint32_t n = reduced.mean.size;
    irradiance::Source s;
    s.size = n;
    s.vector.reserve(24ull * n * n);
    s.radiance.reserve(24ull * n * n);
    s.spread.reserve(24ull * n * n);
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const double s0 = 2.0 * x / n - 1, s1 = 2.0 * (x + 1) / n - 1, t0 = 2.0 * y / n - 1, t1 = 2.0 * (y + 1) / n - 1;
                const V3 c[4] = {v3(env::cube_direction(f, s0, t0)), v3(env::cube_direction(f, s1, t0)), v3(env::cube_direction(f, s1, t1)),
                                 v3(env::cube_direction(f, s0, t1))};
                // Lambert's formula: W = 1/2 sum theta_e normalize(a x b), counter-clockwise seen from outside; the
                // corners' winding flips with the face, and W must point out through the texel.
                V3 w{0, 0, 0};
                for (int i = 0; i < 4; ++i) {
                    const V3 ab = cross(c[i], c[(i + 1) % 4]);
                    const double k = 0.5 * angle(c[i], c[(i + 1) % 4]) / norm(ab);
                    w = {w.x + k * ab.x, w.y + k * ab.y, w.z + k * ab.z};
                }
                if (dot(w, c[0]) < 0) w = {-w.x, -w.y, -w.z};
                const double wl = norm(w);
                const V3 wu{w.x / wl, w.y / wl, w.z / wl};
                // The cap around W that holds the texel: the corners' largest angle (a convex spherical polygon lies
                // in every cap that holds its corners), widened so float rounding never calls a crossed texel whole.
                double rho = 0, diameter = 0;
                for (int i = 0; i < 4; ++i) {
                    rho = std::max(rho, angle(wu, c[i]));
                    for (int j = i + 1; j < 4; ++j) diameter = std::max(diameter, angle(c[i], c[j]));
                }
                rho = rho * 1.01 + 1e-6;
                s.vector.insert(s.vector.end(), {float(w.x), float(w.y), float(w.z), float(wl * std::sin(rho))});
                const float* l = reduced.mean.texel(f, x, y);
                s.radiance.insert(s.radiance.end(), {l[0], l[1], l[2], 0.0f});
                const auto& d = reduced.deviation[(std::size_t(f) * n + y) * n + x];
                // Rounded up by a relative 1e-6 so the float never undercuts the double bound.
                const double up = 1 + 1e-6;
                s.spread.insert(s.spread.end(), {float(diameter * d[0] * up), float(diameter * d[1] * up), float(diameter * d[2] * up),
                                                 float(diameter * up)});
            }
    return s;
}

IrradianceMapResult compute_irradiance_map(const env::Cubemap& source, const IrradianceMapSpec& spec,
                                           const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
    if (spec.face_size == 0) throw std::invalid_argument("irradiance: face size must be at least 1");
    const auto start = std::chrono::steady_clock::now();
    IrradianceMapResult r;
    r.source_size = source.size;
    // The reduced size: halve while it stays at least the requested size (and divides the source's).
    std::uint32_t conv = source.size;
    while (conv % 2 == 0 && conv / 2 >= std::max<std::uint32_t>(1, spec.source_size)) conv /= 2;
    r.convolution_size = spec.backend.is_oracle() ? source.size : conv;
    const env::ReducedCubemap reduced = env::reduce_cubemap(source, conv);
    const irradiance::Source packed = pack_irradiance_source(reduced);
    const std::uint32_t n = spec.face_size;
    std::vector<irradiance::Target> targets;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x) {
                const env::Dir d = centre(f, x, y, n);
                targets.push_back({d.x, d.y, d.z});
            }
    irradiance::IrradianceIntegrand integrand(packed, targets, 64, {}, [&](const irradiance::Target& t) {
        const auto e = env::irradiance_exact(source, {t.x, t.y, t.z});
        irradiance::Value v;
        for (int c = 0; c < 3; ++c) {
            v.irradiance[c] = e[c];
            v.error_bound[c] = 1e-12 * std::abs(e[c]);  // exact up to double rounding
        }
        return v;
    });
    schedule::Scheduler scheduler(spec.backend);
    schedule::RunCallbacks cb;
    cb.progress = progress;
    const schedule::RunReport report = scheduler.run(integrand, {}, cb);
    r.rerun_items = report.rerun;
    r.failed_devices = report.failed_places;
    r.backend = spec.backend.is_oracle() ? "oracle: exact convolution of the full-resolution source (C++ double)"
                                         : "opencl: " + spec.backend.device + " (kernels/irradiance/irradiance.cl, float)";
    r.map = env::Cubemap(n);
    r.bound = env::Cubemap(n);
    const env::Sh9 sh = env::sh_project_cubemap(source);
    double power[3] = {0, 0, 0};
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < source.size; ++y)
            for (std::uint32_t x = 0; x < source.size; ++x)
                for (int c = 0; c < 3; ++c) power[c] += source.texel(f, x, y)[c] * env::cube_texel_solid_angle(x, y, source.size);
    double largest = 0;
    ErrorStats sh_error;  // |SH irradiance - map| over every texel and channel (core/error_stats.hpp)
    std::size_t k = 0;
    std::vector<std::array<double, 3>> sh_values;
    for (int f = 0; f < 6; ++f)
        for (std::uint32_t y = 0; y < n; ++y)
            for (std::uint32_t x = 0; x < n; ++x, ++k) {
                const irradiance::Value& v = integrand.values()[k];
                const auto e_sh = env::sh_irradiance(sh, centre(f, x, y, n));
                for (int c = 0; c < 3; ++c) {
                    const double value = v.irradiance[c] / kPi;
                    r.map.texel(f, x, y)[c] = float(value);
                    r.bound.texel(f, x, y)[c] = float(v.error_bound[c] / kPi);
                    if (value > 0) r.max_relative_bound = std::max(r.max_relative_bound, v.error_bound[c] / v.irradiance[c]);
                    largest = std::max(largest, std::abs(value));
                    const double diff = std::abs(e_sh[c] / kPi - value);
                    sh_error.add(diff);
                }
            }
    r.sh_max_abs = sh_error.max_abs();
    r.sh_max_relative = largest > 0 ? r.sh_max_abs / largest : r.sh_max_abs;
    r.sh_rms_relative = largest > 0 ? sh_error.rms() / largest : 0;
    r.sh_truncation_bound = 3.0 / 32 * std::max({power[0], power[1], power[2]}) / kPi;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
}

IrradianceVerification verify_irradiance_map(const env::Cubemap& source, const IrradianceMapResult& result, std::uint32_t k,
                                             std::uint64_t seed) {
    IrradianceVerification v;
    ErrorStats error;  // |map - exact| over the checked texels and channels
    std::mt19937_64 rng(seed);
    const std::uint32_t n = result.map.size;
    for (std::uint32_t i = 0; i < k; ++i) {
        const int f = int(rng() % 6);
        const std::uint32_t x = std::uint32_t(rng() % n), y = std::uint32_t(rng() % n);
        const auto exact = env::irradiance_exact(source, centre(f, x, y, n));
        bool failed = false;
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(double(result.map.texel(f, x, y)[c]) - exact[c] / kPi);
            // The map is stored as float: half an ulp of its value on top of the kernel's bound.
            const double bound = double(result.bound.texel(f, x, y)[c]) + std::abs(exact[c] / kPi) * 6e-8;
            error.add(diff);
            const double ratio = bound > 0 ? diff / bound : (diff > 0 ? 1e30 : 0);
            if (ratio > v.worst_ratio) {
                v.worst_ratio = ratio;
                std::ostringstream s;
                s << "face " << f << " texel (" << x << ", " << y << ") channel " << c << ": " << result.map.texel(f, x, y)[c]
                  << " vs exact " << exact[c] / kPi << ", bound " << bound;
                v.worst_texel = s.str();
            }
            failed = failed || diff > bound;
        }
        v.failed += failed;
        ++v.checked;
    }
    v.max_abs = error.max_abs();
    return v;
}

nlohmann::json irradiance_map_metadata(const IrradianceMapSpec& spec, const IrradianceMapResult& r) {
    nlohmann::json m;
    m["layout"] = "irradiance cubemap E / pi, horizontal cross: +Y above +Z; -X +Z +X -Z; -Y below +Z (OpenGL face orientation)";
    m["integral"] = "E(n) = int L(l) max(0, n.l) dl; stored E / pi (a constant environment L gives L)";
    m["method"] = "direct convolution: every texel of the source reduced to convolution_size (solid-angle means) with its exact "
                  "clamped-cosine integral (Lambert's formula, horizon-clipped)";
    m["source"] = spec.source;
    m["face_size"] = r.map.size;
    m["source_size"] = r.source_size;
    m["convolution_size"] = r.convolution_size;
    m["backend"] = r.backend;
    m["rerun_items"] = r.rerun_items;  // rerun on another device after one failed (failover)
    m["failed_devices"] = r.failed_devices;
    m["error_bound"] = {{"meaning", "per texel |value - exact convolution of the full-resolution source| <= bound "
                                    "(reduction: sum of texel diameter x spread; float rounding)"},
                        {"max_relative", r.max_relative_bound}};
    m["sh_comparison"] = {{"max_abs", r.sh_max_abs},
                          {"max_relative", r.sh_max_relative},
                          {"rms_relative", r.sh_rms_relative},
                          {"truncation_bound", r.sh_truncation_bound},
                          {"meaning", "order-2 SH irradiance (env/sh.hpp) minus this map at the output texels, E / pi units, relative to "
                                      "the map's largest value; truncation_bound = 3/32 int L dl / pi bounds |E_sh - E| / pi for any "
                                      "environment (the clamped cosine's order-2 truncation is off by at most 3/32, at grazing)"}};
    m["seconds"] = r.seconds;
    m["version"] = MICROSHADOW_VERSION;
    m["command_line"] = spec.command_line;
    return m;
}

namespace {
lutfmt::PixelEncoding irradiance_encoding(const std::string& encoding_name) {
    const lutfmt::PixelEncoding encoding = lutfmt::parse_pixel_encoding(encoding_name);
    if (encoding != lutfmt::PixelEncoding::float16 && encoding != lutfmt::PixelEncoding::float32)
        throw std::invalid_argument("irradiance encoding " + encoding_name + ": float16 or float32");
    return encoding;
}
}  // namespace

lutfmt::TextureFiles add_irradiance_map(OutputSet& outputs, const std::string& dir, const std::string& format,
                                        const std::string& encoding) {
    const lutfmt::TextureFormat f = lutfmt::parse_texture_format(format, lutfmt::TextureUse::cubemap);
    if (f != lutfmt::TextureFormat::exr) irradiance_encoding(encoding);
    return lutfmt::add_texture_files(outputs, lutfmt::file_name(dir + "/irradiance", f), f);
}

void write_irradiance_map(OutputSet& outputs, const lutfmt::TextureFiles& files, const env::Image& cross, const std::string& encoding_name,
                          const nlohmann::json& metadata) {
    if (files.format == lutfmt::TextureFormat::exr) {
        lutfmt::write_texture(outputs, files, env::image_texture(cross, metadata), lutfmt::PixelEncoding::float32);
        return;
    }
    // One cubemap level, RGBA with A = 1.
    const lutfmt::PixelEncoding encoding = irradiance_encoding(encoding_name);
    const env::Cubemap cube = env::cubemap_from_image(cross);
    lutfmt::TextureData t = env::cubemap_texture({&cube}, metadata);
    t.metadata["file_format"] = lutfmt::to_string(files.format) + "-cubemap";
    t.metadata["padding"] = "A = 1";
    t.metadata["encoding"] = lutfmt::to_string(encoding);
    lutfmt::write_texture(outputs, files, t, encoding);
}

IrradianceFiles add_irradiance_files(OutputSet& outputs, const std::string& dir, const std::string& format,
                                     const std::string& encoding) {
    IrradianceFiles files;
    files.encoding = encoding;
    files.map = add_irradiance_map(outputs, dir, format, encoding);
    files.json = outputs.add(dir + "/irradiance.json");
    files.preview = outputs.add(dir + "/irradiance_preview.png");
    return files;
}

void write_irradiance_files(OutputSet& outputs, const IrradianceFiles& files, const IrradianceMapResult& r,
                            const nlohmann::json& metadata, double exposure) {
    const env::Image cross = env::cross_image(r.map);
    write_irradiance_map(outputs, files.map, cross, files.encoding, metadata);
    outputs.stream(files.json) << metadata.dump(2) << "\n";
    char caption[160];
    std::snprintf(caption, sizeof caption, "irradiance E / pi by direct convolution (%u^2 source), cross: +Y top; -X, +Z, +X, -Z; -Y bottom",
                  r.convolution_size);
    env::write_png_file(outputs.temp_path(files.preview), env::cross_preview_canvas(cross, exposure, caption));
}

std::vector<std::string> stale_irradiance_files(const std::string& dir, const std::set<std::string>& written) {
    static const std::set<std::string> kMaps = {"irradiance.exr", "irradiance.ktx2", "irradiance.dds", "irradiance.dds.json"};
    return stale_job_files(dir, written, [](const std::string& name) { return kMaps.count(name) > 0; });
}

}  // namespace ms
