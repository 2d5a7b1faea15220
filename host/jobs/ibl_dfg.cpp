#include "jobs/ibl_dfg.hpp"

#include "core/error_stats.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <random>
#include <sstream>
#include <stdexcept>

#include "core/estimate.hpp"
#include "env/image.hpp"
#include "env/preview.hpp"
#include "io/atomic_file.hpp"
#include "io/png_file.hpp"
#include "io/text.hpp"
#include "lut/formats/texture.hpp"
#include "lut/formats/texture_writer.hpp"

namespace ms {

const char* to_string(DfgMethod m) {
    switch (m) {
        case DfgMethod::exact: return "exact";
        case DfgMethod::sampled: return "sampled";
        case DfgMethod::quadrature: return "quadrature";
    }
    return "?";
}

DfgMethod parse_dfg_method(const std::string& s) {
    if (s == "exact") return DfgMethod::exact;
    if (s == "sampled") return DfgMethod::sampled;
    if (s == "quadrature") return DfgMethod::quadrature;
    throw std::invalid_argument("--method: '" + s + "' is not exact, sampled or quadrature");
}

const char* to_string(DfgChannel c) {
    switch (c) {
        case DfgChannel::scale: return "scale";
        case DfgChannel::bias: return "bias";
        case DfgChannel::albedo: return "E";
        case DfgChannel::sheen: return "sheen";
    }
    return "?";
}

std::vector<DfgChannel> parse_dfg_channels(const std::string& s) {
    std::vector<DfgChannel> out;
    std::stringstream in(s);
    std::string name;
    while (std::getline(in, name, ',')) {
        std::string lower = name;
        std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        DfgChannel c;
        if (lower == "scale") c = DfgChannel::scale;
        else if (lower == "bias") c = DfgChannel::bias;
        else if (lower == "e" || lower == "albedo") c = DfgChannel::albedo;
        else if (lower == "sheen" || lower == "cloth") c = DfgChannel::sheen;
        else throw std::invalid_argument("--channels: '" + name + "' is not scale, bias, E or sheen");
        if (std::find(out.begin(), out.end(), c) != out.end())
            throw std::invalid_argument("--channels: '" + name + "' given twice");
        out.push_back(c);
    }
    if (out.empty() || out.size() > 4) throw std::invalid_argument("--channels: 1 to 4 of scale, bias, E, sheen (comma-separated), not '" + s + "'");
    return out;
}

std::string channels_string(const std::vector<DfgChannel>& channels) {
    std::string s;
    for (DfgChannel c : channels) s += (s.empty() ? "" : ",") + std::string(to_string(c));
    return s;
}

bool has_sheen(const std::vector<DfgChannel>& channels) {
    return std::find(channels.begin(), channels.end(), DfgChannel::sheen) != channels.end();
}

const char* to_string(DfgParameterization p) { return p == DfgParameterization::linear ? "linear" : "sqrt-n-dot-v"; }

DfgParameterization parse_dfg_parameterization(const std::string& s) {
    if (s == "linear") return DfgParameterization::linear;
    if (s == "sqrt-n-dot-v") return DfgParameterization::sqrt_n_dot_v;
    throw std::invalid_argument("--parameterization: '" + s + "' is not linear or sqrt-n-dot-v");
}

double DfgBakeResult::channel(std::uint32_t x, std::uint32_t y, DfgChannel c) const {
    const dfg::DfgValue& v = at(x, y);
    switch (c) {
        case DfgChannel::scale: return v.scale.term;
        case DfgChannel::bias: return v.bias.term;
        case DfgChannel::albedo: return v.albedo.term;
        case DfgChannel::sheen: return v.sheen.term;
    }
    return 0;
}

void validate(const DfgBakeSpec& spec) {
    for (const Axis* a : {&spec.n_dot_v, &spec.roughness}) {
        if (a->count < 1 || a->count > 4096) throw std::invalid_argument("DFG LUT: axis " + a->name + " needs 1..4096 texels");
        if (!(a->min >= 0 && a->max <= 1 && a->min <= a->max))
            throw std::invalid_argument("DFG LUT: axis " + a->name + " must lie in [0, 1]");
    }
    if (spec.method == DfgMethod::sampled && spec.plan.replicates < 2)
        throw std::invalid_argument("DFG LUT: at least 2 replicates (error bars)");
    if (spec.channels.empty() || spec.channels.size() > 4) throw std::invalid_argument("DFG LUT: 1 to 4 channels");
}

schedule::BackendSpec dfg_backend(const DfgBakeSpec& spec) {
    schedule::BackendSpec where = spec.backend;
    where.kind = spec.method == DfgMethod::sampled ? schedule::Backend::Kind::opencl : schedule::Backend::Kind::oracle;
    return where;
}

dfg::DfgPoint dfg_texel_point(const DfgBakeSpec& spec, std::uint32_t x, std::uint32_t y) {
    const double r = spec.roughness.value(y);
    const double a = spec.n_dot_v.value(x);
    const double n_dot_v = spec.parameterization == DfgParameterization::sqrt_n_dot_v ? a * a : a;
    return {std::max(n_dot_v, kMinNdotV), r * r};
}

namespace {
// The host rule of a method that runs on host threads, with the cloth channel when asked.
dfg::DfgRoutineConfig host_routine(const DfgBakeSpec& spec, dfg::DfgHostRule rule, bool sheen) {
    dfg::DfgRoutineConfig config = spec.routine;
    config.host_rule = rule;
    config.sheen = sheen;
    return config;
}
}  // namespace

DfgBakeResult bake_dfg(const DfgBakeSpec& spec, schedule::Scheduler& scheduler, const DfgBakeCallbacks& callbacks) {
    validate(spec);
    const auto start = std::chrono::steady_clock::now();
    DfgBakeResult result;
    result.width = spec.n_dot_v.count;
    result.height = spec.roughness.count;
    result.channels = spec.channels;
    result.values.resize(std::size_t(result.width) * result.height);
    result.exact.assign(result.values.size(), 0);
    result.backend = scheduler.name();
    const bool sheen = has_sheen(spec.channels);
    // Integrated texels, in rows; roughness 0 is the exact limit: a mirror for GGX, and for Charlie
    // every half vector on the horizon, whose reflection lies below it (sheen 0).
    std::vector<dfg::DfgPoint> points;
    std::vector<std::size_t> where;
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x) {
            const dfg::DfgPoint p = dfg_texel_point(spec, x, y);
            const std::size_t i = std::size_t(y) * result.width + x;
            if (p.alpha == 0) {
                const double fc = std::pow(1 - p.n_dot_v, 5);
                result.values[i] = {{1 - fc, 0}, {fc, 0}, {1, 0}, {0, 0}};
                result.exact[i] = 1;
            } else {
                points.push_back(p);
                where.push_back(i);
            }
        }
    if (!points.empty()) {
        dfg::DfgRoutineConfig config = spec.routine;
        if (spec.method == DfgMethod::exact) config = host_routine(spec, dfg::DfgHostRule::exact, sheen);
        if (spec.method == DfgMethod::quadrature) config = host_routine(spec, dfg::DfgHostRule::quadrature, sheen);
        dfg::DfgIntegrand integrand(points, result.width, spec.plan, config);
        schedule::RunCallbacks cb;
        cb.progress = callbacks.progress;
        const schedule::RunReport report = scheduler.run(integrand, {}, cb);
        result.rerun_items = report.rerun;
        result.failed_devices = report.failed_places;
        std::vector<dfg::DfgValue> values = integrand.take_values();
        if (spec.method == DfgMethod::sampled && sheen) {
            // The kernel integrates GGX only: the cloth channel comes from the exact path on host threads.
            dfg::DfgIntegrand cloth(points, result.width, spec.plan, host_routine(spec, dfg::DfgHostRule::exact, true));
            schedule::Scheduler host(schedule::BackendSpec::oracle(spec.backend.threads));
            host.run(cloth);
            for (std::size_t k = 0; k < points.size(); ++k) values[k].sheen = cloth.values()[k].sheen;
        }
        for (std::size_t k = 0; k < points.size(); ++k) {
            result.values[where[k]] = values[k];
            const double largest = std::max({values[k].scale.std_error, values[k].bias.std_error, values[k].albedo.std_error});
            if (spec.method == DfgMethod::sampled) {
                result.max_std_error = std::max(result.max_std_error, largest);
                result.max_exact_error = std::max(result.max_exact_error, values[k].sheen.std_error);
            } else {
                result.max_exact_error = std::max({result.max_exact_error, largest, values[k].sheen.std_error});
            }
        }
    }
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

DfgBakeResult bake_dfg(const DfgBakeSpec& spec, const DfgBakeCallbacks& callbacks) {
    schedule::Scheduler scheduler(dfg_backend(spec));
    return bake_dfg(spec, scheduler, callbacks);
}

nlohmann::json dfg_metadata(const DfgBakeSpec& spec, const DfgBakeResult& result) {
    auto axis = [](const Axis& a) {
        return nlohmann::json{{"name", a.name}, {"min", a.min}, {"max", a.max}, {"count", a.count}, {"texel", to_string(a.texel)}};
    };
    const bool sampled = spec.method == DfgMethod::sampled;
    nlohmann::json m;
    m["layout"] = "dfg";
    m["integrals"] =
        "split-sum GGX: scale = int f (1 - Fc) NdotL dL, bias = int f Fc NdotL dL, E = scale + bias; "
        "f = D G2 / (4 NdotL NdotV), height-correlated Smith G2, Fc = (1 - VdotH)^5, alpha = roughness^2; "
        "sheen = int D_Charlie V_Neubelt NdotL dL (Estevez-Kulla NDF with alpha = roughness^2, "
        "V = 1 / (4 (NdotL + NdotV - NdotL NdotV)))";
    m["axes"] = {axis(spec.n_dot_v), axis(spec.roughness)};
    m["parameterization"] = to_string(spec.parameterization);
    m["x"] = spec.parameterization == DfgParameterization::linear ? "n_dot_v" : "sqrt(n_dot_v): texel coordinate a holds NdotV = a^2";
    m["y"] = "roughness (increasing downwards)";
    const char* names[4] = {"R", "G", "B", "A"};
    nlohmann::json channels = nlohmann::json::array();
    for (std::size_t c = 0; c < spec.channels.size(); ++c) {
        std::string value = to_string(spec.channels[c]);
        if (spec.channels[c] == DfgChannel::albedo) value += " = scale + bias (energy compensation: 1 + F0 (1/E - 1))";
        if (spec.channels[c] == DfgChannel::sheen) value += " (cloth: Charlie NDF, Neubelt visibility)";
        channels.push_back({{"name", names[c]}, {"value", value}});
    }
    m["channels"] = channels;
    m["channel_order"] = channels_string(spec.channels);
    m["n_dot_v_clamp"] = kMinNdotV;
    m["method"] = to_string(spec.method);
    m["estimator"] = spec.method == DfgMethod::exact      ? "Gauss-Legendre over the half vector (azimuth outer, graded panels), error from two orders"
                     : spec.method == DfgMethod::quadrature ? "Gauss-Legendre quadrature (oracle), error from two orders"
                                                            : "VNDF sampling, reflected directions weighted by G2/G1(V)";
    if (sampled && has_sheen(spec.channels)) m["sheen_estimator"] = "Gauss-Legendre (the exact path; the kernel integrates GGX only)";
    m["sequence"] = to_string(spec.plan.sequence);
    m["samples"] = sampled ? spec.plan.samples : 0;
    m["replicates"] = sampled ? spec.plan.replicates : 0;
    m["seed"] = spec.plan.seed;
    m["quadrature_order"] = spec.method == DfgMethod::exact ? spec.routine.exact_order : spec.routine.quadrature_order;
    m["max_std_error"] = result.max_std_error;
    m["max_quadrature_error_estimate"] = result.max_exact_error;
    m["max_error_bound_99.9"] =
        sampled ? result.max_std_error * student_t_quantile(0.999, int(spec.plan.replicates) - 1) : result.max_exact_error;
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

void check_dfg_lut_format(const std::string& path) {
    (void)lutfmt::texture_format_for_path(path, lutfmt::TextureUse::dfg);
}

void check_dfg_lut_output(const std::string& path, const std::vector<DfgChannel>& channels, const std::string& symbol) {
    const lutfmt::TextureFormat format = lutfmt::texture_format_for_path(path, lutfmt::TextureUse::dfg);
    if (format == lutfmt::TextureFormat::png && has_sheen(channels)) {
        std::vector<std::string> others;
        for (lutfmt::TextureFormat f : lutfmt::formats_for(lutfmt::TextureUse::dfg))
            if (f != lutfmt::TextureFormat::png) others.push_back(lutfmt::format_info(f).extensions.front());
        std::string list;
        for (std::size_t i = 0; i < others.size(); ++i) list += (i == 0 ? "" : i + 1 == others.size() ? " or " : ", ") + others[i];
        throw std::invalid_argument("DFG LUT " + path + ": a PNG holds [0, 1] and the sheen channel exceeds 1 at grazing views; use " + list);
    }
    const bool identifier = !symbol.empty() && !std::isdigit(static_cast<unsigned char>(symbol[0])) &&
                            std::all_of(symbol.begin(), symbol.end(), [](unsigned char c) { return std::isalnum(c) || c == '_'; });
    if (!identifier) throw std::invalid_argument("--symbol: '" + symbol + "' is not a C identifier (letters, digits, _; not starting with a digit)");
}

DfgLutFiles add_dfg_lut_files(OutputSet& outputs, const std::string& path) {
    return lutfmt::add_texture_files(outputs, path, lutfmt::texture_format_for_path(path, lutfmt::TextureUse::dfg));
}

namespace {

// The texels channel by channel as floats, rows of NdotV texels, roughness rows downwards.
std::vector<float> channel_data(const DfgBakeResult& result) {
    std::vector<float> data;
    data.reserve(result.values.size() * result.channels.size());
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x)
            for (DfgChannel c : result.channels) data.push_back(float(result.channel(x, y, c)));
    return data;
}

// The metadata a file records for the values it stores: the computed values' bound
// ("max_error_bound_99.9" as dfg_metadata made it, kept as "computed_error_bound_99.9") plus their
// rounding to the stored encoding (float32 at least: the quadrature's ~1e-12 is far below half a float
// step), so that every stored texel lies within "max_error_bound_99.9" of the integral.
nlohmann::json stored_metadata(const nlohmann::json& metadata, const std::vector<float>& data, lutfmt::PixelEncoding encoding) {
    nlohmann::json m = metadata.is_object() ? metadata : nlohmann::json::object();
    const double computed = m.contains("computed_error_bound_99.9") ? m["computed_error_bound_99.9"].get<double>()
                                                                     : m.value("max_error_bound_99.9", 0.0);
    const double rounding = lutfmt::quantisation_error(data, encoding);
    m["computed_error_bound_99.9"] = computed;
    m["storage_rounding"] = {{"encoding", lutfmt::to_string(encoding)}, {"max_abs", rounding}, {"kind", lutfmt::quantisation_kind(encoding)}};
    m["max_error_bound_99.9"] = computed + rounding;
    return m;
}

}  // namespace

void write_dfg_lut(OutputSet& outputs, const DfgLutFiles& files, const DfgBakeResult& result, const nlohmann::json& metadata,
                   bool half, const std::string& symbol) {
    using lutfmt::TextureFormat;
    const TextureFormat format = files.format;
    const std::size_t nc = result.channels.size();
    // A PNG is 16-bit; every other format float32, or float16 with `half`.
    const lutfmt::PixelEncoding encoding = format == TextureFormat::png ? lutfmt::PixelEncoding::unorm16
                                           : half                        ? lutfmt::PixelEncoding::float16
                                                                         : lutfmt::PixelEncoding::float32;
    // A 2D texture, x = NdotV, y = roughness, the result's channels per texel.
    lutfmt::TextureData t;
    t.width = result.width;
    t.height = result.height;
    t.channels = std::uint32_t(nc);
    t.levels.push_back(channel_data(result));
    const std::vector<float>& data = t.levels[0];
    // Every format records the bound of what it stores (stored_metadata): the encoding it rounds to.
    t.metadata = stored_metadata(metadata, data, encoding);
    switch (format) {
        case TextureFormat::exr: break;
        case TextureFormat::png:
            // RGB (1-3 channels; unused ones 0) or RGBA (4), q = round(v * 65535) with v clamped to [0, 1].
            t.metadata["file_format"] = "png16";
            t.metadata["quantisation"] = {{"kind", "unorm16"}, {"max_abs", t.metadata["storage_rounding"]["max_abs"]}};
            if (nc < 3) t.metadata["unused_channels_zero"] = true;
            break;
        case TextureFormat::header:
        case TextureFormat::inc: {
            // The C source convention of every texture (texture_writer.hpp), under `symbol`.
            t.metadata["file_format"] = format == TextureFormat::header ? "c-header" : "c-inc";
            t.c_identifier = symbol;
            const std::string ID = to_upper(symbol);
            // x is NdotV itself or sqrt(NdotV) (the metadata's "parameterization").
            const std::string x_axis = t.metadata.value("parameterization", std::string("linear")) == "linear" ? "linear" : "x = sqrt(NdotV)";
            t.c_comment = {"microshadow DFG LUT, written by microshadow " + std::string(MICROSHADOW_VERSION) + ". Generated: do not edit.",
                           "2D texture: width " + std::to_string(result.width) + " (NdotV, " + x_axis + "), height " +
                               std::to_string(result.height) + " (roughness, increasing downwards); " + std::to_string(nc) +
                               " components per texel (" + channels_string(result.channels) + "), " + lutfmt::to_string(encoding) + ".",
                           "index = (y * width + x) * " + std::to_string(nc) +
                               " + c; sample with linear filtering, clamp-to-edge, no mips. alpha = roughness^2.",
                           "The metadata (" + symbol + "_metadata, or the microshadow-metadata line of an .inc) records the axes and the error bound."};
            t.c_defines = {"#define " + ID + "_WIDTH " + std::to_string(result.width) + "u  /* NdotV texels */",
                           "#define " + ID + "_HEIGHT " + std::to_string(result.height) + "u  /* roughness texels */",
                           "#define " + ID + "_DEPTH 1u  /* a 2D texture */",
                           "#define " + ID + "_COMPONENTS " + std::to_string(nc) + "u  /* " + channels_string(result.channels) + " */"};
            break;
        }
        case TextureFormat::ktx2:
        case TextureFormat::dds: {
            // Two channels are stored as RG (RG16F / RG32F), the others as RGBA with the last channel repeated.
            const bool ktx2 = format == TextureFormat::ktx2;
            t.stored_components = nc == 2 ? 2 : 4;
            t.metadata["file_format"] = ktx2 ? "ktx2-2d" : "dds-2d";
            t.metadata["texture_channels"] = t.stored_components;
            if (t.stored_components > nc) {
                nlohmann::json padded = nlohmann::json::array();
                for (std::size_t c = nc; c < 4; ++c) padded.push_back(std::string(1, "RGBA"[c]));
                t.metadata["padded_channels"] = padded;
                t.metadata["padding"] = std::string("channels after ") + "RGBA"[nc - 1] + " repeat it (" + to_string(result.channels.back()) + ")";
            }
            if (ktx2) t.metadata["ktx2_orientation"] = "rd";
            // The sampling term of the error budget: the largest per-texel replicate standard error (or the
            // quadrature's error estimate).
            if (!t.metadata.contains("max_error") && t.metadata.contains("max_std_error"))
                t.metadata["max_error"] = std::max(t.metadata["max_std_error"].get<double>(),
                                                   t.metadata.value("max_quadrature_error_estimate", 0.0));
            lutfmt::add_error_budget(t.metadata, data, encoding);
            break;
        }
    }
    lutfmt::write_texture(outputs, files, t, encoding);
}

void write_dfg_lut(const std::string& path, const DfgBakeResult& result, const nlohmann::json& metadata, bool half,
                   const std::string& symbol) {
    OutputSet outputs;
    const DfgLutFiles files = add_dfg_lut_files(outputs, path);
    write_dfg_lut(outputs, files, result, metadata, half, symbol);
    outputs.commit();
}

namespace {

// The Bonferroni-t comparison of sampled estimates (scale, bias, E) with a reference at the texels.
void compare_sampled(DfgVerification& v, const std::vector<dfg::DfgValue>& sampled, const std::vector<dfg::DfgValue>& reference,
                     const std::vector<std::pair<std::uint32_t, std::uint32_t>>& texels, int df, std::vector<std::uint8_t>& bad) {
    v.threshold = student_t_quantile(1 - 0.001 / (3.0 * double(texels.size())), df);
    for (std::size_t i = 0; i < texels.size(); ++i) {
        const Estimate* a[3] = {&sampled[i].scale, &sampled[i].bias, &sampled[i].albedo};
        const Estimate* b[3] = {&reference[i].scale, &reference[i].bias, &reference[i].albedo};
        for (int c = 0; c < 3; ++c) {
            const double diff = std::abs(a[c]->term - b[c]->term);
            const double slack = b[c]->std_error + 1e-6;
            const double z = a[c]->std_error > 0 ? std::max(0.0, diff - slack) / a[c]->std_error : (diff > slack ? 1e9 : 0.0);
            v.worst_abs_diff = std::max(v.worst_abs_diff, diff);
            if (z > v.worst_z) {
                v.worst_z = z;
                std::ostringstream s;
                s << "texel (" << texels[i].first << ", " << texels[i].second << ") channel " << "RGB"[c] << ": " << a[c]->term
                  << " vs " << b[c]->term;
                v.worst_texel = s.str();
            }
            if (z > v.threshold) bad[i] = 1;
        }
    }
}

// The deterministic comparison: every channel (and sheen when asked) within `tolerance`.
void compare_deterministic(DfgVerification& v, const std::vector<dfg::DfgValue>& mine, const std::vector<dfg::DfgValue>& reference,
                           const std::vector<std::pair<std::uint32_t, std::uint32_t>>& texels, bool ggx, bool sheen,
                           double tolerance, std::vector<std::uint8_t>& bad) {
    v.deterministic_tolerance = tolerance;
    const char* names[4] = {"scale", "bias", "E", "sheen"};
    for (std::size_t i = 0; i < texels.size(); ++i) {
        const double a[4] = {mine[i].scale.term, mine[i].bias.term, mine[i].albedo.term, mine[i].sheen.term};
        const double b[4] = {reference[i].scale.term, reference[i].bias.term, reference[i].albedo.term, reference[i].sheen.term};
        for (int c = ggx ? 0 : 3; c < (sheen ? 4 : 3); ++c) {
            const double diff = std::abs(a[c] - b[c]);
            if (diff > v.worst_deterministic_diff) {
                v.worst_deterministic_diff = diff;
                std::ostringstream s;
                s << std::setprecision(12) << "texel (" << texels[i].first << ", " << texels[i].second << ") " << names[c] << ": "
                  << a[c] << " vs " << b[c];
                v.worst_deterministic_texel = s.str();
            }
            if (diff > tolerance) bad[i] = 1;
        }
    }
}

std::vector<dfg::DfgValue> run_host(const DfgBakeSpec& spec, const std::vector<dfg::DfgPoint>& points, dfg::DfgHostRule rule,
                                    bool sheen, int quadrature_order) {
    dfg::DfgRoutineConfig config = spec.routine;
    config.host_rule = rule;
    config.sheen = sheen;
    config.quadrature_order = quadrature_order;
    dfg::DfgIntegrand integrand(points, 1, spec.plan, config);
    schedule::Scheduler scheduler(schedule::BackendSpec::oracle(spec.backend.threads));
    scheduler.run(integrand);
    return integrand.take_values();
}

}  // namespace

DfgVerification verify_dfg(const DfgBakeSpec& spec, const DfgBakeResult& result, std::uint32_t k, std::uint64_t seed) {
    DfgVerification v;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> texels;
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x)
            if (!result.exact[std::size_t(y) * result.width + x]) texels.push_back({x, y});
    if (texels.empty() || k == 0) return v;
    std::mt19937_64 rng(seed);
    std::shuffle(texels.begin(), texels.end(), rng);
    texels.resize(std::min<std::size_t>(k, texels.size()));
    std::vector<dfg::DfgPoint> points;
    std::vector<dfg::DfgValue> mine;
    for (const auto& [x, y] : texels) {
        points.push_back(dfg_texel_point(spec, x, y));
        mine.push_back(result.at(x, y));
    }
    const bool sheen = has_sheen(result.channels);
    std::vector<std::uint8_t> bad(points.size(), 0);
    const int df = int(spec.plan.replicates) - 1;
    if (spec.method == DfgMethod::sampled) {
        // The quadrature at its usual order: its error (~1e-9) is far inside the kernel's bars.
        const auto reference = run_host(spec, points, dfg::DfgHostRule::quadrature, sheen, spec.routine.quadrature_order);
        compare_sampled(v, mine, reference, texels, df, bad);
        if (sheen) {
            // The sheen channel came from the exact path: against the quadrature's at order 20.
            const auto q20 = run_host(spec, points, dfg::DfgHostRule::quadrature, true, 20);
            compare_deterministic(v, mine, q20, texels, /*ggx=*/false, true, kDfgExactTolerance, bad);
        }
        v.reference = "the quadrature oracle";
    } else if (spec.method == DfgMethod::exact) {
        const auto q20 = run_host(spec, points, dfg::DfgHostRule::quadrature, sheen, 20);
        compare_deterministic(v, mine, q20, texels, true, sheen, kDfgExactTolerance, bad);
        // And the sampled kernel, the method with nothing in common with either quadrature.
        dfg::DfgIntegrand kernel(points, 1, spec.plan, spec.routine);
        schedule::Scheduler device(schedule::BackendSpec::opencl(spec.backend.device));
        device.run(kernel);
        compare_sampled(v, kernel.values(), mine, texels, df, bad);
        v.reference = "the quadrature oracle (order 20) and the VNDF kernel";
    } else {
        const auto reference = run_host(spec, points, dfg::DfgHostRule::exact, sheen, spec.routine.quadrature_order);
        compare_deterministic(v, mine, reference, texels, true, sheen, kDfgExactTolerance, bad);
        v.reference = "the exact path";
    }
    v.checked = std::uint32_t(points.size());
    for (std::uint8_t b : bad) v.failed += b;
    return v;
}

namespace {
env::Canvas dfg_preview_canvas(const DfgBakeResult& result, const DfgBakeSpec& spec) {
    // One tile per channel, each on its own scale from 0 (black) to its largest value (white), the
    // scale in its title: bias is at most ~0.2 and would be near black on scale's, sheen exceeds 1.
    std::vector<env::PlotTile> tiles;
    for (DfgChannel c : result.channels) {
        env::PlotTile tile;
        tile.width = result.width;
        tile.height = result.height;
        tile.values.resize(result.values.size());
        double top = 0;
        for (std::uint32_t y = 0; y < result.height; ++y)
            for (std::uint32_t x = 0; x < result.width; ++x) top = std::max(top, result.channel(x, y, c));
        const double scale = top > 0 ? 1 / top : 1;
        for (std::uint32_t y = 0; y < result.height; ++y)
            for (std::uint32_t x = 0; x < result.width; ++x)
                tile.values[std::size_t(y) * result.width + x] = float(result.channel(x, y, c) * scale);
        char title[64];
        std::snprintf(title, sizeof title, "%s 0 to %.3g", to_string(c), top);
        tile.title = title;
        tiles.push_back(std::move(tile));
    }
    const std::string caption = "DFG LUT " + std::to_string(result.width) + " x " + std::to_string(result.height) + ", " +
                                to_string(spec.n_dot_v.texel) + ", x = " +
                                (spec.parameterization == DfgParameterization::linear ? "NdotV" : "sqrt(NdotV)") +
                                ", alpha = roughness^2; each panel black (0) to white (its maximum)";
    return env::plot_canvas(tiles, spec.parameterization == DfgParameterization::linear ? "NdotV" : "sqrt NdotV", "roughness", caption);
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
    ErrorStats channel[3];  // scale, bias, E: the LUT minus the reference
    for (std::uint32_t y = 0; y < result.height; ++y)
        for (std::uint32_t x = 0; x < result.width; ++x) {
            const auto& v = result.at(x, y);
            const double mine[3] = {v.scale.term, v.bias.term, v.albedo.term};
            for (int k = 0; k < 3; ++k) {
                const double d = mine[k] - double(ref.at(x, y, k));
                channel[k].add(d);
                if (std::abs(d) > c.max_all) c.max_all = std::abs(d), c.worst_x = x, c.worst_y = y;
            }
        }
    for (int k = 0; k < 3; ++k) {
        c.max_abs[k] = channel[k].max_abs();
        c.rms[k] = channel[k].rms();
    }
    return c;
}

}  // namespace ms
