#include "jobs/ibl_prefilter.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <time.h>

#include "core/cancel.hpp"
#include "env/preview.hpp"
#include "io/atomic_file.hpp"
#include "jobs/ibl_env.hpp"
#include "integrands/prefilter/prefilter_integrand.hpp"
#include "lut/formats/texture.hpp"
#include "schedule/scheduler.hpp"

namespace ms {

prefilter::SourceChain pack_chain(const std::vector<env::Cubemap>& chain) {
    prefilter::SourceChain c;
    c.size0 = chain[0].size;
    std::uint32_t offset = 0;
    for (const auto& level : chain) {
        c.offset.push_back(offset);
        for (int f = 0; f < 6; ++f) c.rgb.insert(c.rgb.end(), level.faces[f].data.begin(), level.faces[f].data.end());
        offset += 6 * level.size * level.size;
    }
    return c;
}

namespace {
// The chain on OpenCL devices through the scheduler (one item per 256 output texels).
void prefilter_on_devices(const std::vector<env::Cubemap>& chain, const PrefilterSpec& spec, const PointSet& points,
                          PrefilterResult& r, const PrefilterCallbacks& cb, double& worst) {
    const prefilter::SourceChain packed = pack_chain(chain);
    std::vector<prefilter::Target> targets;
    for (std::size_t m = 1; m < r.mips.size(); ++m) {
        const std::uint32_t n = r.mips[m].size;
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x) {
                    const env::Dir d = env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
                    targets.push_back({d.x, d.y, d.z, r.roughness[m]});
                }
    }
    prefilter::RoutineConfig config;
    config.filtered = spec.options.filtered;
    config.lod_bias = spec.options.lod_bias;
    prefilter::PrefilterIntegrand integrand(packed, targets, 256, points, config, [&](const prefilter::Target& t) {
        const env::PrefilterValue v = env::prefilter_direction(chain, {t.x, t.y, t.z}, t.roughness, points, spec.options);
        return prefilter::Value{v.value, v.std_error};
    });
    schedule::Scheduler scheduler(schedule::Backend::opencl(ocl::select_devices(spec.device)));
    scheduler.set_fault_injection(spec.fault);
    schedule::RunCallbacks rcb;
    rcb.progress = cb.progress;
    const schedule::RunReport report = scheduler.run(integrand, {}, rcb);
    r.rerun_items = report.rerun;
    r.failed_devices = report.failed_places;
    std::size_t k = 0;
    for (std::size_t m = 1; m < r.mips.size(); ++m) {
        const std::uint32_t n = r.mips[m].size;
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < n; ++y)
                for (std::uint32_t x = 0; x < n; ++x, ++k) {
                    const auto& v = integrand.values()[k];
                    float* t = r.mips[m].texel(f, x, y);
                    for (int c = 0; c < 3; ++c) {
                        t[c] = float(v.value[c]);
                        if (v.value[c] > 0) worst = std::max(worst, v.std_error[c] / v.value[c]);
                    }
                }
    }
}
}  // namespace

std::uint32_t default_levels(std::uint32_t size) {
    std::uint32_t levels = 1;
    while ((size >> levels) >= 4) ++levels;  // down to 4 x 4
    return levels;
}

PrefilterResult prefilter_cubemap(const env::Cubemap& source, const PrefilterSpec& spec, const PrefilterCallbacks& cb) {
    const auto start = std::chrono::steady_clock::now();
    const std::uint32_t size = source.size;
    const std::uint32_t levels = spec.levels ? spec.levels : default_levels(size);
    if ((size >> (levels - 1)) == 0) throw std::invalid_argument("prefilter: too many levels for a face of " + std::to_string(size));
    const std::vector<env::Cubemap> chain = env::mip_chain(source);
    if (spec.wide_samples_factor == 0 || (spec.wide_samples_factor & (spec.wide_samples_factor - 1)))
        throw std::invalid_argument("--wide-samples-factor must be a power of two (the point sets are nets of 2^m points)");
    const PointSet points = make_point_set(spec.plan);
    SamplingPlan wide_plan = spec.plan;
    wide_plan.samples *= std::max(1u, spec.wide_samples_factor);
    const PointSet wide_points = spec.wide_samples_factor > 1 ? make_point_set(wide_plan) : PointSet{};
    PrefilterResult r;
    r.mips.push_back(source);
    r.roughness.push_back(0);
    struct Row {
        std::uint32_t mip;
        int face;
        std::uint32_t y;
    };
    std::vector<Row> rows;
    for (std::uint32_t m = 1; m < levels; ++m) {
        r.mips.emplace_back(size >> m);
        r.roughness.push_back(env::mip_roughness(m, levels, spec.mapping));
        for (int f = 0; f < 6; ++f)
            for (std::uint32_t y = 0; y < (size >> m); ++y) rows.push_back({m, f, y});
    }
    if (spec.wide_samples_factor > 1 && !spec.device.empty())
        throw std::invalid_argument("--wide-samples-factor is implemented in the C++ estimator only (no --device)");
    if (spec.bright_threshold > 0 && !spec.device.empty())
        throw std::invalid_argument("--bright-threshold is implemented in the C++ estimator only (no --device)");
    env::BrightSplit split;
    if (spec.bright_threshold > 0) {
        split = env::split_bright_texels(source, spec.bright_threshold, spec.bright_max_texels);
        r.bright_texels = split.texels.size();
        r.bright_power_fraction = split.bright_power_fraction;
    }
    const bool use_split = spec.bright_threshold > 0;
    if (!spec.device.empty()) {
        double worst = 0;
        prefilter_on_devices(chain, spec, points, r, cb, worst);
        r.max_relative_std_error = worst;
        for (std::uint32_t m = 1; m < levels; ++m) r.texels += 6ull * (size >> m) * (size >> m);
        r.samples = r.texels * spec.plan.samples;
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        r.cpu_seconds = 0;  // the device's time is in seconds
        return r;
    }
    std::atomic<std::size_t> next{0}, done{0};
    std::mutex mutex;
    std::exception_ptr error;
    std::vector<double> worst(1, 0.0);
    std::atomic<long long> cpu_ns{0};
    auto work = [&] {
        double local_worst = 0;
        timespec t0{}, t1{};
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t0);
        try {
            for (;;) {
                const std::size_t i = next++;
                if (i >= rows.size()) break;
                throw_if_cancelled();
                const Row& row = rows[i];
                env::Cubemap& out = r.mips[row.mip];
                const std::uint32_t n = out.size;
                for (std::uint32_t x = 0; x < n; ++x) {
                    const env::Dir d = env::cube_direction(row.face, 2 * (x + 0.5) / n - 1, 2 * (row.y + 0.5) / n - 1);
                    const bool wide = r.roughness[row.mip] >= spec.bright_min_roughness;
                    const PointSet& pts = wide && spec.wide_samples_factor > 1 ? wide_points : points;
                    const env::PrefilterValue v = use_split && wide ? env::prefilter_direction_split(split, d, r.roughness[row.mip], pts, spec.options)
                                                                    : env::prefilter_direction(chain, d, r.roughness[row.mip], pts, spec.options);
                    float* t = out.texel(row.face, x, row.y);
                    for (int c = 0; c < 3; ++c) {
                        t[c] = float(v.value[c]);
                        if (v.value[c] > 0) local_worst = std::max(local_worst, v.std_error[c] / v.value[c]);
                    }
                }
                ++done;
            }
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex);
            if (!error) error = std::current_exception();
            next = rows.size();
        }
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t1);
        cpu_ns += (t1.tv_sec - t0.tv_sec) * 1000000000LL + (t1.tv_nsec - t0.tv_nsec);
        std::lock_guard<std::mutex> lock(mutex);
        worst[0] = std::max(worst[0], local_worst);
    };
    const unsigned threads = spec.threads ? spec.threads : std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads; ++t) pool.emplace_back(work);
    while (true) {
        {
            std::lock_guard<std::mutex> lock(mutex);
            if (done >= rows.size() || error) break;
        }
        if (cb.progress) cb.progress(done, rows.size());
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (next >= rows.size() && done >= rows.size()) break;
    }
    for (auto& t : pool) t.join();
    if (error) std::rethrow_exception(error);
    if (cb.progress) cb.progress(rows.size(), rows.size());
    r.max_relative_std_error = worst[0];
    for (std::uint32_t m = 1; m < levels; ++m) {
        const std::uint64_t texels = 6ull * (size >> m) * (size >> m);
        r.texels += texels;
        r.samples += texels * (r.roughness[m] >= spec.bright_min_roughness ? wide_plan.samples : spec.plan.samples);
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.cpu_seconds = double(cpu_ns.load()) * 1e-9;
    return r;
}

PrefilterVerification verify_prefilter(const env::Cubemap& source, const PrefilterResult& result, const PrefilterSpec& spec,
                                       std::uint32_t k, std::uint64_t seed, const std::vector<env::Cubemap>* source_chain) {
    PrefilterVerification v;
    if (result.mips.size() < 2 || k == 0) return v;
    std::vector<env::Cubemap> own;
    if (!source_chain) own = env::mip_chain(source);
    const std::vector<env::Cubemap>& chain = source_chain ? *source_chain : own;
    const PointSet points = make_point_set(spec.plan);
    SamplingPlan wide_plan = spec.plan;
    wide_plan.samples *= std::max(1u, spec.wide_samples_factor);
    const PointSet wide_points = spec.wide_samples_factor > 1 ? make_point_set(wide_plan) : PointSet{};
    env::BrightSplit split;
    if (spec.bright_threshold > 0) split = env::split_bright_texels(source, spec.bright_threshold, spec.bright_max_texels);
    std::mt19937_64 rng(seed);
    double ss = 0, ss_se = 0;
    std::size_t count = 0;
    std::vector<double> ss_mip(result.mips.size(), 0.0), se_mip(result.mips.size(), 0.0), n_mip(result.mips.size(), 0.0);
    for (std::uint32_t i = 0; i < k; ++i) {
        const std::uint32_t m = 1 + std::uint32_t(rng() % (result.mips.size() - 1));
        const std::uint32_t n = result.mips[m].size;
        const int f = int(rng() % 6);
        const std::uint32_t x = std::uint32_t(rng() % n), y = std::uint32_t(rng() % n);
        const env::Dir d = env::cube_direction(f, 2 * (x + 0.5) / n - 1, 2 * (y + 0.5) / n - 1);
        const auto ref = env::prefilter_oracle(source, d, result.roughness[m]);
        const float* got = result.mips[m].texel(f, x, y);
        // Error bars of this texel: recompute it (the file stores values only).
        const bool wide = result.roughness[m] >= spec.bright_min_roughness;
        const PointSet& pts = wide && spec.wide_samples_factor > 1 ? wide_points : points;
        const env::PrefilterValue again = spec.bright_threshold > 0 && wide ? env::prefilter_direction_split(split, d, result.roughness[m], pts, spec.options)
                                                                            : env::prefilter_direction(chain, d, result.roughness[m], pts, spec.options);
        const double scale = std::max(1e-30, (std::abs(ref[0]) + std::abs(ref[1]) + std::abs(ref[2])) / 3);
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(double(got[c]) - ref[c]);
            const double rel = diff / scale;
            ss += rel * rel;
            ++count;
            if (rel > v.max_relative) {
                v.max_relative = rel;
                std::ostringstream s;
                s << "mip " << m << " face " << f << " texel (" << x << ", " << y << ") channel " << c << ": " << got[c]
                  << " vs oracle " << ref[c];
                v.worst_texel = s.str();
            }
            if (again.std_error[c] > 0) v.worst_z = std::max(v.worst_z, diff / again.std_error[c]);
            ss_se += (again.std_error[c] / scale) * (again.std_error[c] / scale);
            ss_mip[m] += rel * rel;
            se_mip[m] += (again.std_error[c] / scale) * (again.std_error[c] / scale);
            n_mip[m] += 1;
        }
        ++v.checked;
    }
    v.rms_relative = std::sqrt(ss / double(count));
    v.rms_relative_std_error = std::sqrt(ss_se / double(count));
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        v.rms_relative_by_mip.push_back(n_mip[m] > 0 ? std::sqrt(ss_mip[m] / n_mip[m]) : 0);
        v.rms_std_error_by_mip.push_back(n_mip[m] > 0 ? std::sqrt(se_mip[m] / n_mip[m]) : 0);
    }
    return v;
}

nlohmann::json prefilter_metadata(const PrefilterSpec& spec, const PrefilterResult& result) {
    nlohmann::json m;
    m["layout"] = "prefiltered specular cubemap, one horizontal cross per mip (+Y above +Z; -X +Z +X -Z; -Y below +Z)";
    m["integral"] = "P(n) = int L(l) (n.l) D(h) dl / int (n.l) D(h) dl, GGX D, alpha = roughness^2, N = V = R";
    m["source"] = spec.source;
    m["mapping"] = to_string(spec.mapping);
    m["roughness"] = result.roughness;
    m["levels"] = result.mips.size();
    m["base_size"] = result.mips.empty() ? 0 : result.mips[0].size;
    m["estimator"] = spec.options.filtered ? "filtered importance sampling (Krivanek & Colbert 2008)" : "importance sampling of the full-resolution source";
    m["lod_bias"] = spec.options.lod_bias;
    if (spec.bright_threshold > 0)
        m["bright_texels"] = {{"threshold_times_mean_radiance", spec.bright_threshold}, {"max_texels", spec.bright_max_texels},
                              {"min_roughness", spec.bright_min_roughness},
                              {"count", result.bright_texels}, {"power_fraction", result.bright_power_fraction},
                              {"method", "summed explicitly over their solid angles, removed from the sampled environment"}};
    m["sequence"] = to_string(spec.plan.sequence);
    m["samples"] = spec.plan.samples;
    m["wide_samples_factor"] = spec.wide_samples_factor;  // on mips of roughness >= bright_min_roughness
    m["wide_min_roughness"] = spec.bright_min_roughness;
    m["samples_total"] = result.samples;
    m["replicates"] = spec.plan.replicates;
    m["seed"] = spec.plan.seed;
    m["max_relative_std_error"] = result.max_relative_std_error;
    m["seconds"] = result.seconds;
    m["cpu_seconds"] = result.cpu_seconds;  // summed over the threads: stable on a shared machine
    m["device"] = spec.device.empty() ? "CPU threads (C++ double)" : "opencl: " + spec.device + " (kernels/prefilter/prefilter.cl, float)";
    m["rerun_items"] = result.rerun_items;  // rerun on another device after one failed (failover)
    m["failed_devices"] = result.failed_devices;
    m["version"] = MICROSHADOW_VERSION;
    m["command_line"] = spec.command_line;
    return m;
}

namespace {

lutfmt::PixelEncoding cubemap_encoding(const std::string& encoding_name) {
    const lutfmt::PixelEncoding encoding = lutfmt::parse_pixel_encoding(encoding_name);
    if (encoding != lutfmt::PixelEncoding::float16 && encoding != lutfmt::PixelEncoding::float32)
        throw std::invalid_argument("cubemap encoding " + encoding_name + ": float16 or float32 (unorm clips radiance above 1)");
    return encoding;
}

lutfmt::TextureData prefilter_texture(const PrefilterResult& result, const nlohmann::json& metadata, const std::string& format,
                                      lutfmt::PixelEncoding encoding) {
    if (result.mips.empty()) throw std::invalid_argument("cubemap: no mips");
    lutfmt::TextureData t;
    t.width = t.height = result.mips[0].size;
    t.faces = 6;
    t.channels = 3;
    t.alpha = 1.0f;
    double max_abs = 0, max_rel = 0;
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        if (result.mips[m].size != lutfmt::level_size(t.width, std::uint32_t(m)))
            throw std::invalid_argument("cubemap: mip " + std::to_string(m) + " is not half the size of the one above");
        std::vector<float> level;
        for (int f = 0; f < 6; ++f) level.insert(level.end(), result.mips[m].faces[f].data.begin(), result.mips[m].faces[f].data.end());
        if (encoding == lutfmt::PixelEncoding::float16)
            for (float v : level) {
                const double err = std::abs(double(lutfmt::half_to_float(lutfmt::float_to_half(v))) - v);
                max_abs = std::max(max_abs, err);
                if (v != 0) max_rel = std::max(max_rel, err / std::abs(double(v)));
            }
        t.levels.push_back(std::move(level));
    }
    t.metadata = metadata.is_object() ? metadata : nlohmann::json::object();
    t.metadata["file_format"] = format == "ktx2" ? "ktx2-cubemap" : "dds-cubemap";
    t.metadata["mip_roughness"] = result.roughness;
    t.metadata["faces"] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    t.metadata["texture_channels"] = 4;
    t.metadata["padding"] = "A = 1 (RGB radiance)";
    t.metadata["encoding"] = lutfmt::to_string(encoding);
    t.metadata["quantisation"] = {{"kind", lutfmt::quantisation_kind(encoding)}, {"max_abs", max_abs}, {"max_relative", max_rel}};
    return t;
}

env::Canvas prefilter_preview_canvas(const PrefilterResult& result, double exposure) {
    // Each mip's cross magnified (nearest) to the base size, side by side in two rows.
    const std::uint32_t n = result.mips[0].size;
    const std::uint32_t cols = std::uint32_t((result.mips.size() + 1) / 2);
    const std::uint32_t cw = 4 * n + 8, ch = 3 * n + 28;
    // A strip at the bottom names the tone map.
    env::Image img(std::max(cols * cw, env::text_width(env::tone_map_caption(exposure), 1) + 8), 2 * ch + 14, {"R", "G", "B"});
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        const env::Image cross = env::cross_image(result.mips[m]);
        const std::uint32_t zoom = n / result.mips[m].size;
        const std::uint32_t ox = std::uint32_t(m % cols) * cw, oy = std::uint32_t(m / cols) * ch;
        for (std::uint32_t y = 0; y < 3 * n; ++y)
            for (std::uint32_t x = 0; x < 4 * n; ++x)
                for (int c = 0; c < 3; ++c) img.at(ox + x, oy + y, c) = cross.at(x / zoom, y / zoom, c);
    }
    env::Canvas canvas = env::tone_map(img, exposure);
    for (std::size_t m = 0; m < result.mips.size(); ++m) {
        char label[96];
        std::snprintf(label, sizeof label, "mip %zu  %ux%u  roughness %.3f", m, result.mips[m].size, result.mips[m].size,
                      result.roughness[m]);
        const std::int64_t ox = std::int64_t(m % cols) * cw, oy = std::int64_t(m / cols) * ch;
        canvas.text(ox + 2, oy + 3 * n + 4, label, n >= 64 ? 2 : 1, 255);
        env::label_cross_faces(canvas, ox, oy, n);
    }
    canvas.text(4, 2 * ch + 3, env::tone_map_caption(exposure), 1, 255);
    return canvas;
}

// "specular_m<digits>.exr"
bool is_mip_file(const std::string& name) {
    const std::string head = "specular_m", tail = ".exr";
    if (name.size() <= head.size() + tail.size() || name.compare(0, head.size(), head) != 0 ||
        name.compare(name.size() - tail.size(), tail.size(), tail) != 0)
        return false;
    for (std::size_t i = head.size(); i < name.size() - tail.size(); ++i)
        if (name[i] < '0' || name[i] > '9') return false;
    return true;
}

}  // namespace

PrefilterFiles add_prefilter_files(OutputSet& outputs, const std::string& dir, std::uint32_t levels, const std::string& format,
                                   const std::string& encoding) {
    PrefilterFiles files;
    files.format = format;
    files.encoding = encoding;
    if (format == "exr") {
        for (std::uint32_t m = 0; m < levels; ++m) files.mips.push_back(outputs.add(dir + "/specular_m" + std::to_string(m) + ".exr"));
    } else if (format == "ktx2" || format == "dds") {
        cubemap_encoding(encoding);
        files.cubemap = outputs.add(dir + "/specular." + format, /*binary=*/true);
        if (format == "dds") files.cubemap_sidecar = outputs.add(dir + "/specular.dds.json");
    } else {
        throw std::invalid_argument("cubemap format " + format + ": exr, ktx2 or dds");
    }
    files.preview = outputs.add(dir + "/specular_preview.png");
    return files;
}

void write_prefilter_files(OutputSet& outputs, const PrefilterFiles& files, const PrefilterResult& result,
                           const nlohmann::json& metadata, double exposure) {
    if (files.format == "exr") {
        if (files.mips.size() != result.mips.size())
            throw std::logic_error("write_prefilter_files: " + std::to_string(files.mips.size()) + " mip files for " +
                                   std::to_string(result.mips.size()) + " mips");
        for (std::size_t m = 0; m < result.mips.size(); ++m) {
            throw_if_cancelled();  // a signal during a long chain of writes stops it here (nothing is committed)
            nlohmann::json meta = metadata;
            meta["mip"] = m;
            meta["mip_roughness"] = result.roughness[m];
            env::write_exr_file(outputs.temp_path(files.mips[m]), outputs.target(files.mips[m]).named, env::cross_image(result.mips[m]), meta);
        }
    } else {
        const lutfmt::PixelEncoding encoding = cubemap_encoding(files.encoding);
        const lutfmt::TextureData t = prefilter_texture(result, metadata, files.format, encoding);
        const std::vector<std::uint8_t> bytes =
            files.format == "ktx2" ? lutfmt::encode_ktx2_texture(t, encoding) : lutfmt::encode_dds_texture(t, encoding);
        outputs.stream(files.cubemap.value()).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        if (files.cubemap_sidecar) outputs.stream(*files.cubemap_sidecar) << lutfmt::dds_sidecar_json(t, encoding).dump(2) << "\n";
    }
    env::write_png_file(outputs.temp_path(files.preview), prefilter_preview_canvas(result, exposure));
}

std::vector<std::string> stale_prefilter_files(const std::string& dir, const std::set<std::string>& written) {
    static const std::set<std::string> kOthers = {"specular.ktx2", "specular.dds", "specular.dds.json", "dfg.exr", "dfg.ktx2",
                                                  "dfg.dds",       "dfg.dds.json", "dfg_preview.png",   "irradiance.exr",
                                                  "irradiance.ktx2", "irradiance.dds", "irradiance.dds.json"};
    return stale_job_files(dir, written, [](const std::string& name) { return is_mip_file(name) || kOthers.count(name) > 0; });
}

}  // namespace ms
