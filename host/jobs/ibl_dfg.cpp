#include "jobs/ibl_dfg.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <stdexcept>

#include "core/estimate.hpp"
#include "env/image.hpp"
#include "io/atomic_file.hpp"
#include "lut/formats/texture.hpp"

namespace ms {

void validate(const DfgBakeSpec& spec) {
    for (const Axis* a : {&spec.n_dot_v, &spec.roughness}) {
        if (a->count < 1 || a->count > 4096) throw std::invalid_argument("DFG LUT: axis " + a->name + " needs 1..4096 texels");
        if (!(a->min >= 0 && a->max <= 1 && a->min <= a->max))
            throw std::invalid_argument("DFG LUT: axis " + a->name + " must lie in [0, 1]");
    }
    if (spec.plan.replicates < 2) throw std::invalid_argument("DFG LUT: at least 2 replicates (error bars)");
}

schedule::Backend dfg_backend(const DfgBakeSpec& spec) {
    return spec.oracle ? schedule::Backend::oracle(spec.oracle_threads)
                       : schedule::Backend::opencl(ocl::select_devices(spec.device));
}

dfg::DfgPoint dfg_texel_point(const DfgBakeSpec& spec, std::uint32_t x, std::uint32_t y) {
    const double r = spec.roughness.value(y);
    return {std::max(spec.n_dot_v.value(x), kMinNdotV), r * r};
}

DfgBakeResult bake_dfg(const DfgBakeSpec& spec, schedule::Scheduler& scheduler, const DfgBakeCallbacks& callbacks) {
    validate(spec);
    const auto start = std::chrono::steady_clock::now();
    DfgBakeResult result;
    result.width = spec.n_dot_v.count;
    result.height = spec.roughness.count;
    result.values.resize(std::size_t(result.width) * result.height);
    result.exact.assign(result.values.size(), 0);
    result.backend = scheduler.name();
    // Sampled texels, in rows; roughness 0 is the exact limit.
    std::vector<dfg::DfgPoint> points;
    std::vector<std::size_t> where;
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x) {
            const dfg::DfgPoint p = dfg_texel_point(spec, x, y);
            const std::size_t i = std::size_t(y) * result.width + x;
            if (p.alpha == 0) {
                const double fc = std::pow(1 - p.n_dot_v, 5);
                result.values[i] = {{1 - fc, 0}, {fc, 0}, {1, 0}};
                result.exact[i] = 1;
            } else {
                points.push_back(p);
                where.push_back(i);
            }
        }
    if (!points.empty()) {
        dfg::DfgIntegrand integrand(points, result.width, spec.plan, spec.routine);
        schedule::RunCallbacks cb;
        cb.progress = callbacks.progress;
        const schedule::RunReport report = scheduler.run(integrand, {}, cb);
        result.rerun_items = report.rerun;
        result.failed_devices = report.failed_places;
        const auto& values = integrand.values();
        for (std::size_t k = 0; k < points.size(); ++k) {
            result.values[where[k]] = values[k];
            result.max_std_error = std::max({result.max_std_error, values[k].scale.std_error, values[k].bias.std_error,
                                             values[k].albedo.std_error});
        }
    }
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

DfgBakeResult bake_dfg(const DfgBakeSpec& spec, const DfgBakeCallbacks& callbacks) {
    schedule::Scheduler scheduler(dfg_backend(spec));
    scheduler.set_fault_injection(spec.fault);
    return bake_dfg(spec, scheduler, callbacks);
}

nlohmann::json dfg_metadata(const DfgBakeSpec& spec, const DfgBakeResult& result) {
    auto axis = [](const Axis& a) {
        return nlohmann::json{{"name", a.name}, {"min", a.min}, {"max", a.max}, {"count", a.count}, {"texel", to_string(a.texel)}};
    };
    nlohmann::json m;
    m["layout"] = "dfg";
    m["integrals"] =
        "split-sum GGX: scale = int f (1 - Fc) NdotL dL, bias = int f Fc NdotL dL, E = scale + bias; "
        "f = D G2 / (4 NdotL NdotV), height-correlated Smith G2, Fc = (1 - VdotH)^5, alpha = roughness^2";
    m["axes"] = {axis(spec.n_dot_v), axis(spec.roughness)};
    m["x"] = "n_dot_v";
    m["y"] = "roughness (increasing downwards)";
    m["channels"] = {{{"name", "R"}, {"value", "scale"}}, {{"name", "G"}, {"value", "bias"}}, {{"name", "B"}, {"value", "E = scale + bias (energy compensation: 1 + F0 (1/E - 1))"}}};
    m["n_dot_v_clamp"] = kMinNdotV;
    m["estimator"] = spec.oracle ? "Gauss-Legendre quadrature (oracle), error from two orders"
                                 : "VNDF sampling, reflected directions weighted by G2/G1(V)";
    m["sequence"] = to_string(spec.plan.sequence);
    m["samples"] = spec.oracle ? 0 : spec.plan.samples;
    m["replicates"] = spec.plan.replicates;
    m["seed"] = spec.plan.seed;
    m["quadrature_order"] = spec.routine.quadrature_order;
    m["max_std_error"] = result.max_std_error;
    m["max_error_bound_99.9"] =
        spec.oracle ? result.max_std_error
                    : result.max_std_error * student_t_quantile(0.999, int(spec.plan.replicates) - 1);
    m["fast_math"] = spec.routine.build.fast_math;
    m["double_kernels"] = spec.routine.build.double_precision;
    m["device"] = result.backend;
    m["rerun_items"] = result.rerun_items;  // rerun on another device after one failed (failover)
    m["failed_devices"] = result.failed_devices;
    m["seconds"] = result.seconds;
    m["version"] = MICROSHADOW_VERSION;
    m["command_line"] = spec.command_line;
    return m;
}

namespace {
std::string extension(const std::string& path) {
    const auto dot = path.find_last_of('.');
    std::string ext = dot == std::string::npos ? "" : path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}
}  // namespace

void check_dfg_lut_format(const std::string& path) {
    const std::string ext = extension(path);
    if (ext == ".exr" || ext == ".h" || ext == ".ktx2" || ext == ".dds") return;
    throw std::invalid_argument("DFG LUT " + path + ": the extension picks the format: .exr, .ktx2, .dds or .h (C header)");
}

DfgLutFiles add_dfg_lut_files(OutputSet& outputs, const std::string& path) {
    check_dfg_lut_format(path);
    DfgLutFiles files;
    files.lut = outputs.add(path, /*binary=*/true);
    if (extension(path) == ".dds") files.sidecar = outputs.add(path + ".json");
    return files;
}

void write_dfg_lut(OutputSet& outputs, const DfgLutFiles& files, const DfgBakeResult& result, const nlohmann::json& metadata,
                   bool half) {
    const std::string path = outputs.target(files.lut).named;
    if (extension(path) == ".h") {
        // A C/C++ header: the metadata as a comment, then float texels [roughness][NdotV][scale, bias, E],
        // printed with 9 significant digits (float round trip).
        std::ostream& out = outputs.stream(files.lut);
        std::string meta = metadata.dump(2);
        for (std::size_t p = meta.find("*/"); p != std::string::npos; p = meta.find("*/", p)) meta.replace(p, 2, "* /");
        out << "/* microshadow DFG LUT (generated; do not edit)\n" << meta << "\n*/\n";
        out << "#pragma once\n\n";
        out << "#define MICROSHADOW_DFG_WIDTH " << result.width << "  /* NdotV */\n";
        out << "#define MICROSHADOW_DFG_HEIGHT " << result.height << "  /* roughness */\n\n";
        out << "static const float microshadow_dfg[MICROSHADOW_DFG_HEIGHT][MICROSHADOW_DFG_WIDTH][3] = {\n";
        char buf[96];
        for (std::uint32_t y = 0; y < result.height; ++y) {
            out << "  {";
            for (std::uint32_t x = 0; x < result.width; ++x) {
                const auto& v = result.at(x, y);
                std::snprintf(buf, sizeof buf, "{%.9gf, %.9gf, %.9gf}%s", float(v.scale.term), float(v.bias.term),
                              float(v.albedo.term), x + 1 < result.width ? ", " : "");
                out << buf;
            }
            out << "}" << (y + 1 < result.height ? "," : "") << "\n";
        }
        out << "};\n";
        return;
    }
    if (extension(path) == ".exr") {
        env::Image img(result.width, result.height, {"R", "G", "B"});
        for (std::uint32_t y = 0; y < result.height; ++y)
            for (std::uint32_t x = 0; x < result.width; ++x) {
                const auto& v = result.at(x, y);
                img.at(x, y, 0) = float(v.scale.term);
                img.at(x, y, 1) = float(v.bias.term);
                img.at(x, y, 2) = float(v.albedo.term);
            }
        env::write_exr_file(outputs.temp_path(files.lut), path, img, metadata, half);
        return;
    }
    // KTX2 / DDS (lut/formats/texture.hpp): a 2D RGBA texture, x = NdotV, y = roughness, R G B = scale
    // bias E, A = E (the writers' padding: the last channel repeated).
    const bool ktx2 = extension(path) == ".ktx2";
    const lutfmt::PixelEncoding encoding = half ? lutfmt::PixelEncoding::float16 : lutfmt::PixelEncoding::float32;
    lutfmt::TextureData t;
    t.width = result.width;
    t.height = result.height;
    t.channels = 3;
    t.levels.emplace_back();
    std::vector<float>& data = t.levels[0];
    data.reserve(std::size_t(result.width) * result.height * 3);
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x) {
            const auto& v = result.at(x, y);
            data.push_back(float(v.scale.term));
            data.push_back(float(v.bias.term));
            data.push_back(float(v.albedo.term));
        }
    t.metadata = metadata.is_object() ? metadata : nlohmann::json::object();
    t.metadata["file_format"] = ktx2 ? "ktx2-2d" : "dds-2d";
    t.metadata["texture_channels"] = 4;
    t.metadata["padded_channels"] = {"A"};
    t.metadata["padding"] = "A repeats B (E = scale + bias); read R G B";
    if (ktx2) t.metadata["ktx2_orientation"] = "rd";
    // The sampling term of the error budget: the largest per-texel replicate standard error.
    if (!t.metadata.contains("max_error") && t.metadata.contains("max_std_error")) t.metadata["max_error"] = t.metadata["max_std_error"];
    lutfmt::add_error_budget(t.metadata, data, encoding);
    const std::vector<std::uint8_t> bytes = ktx2 ? lutfmt::encode_ktx2_texture(t, encoding) : lutfmt::encode_dds_texture(t, encoding);
    outputs.stream(files.lut).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!ktx2) outputs.stream(files.sidecar.value()) << lutfmt::dds_sidecar_json(t, encoding).dump(2) << "\n";
}

void write_dfg_lut(const std::string& path, const DfgBakeResult& result, const nlohmann::json& metadata, bool half) {
    OutputSet outputs;
    const DfgLutFiles files = add_dfg_lut_files(outputs, path);
    write_dfg_lut(outputs, files, result, metadata, half);
    outputs.commit();
}

DfgVerification verify_dfg(const DfgBakeSpec& spec, const DfgBakeResult& result, std::uint32_t k, std::uint64_t seed) {
    DfgVerification v;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> sampled;
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x)
            if (!result.exact[std::size_t(y) * result.width + x]) sampled.push_back({x, y});
    if (sampled.empty() || k == 0) return v;
    std::mt19937_64 rng(seed);
    std::shuffle(sampled.begin(), sampled.end(), rng);
    sampled.resize(std::min<std::size_t>(k, sampled.size()));
    std::vector<dfg::DfgPoint> points;
    for (const auto& [x, y] : sampled) points.push_back(dfg_texel_point(spec, x, y));
    dfg::DfgIntegrand oracle(points, 1, spec.plan, spec.routine);
    schedule::Scheduler scheduler(schedule::Backend::oracle(spec.oracle_threads));
    scheduler.run(oracle);
    const int df = int(spec.plan.replicates) - 1;
    v.threshold = spec.oracle ? 1.0 : student_t_quantile(1 - 0.001 / (3.0 * double(points.size())), df);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const auto& lut = result.at(sampled[i].first, sampled[i].second);
        const auto& ref = oracle.values()[i];
        const Estimate* a[3] = {&lut.scale, &lut.bias, &lut.albedo};
        const Estimate* b[3] = {&ref.scale, &ref.bias, &ref.albedo};
        bool bad = false;
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(a[c]->term - b[c]->term);
            const double slack = b[c]->std_error + 1e-6;
            const double z = a[c]->std_error > 0 ? std::max(0.0, diff - slack) / a[c]->std_error : (diff > slack ? 1e9 : 0.0);
            v.worst_abs_diff = std::max(v.worst_abs_diff, diff);
            if (z > v.worst_z) {
                v.worst_z = z;
                std::ostringstream s;
                s << "texel (" << sampled[i].first << ", " << sampled[i].second << ") channel " << "RGB"[c] << ": " << a[c]->term
                  << " vs oracle " << b[c]->term;
                v.worst_texel = s.str();
            }
            if (z > v.threshold) bad = true;
        }
        ++v.checked;
        if (bad) ++v.failed;
    }
    return v;
}

}  // namespace ms

#include "env/preview.hpp"

namespace ms {

namespace {
env::Canvas dfg_preview_canvas(const DfgBakeResult& result, const DfgBakeSpec& spec) {
    std::vector<env::PlotTile> tiles(3);
    const char* titles[3] = {"scale", "bias", "E = scale + bias"};
    for (int c = 0; c < 3; ++c) {
        tiles[c].title = titles[c];
        tiles[c].width = result.width;
        tiles[c].height = result.height;
        tiles[c].values.resize(result.values.size());
        for (std::size_t i = 0; i < result.values.size(); ++i) {
            const auto& v = result.values[i];
            tiles[c].values[i] = float(c == 0 ? v.scale.term : c == 1 ? v.bias.term : v.albedo.term);
        }
    }
    const std::string caption = "DFG LUT " + std::to_string(result.width) + " x " + std::to_string(result.height) +
                                ", " + to_string(spec.n_dot_v.texel) + ", alpha = roughness^2, values 0 (black) to 1 (white)";
    return env::plot_canvas(tiles, "NdotV", "roughness", caption);
}
}  // namespace

void write_dfg_preview(const std::string& path, const DfgBakeResult& result, const DfgBakeSpec& spec) {
    env::write_png(path, dfg_preview_canvas(result, spec));
}

void write_dfg_preview_file(const std::string& file, const DfgBakeResult& result, const DfgBakeSpec& spec) {
    env::write_png_file(file, dfg_preview_canvas(result, spec));
}

}  // namespace ms

namespace ms {

DfgComparison compare_dfg(const DfgBakeResult& result, const std::string& reference_exr) {
    nlohmann::json meta;
    const env::Image ref = env::read_exr_rgb(reference_exr, &meta);
    if (ref.width != result.width || ref.height != result.height)
        throw std::invalid_argument("--compare: " + reference_exr + " is " + std::to_string(ref.width) + " x " +
                                    std::to_string(ref.height) + ", the LUT " + std::to_string(result.width) + " x " +
                                    std::to_string(result.height));
    DfgComparison c;
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x) {
            const auto& v = result.at(x, y);
            const double mine[3] = {v.scale.term, v.bias.term, v.albedo.term};
            for (int k = 0; k < 3; ++k) {
                const double d = std::abs(mine[k] - double(ref.at(x, y, k)));
                c.max_abs[k] = std::max(c.max_abs[k], d);
                c.rms[k] += d * d;
                if (d > c.max_all) c.max_all = d, c.worst_x = x, c.worst_y = y;
            }
        }
    for (double& r : c.rms) r = std::sqrt(r / double(result.values.size()));
    return c;
}

}  // namespace ms
