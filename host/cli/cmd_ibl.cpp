// microshadow ibl: the image-based-lighting integrals of the split-sum approximation.
//   ibl dfg --out dfg.exr|.ktx2|.dds|.h [--size N] ...        the DFG LUT (scale, bias, E) by VNDF sampling, or the quadrature oracle
//   ibl prefilter ENV --out DIR                 GGX-prefiltered cubemap mips (cmgen roughness mapping), SH irradiance, previews
//   ibl sh ENV --out sh.json [--irradiance F]  order-2 SH of an environment (9 coefficients per channel) and its
//                                              irradiance cubemap faces through the clamped-cosine convolution
//   ibl irradiance ENV --out DIR               irradiance cubemap (E / pi) by direct convolution, with error bounds and SH comparison
//   (ENV, for sh / prefilter / irradiance, may instead be six face files: --faces PX NX PY NY PZ NZ)
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <optional>
#include <set>
#include <sstream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/preview.hpp"
#include "env/sh.hpp"
#include "io/atomic_file.hpp"
#include "jobs/ibl_dfg.hpp"
#include "jobs/ibl_env.hpp"
#include "jobs/ibl_irradiance.hpp"
#include "jobs/ibl_prefilter.hpp"

#include <filesystem>

namespace ms::cli {

namespace {

// An optional output: its index in the set, or kNoFile when the option was not given.
constexpr std::size_t kNoFile = ~std::size_t(0);
std::size_t add_if_given(OutputSet& outputs, const std::string& path) { return path.empty() ? kNoFile : outputs.add(path); }

struct DfgArgs {
    std::string out, preview, compare, texel = "centres", backend, device = "default";
    std::string method = "sampled", channels = "scale,bias,E", parameterization = "linear", symbol = "microshadow_dfg";
    int warp = 3;
    std::uint32_t size = 64, size_n_dot_v = 0, size_roughness = 0, replicates = 8, verify = 0;
    std::uint64_t samples = 65536, seed = 0;
    bool half = false, fast_math = false, double_kernels = false, quiet = false;
    bool samples_given = false, replicates_given = false;
    unsigned threads = 0;
};

std::string to_chars(double v) {
    std::ostringstream s;
    s << std::setprecision(3) << v;
    return s.str();
}

void run_dfg(const DfgArgs& a) {
    DfgBakeSpec spec;
    spec.n_dot_v.count = a.size_n_dot_v ? a.size_n_dot_v : a.size;
    spec.roughness.count = a.size_roughness ? a.size_roughness : a.size;
    spec.n_dot_v.texel = spec.roughness.texel = parse_texel_convention(a.texel);
    spec.plan.replicates = a.replicates;
    spec.plan.seed = a.seed;
    spec.plan.samples = round_up_samples(a.samples, a.replicates);
    if (spec.plan.samples != a.samples && !a.quiet)
        std::cerr << "note: --samples " << a.samples << " rounded up to " << spec.plan.samples << "\n";
    if (spec.plan.samples / a.replicates > (1u << 24)) throw std::invalid_argument("--samples: at most 2^24 per replicate");
    // --backend opencl|oracle is the older spelling of --method sampled|quadrature.
    std::string method = a.method;
    if (!a.backend.empty()) {
        const std::string implied = a.backend == "oracle" ? "quadrature" : "sampled";
        if (a.method != "sampled" && a.method != implied)
            throw std::invalid_argument("--backend " + a.backend + " contradicts --method " + a.method);
        method = implied;
    }
    spec.method = parse_dfg_method(method);
    spec.channels = parse_dfg_channels(a.channels);
    spec.parameterization = parse_dfg_parameterization(a.parameterization);
    check_dfg_lut_output(a.out, spec.channels, a.symbol);
    spec.oracle_threads = a.threads;
    spec.device = a.device;
    spec.routine.warp = a.warp;
    spec.routine.build.fast_math = a.fast_math;
    spec.routine.build.double_precision = a.double_kernels;
    if (spec.method != DfgMethod::sampled && (a.fast_math || a.double_kernels))
        throw std::invalid_argument("--fast-math and --double-kernels build the kernel of --method sampled; --method " + method + " has none");
    if (spec.method != DfgMethod::sampled && (a.samples_given || a.replicates_given))
        throw std::invalid_argument("--samples and --replicates set --method sampled; --method " + method + " is deterministic");
    spec.command_line = command_line();
    spec.fault = fault_injection_from_environment();
    validate(spec);
    // Every output checked, and two at one path refused, before the bake.
    OutputSet outputs;
    const DfgLutFiles lut_files = add_dfg_lut_files(outputs, a.out);
    const std::size_t preview = add_if_given(outputs, a.preview);

    Progress progress("ibl dfg", a.quiet);
    DfgBakeCallbacks cb;
    cb.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    const DfgBakeResult result = bake_dfg(spec, cb);
    progress.finish();
    nlohmann::json meta = dfg_metadata(spec, result);
    DfgVerification check;
    if (a.verify > 0) {
        check = verify_dfg(spec, result, a.verify);
        meta["verify"] = {{"texels", check.checked}, {"failed", check.failed}, {"reference", check.reference},
                          {"worst_z", check.worst_z}, {"threshold", check.threshold}, {"worst_abs_diff", check.worst_abs_diff},
                          {"worst_deterministic_diff", check.worst_deterministic_diff},
                          {"deterministic_tolerance", check.deterministic_tolerance}};
        if (check.failed > 0) {
            std::ostringstream s;
            s << "verification failed: " << check.failed << " of " << check.checked << " texels differ from " << check.reference
              << std::setprecision(3) << " beyond their error bars (worst z " << check.worst_z << ", limit " << check.threshold
              << "; " << check.worst_texel << "; worst deterministic |diff| " << check.worst_deterministic_diff << ", limit "
              << check.deterministic_tolerance << (check.worst_deterministic_texel.empty() ? "" : ", " + check.worst_deterministic_texel)
              << "); nothing was written";
            throw std::runtime_error(s.str());
        }
    }
    DfgComparison cmp;
    if (!a.compare.empty()) {
        cmp = compare_dfg(result, a.compare);
        meta["compare"] = {{"reference", a.compare},
                           {"max_abs", {cmp.max_abs[0], cmp.max_abs[1], cmp.max_abs[2]}},
                           {"rms", {cmp.rms[0], cmp.rms[1], cmp.rms[2]}}};
    }
    if (preview != kNoFile) write_dfg_preview_file(outputs.temp_path(preview), result, spec);
    write_dfg_lut(outputs, lut_files, result, meta, a.half, a.symbol);
    commit_outputs(outputs);
    if (!a.quiet) {
        std::cerr << std::setprecision(3) << "ibl dfg: " << result.width << " x " << result.height << " (NdotV x roughness), "
                  << (spec.method == DfgMethod::sampled
                          ? std::to_string(spec.plan.samples) + " samples per texel, max std error " + to_chars(result.max_std_error)
                          : std::string(to_string(spec.method)) + ", max error estimate " + to_chars(result.max_exact_error))
                  << ", " << result.seconds << " s on " << result.backend << "\n";
        if (!a.compare.empty())
            std::cerr << "compare: max |diff| scale " << cmp.max_abs[0] << " bias " << cmp.max_abs[1] << " E " << cmp.max_abs[2]
                      << " (worst texel " << cmp.worst_x << ", " << cmp.worst_y << "); rms " << cmp.rms[0] << " " << cmp.rms[1]
                      << " " << cmp.rms[2] << "; bake " << result.seconds << " s\n";
        if (a.verify > 0)
            std::cerr << "verify: " << check.checked << " texels against " << check.reference << ": worst z " << check.worst_z
                      << " (limit " << check.threshold << "), worst |diff| " << check.worst_abs_diff
                      << (check.deterministic_tolerance > 0 ? ", worst deterministic |diff| " + to_chars(check.worst_deterministic_diff) +
                                                                  " (limit " + to_chars(check.deterministic_tolerance) + ")"
                                                            : std::string())
                      << "\n";
    }
}

// The environment of `ibl sh` / `ibl prefilter`: ENV (one image) or --faces (six files), exactly one of them.
void check_environment_arguments(const std::string& env, const std::vector<std::string>& faces) {
    if (env.empty() && faces.empty()) throw std::invalid_argument("give an environment: ENV (one image) or --faces PX NX PY NY PZ NZ");
    if (!env.empty() && !faces.empty()) throw std::invalid_argument("ENV and --faces both given: use one");
}
std::string environment_name(const std::string& env, const std::vector<std::string>& faces) {
    if (!env.empty()) return env;
    std::string s = "faces";
    for (const auto& f : faces) s += " " + f;
    return s;
}

const char* const kShCrossCaption =
    "irradiance E / pi from order-2 SH, horizontal cross: +Y top; -X, +Z, +X, -Z middle; -Y bottom";

// The --out folder of `ibl prefilter` / `ibl irradiance`: checked before any work (it is a folder, or
// can be made in a writable parent), made only once the inputs are read, and removed again by a run
// that made it and then failed (an empty folder is no output).
class OutputFolder {
public:
    explicit OutputFolder(std::string dir) : dir_(std::move(dir)) {
        namespace fs = std::filesystem;
        if (dir_.empty()) throw OutputError("--out: empty folder name");
        std::error_code ec;
        fs::path p = fs::path(dir_).lexically_normal();
        if (fs::exists(p, ec)) {
            if (!fs::is_directory(p, ec)) throw OutputError("--out " + dir_ + " exists and is not a directory");
            if (::access(p.c_str(), W_OK) != 0) throw OutputError("--out " + dir_ + ": the folder is not writable (" + std::strerror(errno) + ")");
            return;
        }
        // The folders to make, deepest first, up to the first that exists.
        for (fs::path q = p; !q.empty() && !fs::exists(q, ec); q = q.parent_path()) {
            to_make_.push_back(q);
            if (q == q.parent_path()) break;
        }
        const fs::path parent = to_make_.back().parent_path().empty() ? fs::path(".") : to_make_.back().parent_path();
        if (!fs::is_directory(parent, ec)) throw OutputError("--out " + dir_ + ": " + parent.string() + " is not a directory");
        if (::access(parent.c_str(), W_OK) != 0)
            throw OutputError("--out " + dir_ + ": cannot create it in " + parent.string() + " (" + std::strerror(errno) + ")");
    }
    ~OutputFolder() {
        if (kept_) return;
        std::error_code ec;
        for (const auto& q : made_) std::filesystem::remove(q, ec);  // only empty folders go (remove fails on others)
    }
    void make() {
        for (auto it = to_make_.rbegin(); it != to_make_.rend(); ++it) {
            std::error_code ec;
            if (!std::filesystem::create_directory(*it, ec) && ec)
                throw OutputError("--out " + dir_ + ": cannot create " + it->string() + " (" + ec.message() + ")");
            made_.insert(made_.begin(), *it);
        }
        to_make_.clear();
    }
    void keep() { kept_ = true; }

private:
    std::string dir_;
    std::vector<std::filesystem::path> to_make_, made_;  // deepest first
    bool kept_ = false;
};

// File names (no folder) of a set's outputs inside `dir`, for the stale-file checks.
std::set<std::string> names_in(const OutputSet& outputs, std::size_t count) {
    std::set<std::string> names;
    for (std::size_t i = 0; i < count; ++i) names.insert(std::filesystem::path(outputs.target(i).named).filename().string());
    return names;
}

struct ShArgs {
    std::string env, out, irradiance, preview, shader, symbol = "microshadow_sh";
    std::vector<std::string> faces;
    std::uint32_t face_size = 32;
    bool quiet = false;
};

void run_sh(const ShArgs& a) {
    check_environment_arguments(a.env, a.faces);
    OutputSet outputs;  // all three files or none; two at one path refused here
    const std::size_t json = outputs.add(a.out);
    const std::size_t irradiance = add_if_given(outputs, a.irradiance);
    const std::size_t preview = add_if_given(outputs, a.preview);
    if (!a.shader.empty()) check_sh_shader_output(a.shader, a.symbol);
    const std::size_t shader = add_if_given(outputs, a.shader);
    // Equirectangular images are projected texel by texel (exact texel integrals); crosses and face files as cubemaps.
    // The cross is needed for the EXR and for the preview alike.
    const std::uint32_t faces = a.irradiance.empty() && a.preview.empty() ? 0 : a.face_size;
    env::Image image;
    if (a.faces.empty()) image = env::read_environment_image(a.env);
    const IrradianceResult r = !a.faces.empty() ? compute_irradiance(env::read_cubemap_faces(a.faces), faces)
                               : image.width == 2 * image.height ? compute_irradiance(image, faces)
                                                                 : compute_irradiance(env::cubemap_from_image(image), faces);
    nlohmann::json meta = irradiance_metadata(r, environment_name(a.env, a.faces), command_line());
    outputs.stream(json) << meta.dump(2) << "\n";
    if (irradiance != kNoFile) env::write_exr_file(outputs.temp_path(irradiance), a.irradiance, r.irradiance_cross, meta);
    if (preview != kNoFile) env::write_png_file(outputs.temp_path(preview), env::cross_preview_canvas(r.irradiance_cross, 1.0, kShCrossCaption));
    if (shader != kNoFile)
        outputs.stream(shader) << sh_shader_source(r.sh, a.shader, a.symbol,
                                                   "   source: " + environment_name(a.env, a.faces) + "\n   command: " + command_line() +
                                                       "\n   version: " + MICROSHADOW_VERSION);
    commit_outputs(outputs);
    if (!a.quiet)
        std::cerr << "ibl sh: " << (a.faces.empty() ? std::to_string(image.width) + " x " + std::to_string(image.height) + " environment"
                                                    : "six " + std::to_string(r.face_size) + "^2 faces")
                  << ", 9 coefficients per channel; "
                  << "irradiance SH vs brute force at 26 normals: max relative difference " << std::setprecision(3)
                  << r.max_relative_sh_error << "\n";
}

struct PrefilterArgs {
    std::string env, out, mapping = "cmgen", device, format = "exr", encoding = "float16";
    std::vector<std::string> faces;
    std::uint32_t size = 0, levels = 0, replicates = 16, verify = 0, irradiance_size = 32, dfg_size = 0;
    std::uint64_t samples = 256, seed = 0, max_samples = 1u << 16;
    double lod_bias = 0.0, exposure = 1.0, bright_threshold = 0, bright_min_roughness = 0, tolerance = 0.02;
    std::string bright = "auto";
    std::size_t bright_max = 4096;
    std::uint32_t wide_samples_factor = 1;
    bool no_fis = false, quiet = false, verify_report = false;
    unsigned threads = 0;
};

void run_prefilter(const PrefilterArgs& a) {
    check_environment_arguments(a.env, a.faces);
    OutputFolder folder(a.out);
    if (a.size && (a.size & (a.size - 1))) throw std::invalid_argument("--size must be a power of two");
    PrefilterSpec spec;
    spec.mapping = env::parse_roughness_mapping(a.mapping);
    spec.levels = a.levels;
    spec.plan.replicates = a.replicates;
    spec.plan.samples = round_up_samples(a.samples, a.replicates);
    spec.plan.seed = a.seed;
    spec.options.filtered = !a.no_fis;
    spec.options.lod_bias = a.lod_bias;
    spec.tolerance = a.tolerance;
    spec.max_samples = a.max_samples;
    if (a.max_samples < a.samples)
        throw std::invalid_argument("--max-samples " + std::to_string(a.max_samples) + " is below --samples " + std::to_string(a.samples));
    spec.bright_threshold = a.bright_threshold;
    spec.bright_auto = a.bright == "auto";
    if (a.bright == "off" && a.bright_threshold > 0) throw std::invalid_argument("--bright off and --bright-threshold together");
    spec.bright_max_texels = a.bright_max;
    spec.bright_min_roughness = a.bright_min_roughness;
    spec.wide_samples_factor = a.wide_samples_factor;
    spec.threads = a.threads;
    spec.device = a.device;
    spec.source = environment_name(a.env, a.faces);
    spec.command_line = command_line();
    spec.fault = fault_injection_from_environment();
    // Test hook: a corrupted estimator (every value scaled by 1 + b, bars unchanged) that --verify must catch.
    if (const char* bias = std::getenv("MICROSHADOW_TEST_PREFILTER_BIAS")) {
        char* end = nullptr;
        spec.test_bias = std::strtod(bias, &end);
        if (end == bias || *end != '\0' || !std::isfinite(spec.test_bias))
            throw std::invalid_argument(std::string("MICROSHADOW_TEST_PREFILTER_BIAS must be a number, not '") + bias + "'");
    }

    env::Cubemap source = a.faces.empty() ? env::cubemap_from_image(env::read_environment_image(a.env), a.size)
                                          : env::read_cubemap_faces(a.faces);
    if (source.size & (source.size - 1))
        throw std::invalid_argument("the face size must be a power of two (it is " + std::to_string(source.size) + ")");
    if (a.size > source.size)
        throw std::invalid_argument("--size " + std::to_string(a.size) + " is larger than the cross's faces (" + std::to_string(source.size) + ")");
    if (a.size && source.size != a.size) source = env::mip_chain(source).at(std::size_t(std::log2(double(source.size) / a.size)));
    if (spec.levels && (source.size >> (spec.levels - 1)) == 0)
        throw std::invalid_argument("--levels " + std::to_string(spec.levels) + " is too many for faces of " + std::to_string(source.size));
    const std::uint32_t levels = spec.levels ? spec.levels : default_levels(source.size);

    // Every file of the run is one set, checked before the work: this run's files, or the previous ones.
    folder.make();
    OutputSet outputs;
    const PrefilterFiles specular = add_prefilter_files(outputs, a.out, levels, a.format, a.encoding);
    // The SH irradiance in the chain's format: a cross for exr, one cubemap level for ktx2 / dds.
    const bool irradiance_texture = a.format != "exr";
    const std::size_t irradiance_map = outputs.add(a.out + "/irradiance." + a.format, /*binary=*/irradiance_texture);
    std::optional<std::size_t> irradiance_sidecar;
    if (a.format == "dds") irradiance_sidecar = outputs.add(a.out + "/irradiance.dds.json");
    const std::size_t irradiance_png = outputs.add(a.out + "/irradiance_preview.png");
    const std::size_t sh_json = outputs.add(a.out + "/sh.json");
    const std::size_t ibl_json = outputs.add(a.out + "/ibl.json");
    DfgLutFiles dfg_files;
    std::size_t dfg_preview = kNoFile;
    if (a.dfg_size > 0) {
        dfg_files = add_dfg_lut_files(outputs, a.out + "/dfg." + a.format);
        dfg_preview = outputs.add(a.out + "/dfg_preview.png");
    }
    const std::size_t file_count = dfg_preview != kNoFile ? dfg_preview + 1 : ibl_json + 1;

    Progress progress("ibl prefilter", a.quiet);
    PrefilterCallbacks cb;
    cb.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    const PrefilterResult result = prefilter_cubemap(source, spec, cb);
    progress.finish();
    nlohmann::json meta = prefilter_metadata(spec, result);
    PrefilterVerification check;
    if (a.verify > 0) {
        check = verify_prefilter(source, result, a.verify);
        meta["verify"] = verification_json(check);
        if (!check.passed && !a.verify_report) {
            std::ostringstream s;
            s << std::setprecision(3) << "verification failed: " << check.checked
              << " texels against the brute-force oracle, worst z " << check.worst_z << " beyond the Bonferroni bound "
              << check.z_bound << " (" << check.worst_z_texel << "); nothing was written";
            throw std::runtime_error(s.str());
        }
    }
    const IrradianceResult irr = compute_irradiance(source, a.irradiance_size);
    nlohmann::json irr_meta = irradiance_metadata(irr, spec.source, command_line());
    std::optional<DfgBakeResult> dfg;
    DfgBakeSpec dspec;
    if (a.dfg_size > 0) {
        dspec.n_dot_v.count = dspec.roughness.count = a.dfg_size;
        dspec.command_line = command_line();
        dspec.fault = spec.fault;
        dfg = bake_dfg(dspec);
    }

    write_prefilter_files(outputs, specular, result, meta, a.exposure);
    if (irradiance_texture)
        write_irradiance_cube(outputs, irradiance_map, irradiance_sidecar, env::cubemap_from_image(irr.irradiance_cross), a.format,
                              a.encoding, irr_meta);
    else
        env::write_exr_file(outputs.temp_path(irradiance_map), outputs.target(irradiance_map).named, irr.irradiance_cross, irr_meta);
    env::write_png_file(outputs.temp_path(irradiance_png), env::cross_preview_canvas(irr.irradiance_cross, a.exposure, kShCrossCaption));
    outputs.stream(sh_json) << irr_meta.dump(2) << "\n";
    outputs.stream(ibl_json) << nlohmann::json{{"specular", meta}, {"irradiance", irr_meta}}.dump(2) << "\n";
    if (dfg) {
        write_dfg_preview_file(outputs.temp_path(dfg_preview), *dfg, dspec);
        write_dfg_lut(outputs, dfg_files, *dfg, dfg_metadata(dspec, *dfg));  // --format ktx2 / dds: float32
    }
    commit_outputs(outputs, stale_prefilter_files(a.out, names_in(outputs, file_count)));
    folder.keep();
    if (!a.quiet) {
        std::cerr << std::setprecision(3) << "ibl prefilter: " << result.mips.size() << " mips from " << source.size << "^2 faces ("
                  << to_string(spec.mapping) << " roughness), " << (spec.options.filtered ? "filtered" : "unfiltered")
                  << " importance sampling, " << result.bright_texels << " bright texels summed explicitly ("
                  << 100 * result.bright_power_fraction << "% of the power), " << double(result.samples) / double(std::max<std::uint64_t>(1, result.texels))
                  << " samples per texel on average, " << result.seconds << " s (" << result.cpu_seconds << " CPU s); largest relative 95% bar "
                  << result.max_relative_bar;
        if (spec.tolerance > 0)
            std::cerr << " (tolerance " << spec.tolerance << (result.unconverged ? ", " + std::to_string(result.unconverged) + " texels above it at --max-samples" : "") << ")";
        std::cerr << "\n";
        std::cerr << "ibl sh: irradiance SH vs brute force: max relative difference " << irr.max_relative_sh_error << "\n";
        if (a.verify > 0)
            std::cerr << "verify: " << check.checked << " texels against the brute-force oracle: relative RMS " << check.rms_relative
                      << ", max " << check.max_relative << ", worst z " << check.worst_z << " (Bonferroni bound " << check.z_bound << ")\n";
    }
}

struct IrradianceArgs {
    std::string env, out, format = "exr", encoding = "float16", device = "default", backend = "opencl";
    std::vector<std::string> faces;
    std::uint32_t face_size = 32, source_size = 128, verify = 0;
    double exposure = 1.0;
    bool quiet = false;
    unsigned threads = 0;
};

void run_irradiance(const IrradianceArgs& a) {
    check_environment_arguments(a.env, a.faces);
    OutputFolder folder(a.out);
    IrradianceMapSpec spec;
    spec.face_size = a.face_size;
    spec.source_size = a.source_size;
    spec.oracle = a.backend == "oracle";
    spec.device = a.device;
    spec.threads = a.threads;
    spec.source = environment_name(a.env, a.faces);
    spec.command_line = command_line();
    spec.fault = fault_injection_from_environment();
    // Equirectangular images are resampled to a cubemap of height / 2 (a power of two), crosses and faces kept.
    bool resampled = false;
    const env::Cubemap source = [&] {
        if (!a.faces.empty()) return env::read_cubemap_faces(a.faces);
        const env::Image image = env::read_environment_image(a.env);
        resampled = image.width == 2 * image.height;
        return env::cubemap_from_image(image);
    }();
    // What --verify compares with: the exact convolution of the cube the map is computed from, which for
    // an equirectangular ENV is its resampling, not the image itself (whose difference is larger).
    const std::string reference =
        resampled ? "the exact convolution of the resampled cube (ENV's equirectangular image resampled to " +
                        std::to_string(source.size) + "^2 faces), not of the image itself"
                  : "the exact convolution of the source cube as given";
    folder.make();
    OutputSet outputs;  // this run's files or the previous ones, checked before the work
    const IrradianceFiles files = add_irradiance_files(outputs, a.out, a.format, a.encoding);
    Progress progress("ibl irradiance", a.quiet);
    const IrradianceMapResult r = compute_irradiance_map(source, spec, [&](std::uint64_t d, std::uint64_t t) { progress.update(d, t); });
    progress.finish();
    nlohmann::json meta = irradiance_map_metadata(spec, r);
    IrradianceVerification check;
    if (a.verify > 0) {
        check = verify_irradiance_map(source, r, a.verify);
        meta["verify"] = {{"texels", check.checked}, {"failed", check.failed}, {"worst_ratio", check.worst_ratio},
                          {"max_abs", check.max_abs}, {"worst", check.worst_texel}, {"reference", reference}};
        if (check.failed > 0)
            throw std::runtime_error("verification failed: " + std::to_string(check.failed) + " of " + std::to_string(check.checked) +
                                     " texels differ from " + reference + " by more than their bound (" + check.worst_texel +
                                     "); nothing was written");
    }
    write_irradiance_files(outputs, files, r, meta, a.exposure);
    commit_outputs(outputs, stale_irradiance_files(a.out, names_in(outputs, files.preview + 1)));
    folder.keep();
    if (!a.quiet) {
        std::cerr << std::setprecision(3) << "ibl irradiance: " << r.map.size << "^2 faces from " << r.source_size << "^2 (convolved at "
                  << r.convolution_size << "^2), " << r.seconds << " s on " << r.backend << "; max relative error bound "
                  << r.max_relative_bound << "\n";
        std::cerr << "order-2 SH vs direct: max |diff| " << r.sh_max_abs << " (" << r.sh_max_relative << " of the largest value, RMS "
                  << r.sh_rms_relative << "); SH truncation bound 3/32 int L / pi = " << r.sh_truncation_bound << "\n";
        if (a.verify > 0)
            std::cerr << "verify: " << check.checked << " texels against " << reference << ": max |diff| " << check.max_abs
                      << ", worst |diff| / bound " << check.worst_ratio << "\n";
    }
}

}  // namespace

void add_ibl_command(CLI::App& app) {
    auto* ibl = app.add_subcommand("ibl", "image-based lighting: the split-sum DFG LUT and environment irradiance");
    ibl->require_subcommand(1);

    auto d = std::make_shared<DfgArgs>();
    auto* dfg = ibl->add_subcommand("dfg", "bake the DFG LUT (x = NdotV, y = roughness; R, G, B = scale, bias, E) to OpenEXR, KTX2 or DDS");
    dfg->add_option("--out", d->out, "output .exr, .ktx2, .dds (RG for 2 channels, else RGBA; metadata in <file>.json), .png (16-bit), .h (C header) or .inc (C initialiser list)")->required();
    dfg->add_option("--method", d->method, "exact (Gauss-Legendre, ~1e-12), sampled (the VNDF kernel, error bars) or quadrature (the independent check)")
        ->check(CLI::IsMember({"exact", "sampled", "quadrature"}))
        ->capture_default_str();
    dfg->add_option("--channels", d->channels, "channels in order, 1-4 of scale, bias, E (= scale + bias), sheen (cloth); Filament: bias,E,sheen")
        ->capture_default_str();
    dfg->add_option("--parameterization", d->parameterization, "x axis: linear (NdotV) or sqrt-n-dot-v (HDRP: x = sqrt(NdotV))")
        ->check(CLI::IsMember({"linear", "sqrt-n-dot-v"}))
        ->capture_default_str();
    dfg->add_option("--symbol", d->symbol, "C array name of a .h output (macros SYMBOL_WIDTH, _HEIGHT, _CHANNELS)")->capture_default_str();
    dfg->add_option("--size", d->size, "texels on both axes")->transform(decimal_range(1, 4096))->capture_default_str();
    dfg->add_option("--size-n-dot-v", d->size_n_dot_v, "texels on the NdotV axis")->transform(decimal_range(1, 4096));
    dfg->add_option("--size-roughness", d->size_roughness, "texels on the roughness axis")->transform(decimal_range(1, 4096));
    dfg->add_option("--texel", d->texel, "centres (i + 0.5) / n or endpoints i / (n - 1)")
        ->check(CLI::IsMember({"centres", "centers", "endpoints"}))
        ->capture_default_str();
    dfg->add_option("--samples", d->samples, "--method sampled: VNDF samples per texel (all replicates)")
        ->transform(decimal_range(16, std::uint64_t(1) << 28))
        ->capture_default_str();
    dfg->add_option("--replicates", d->replicates, "--method sampled: independent scrambles (error bars)")->transform(decimal_range(2, 64))->capture_default_str();
    dfg->add_option("--seed", d->seed, "scramble seed")->transform(decimal_range(0, ~std::uint64_t(0)));
    dfg->add_option("--backend", d->backend, "older spelling of --method: opencl = sampled, oracle = quadrature")
        ->check(CLI::IsMember({"opencl", "oracle"}));
    dfg->add_option("--device", d->device, "default, all, an index or part of a name")->capture_default_str();
    dfg->add_option("--threads", d->threads, "host threads of --method exact / quadrature (0: all)")->transform(decimal_range(0, 1024));
    dfg->add_option("--verify", d->verify, "recompute K random texels by independent methods (exact: the quadrature to 1e-10 and the kernel within its bars); fail, writing nothing, on a disagreement")
        ->transform(decimal_range(0, 100000));
    dfg->add_option("--preview", d->preview, "also write a PNG of the channels with axes, each on its own scale");
    dfg->add_option("--compare", d->compare, "report max and RMS differences from a reference LUT of the same size (e.g. --backend oracle's)");
    dfg->add_option("--warp", d->warp, "sample warp towards the VNDF cap's rim: 1 (none), 2, 3")
        ->check(CLI::Range(1, 3))
        ->capture_default_str();
    dfg->add_flag("--half", d->half, "16-bit half floats");
    dfg->add_flag("--fast-math", d->fast_math, "build the kernel with -cl-fast-relaxed-math (recorded)");
    dfg->add_flag("--double-kernels", d->double_kernels, "run the kernel in double (cl_khr_fp64 devices)");
    dfg->add_flag("-q,--quiet", d->quiet, "no progress or summary");
    dfg->callback([d, dfg] {
        d->samples_given = dfg->count("--samples") > 0;
        d->replicates_given = dfg->count("--replicates") > 0;
        run_dfg(*d);
    });

    auto s = std::make_shared<ShArgs>();
    auto* sh = ibl->add_subcommand("sh", "order-2 spherical harmonics (9 per channel) and irradiance of an environment");
    sh->add_option("ENV", s->env, "equirectangular (2:1) or cross (4:3, 3:4) environment, .exr or Radiance .hdr");
    sh->add_option("--faces", s->faces, "instead of ENV: six square face files +X -X +Y -Y +Z -Z (docs/ibl.md: orientation)")->expected(6);
    sh->add_option("--out", s->out, "output JSON: coefficients, convolved irradiance coefficients, provenance")->required();
    sh->add_option("--irradiance", s->irradiance, "also write the irradiance cubemap (E / pi) as a horizontal-cross .exr");
    sh->add_option("--face-size", s->face_size, "irradiance cubemap face size")->transform(decimal_range(1, 1024))->capture_default_str();
    sh->add_option("--preview", s->preview, "PNG of the irradiance cross (Reinhard tone map, sRGB)");
    sh->add_option("--shader", s->shader, "also write the irradiance as shader constants and a function (.glsl or .hlsl; cmgen --sh-shader's form)");
    sh->add_option("--symbol", s->symbol, "name of the shader constants (NAME[9], NAME_irradiance)")->capture_default_str();
    sh->add_flag("-q,--quiet", s->quiet, "no summary");
    sh->callback([s] { run_sh(*s); });

    auto p = std::make_shared<PrefilterArgs>();
    auto* pf = ibl->add_subcommand("prefilter", "GGX-prefiltered specular cubemap mip chain (+ SH irradiance) of an environment, into a directory");
    pf->add_option("ENV", p->env, "environment: equirectangular (2:1) or a 4:3 / 3:4 cross, .exr or Radiance .hdr");
    pf->add_option("--faces", p->faces, "instead of ENV: six square face files +X -X +Y -Y +Z -Z, .exr or .hdr (docs/ibl.md: orientation)")->expected(6);
    pf->add_option("--out", p->out, "output directory (created)")->required();
    pf->add_option("--size", p->size, "base face size (power of two; default: from the source)")->transform(decimal_range(1, 4096));
    pf->add_option("--levels", p->levels, "mips (default: down to 4 x 4)")->transform(decimal_range(1, 13));
    pf->add_option("--mapping", p->mapping, "roughness per mip: cmgen (r = 1 - sqrt(1 - m / (levels - 1))) or linear")
        ->check(CLI::IsMember({"cmgen", "linear"}))
        ->capture_default_str();
    pf->add_option("--tolerance", p->tolerance,
                   "sample each texel until its relative 95% error bar (t over the replicates, + the explicit part's bound) is at most this; 0: a fixed --samples")
        ->check(real_range(0, 1))
        ->capture_default_str();
    pf->add_option("--samples", p->samples, "GGX samples per texel (all replicates): the first round's with a tolerance, else every texel's")
        ->transform(decimal_range(16, 1u << 20))
        ->capture_default_str();
    pf->add_option("--max-samples", p->max_samples, "with a tolerance, at most this many samples per texel")
        ->transform(decimal_range(16, 1u << 24))
        ->capture_default_str();
    pf->add_option("--replicates", p->replicates, "independent scrambles (error bars)")->transform(decimal_range(2, 64))->capture_default_str();
    pf->add_option("--bright", p->bright, "bright texels summed explicitly: auto (chosen for the tolerance) or off")
        ->check(CLI::IsMember({"auto", "off"}))
        ->capture_default_str();
    pf->add_option("--seed", p->seed, "scramble seed")->transform(decimal_range(0, ~std::uint64_t(0)));
    pf->add_flag("--no-fis", p->no_fis, "read every sample from the full-resolution source (brute-force importance sampling)");
    pf->add_option("--lod-bias", p->lod_bias, "filtered importance sampling's LOD bias, -16 to 16 (beyond, every read clamps to an end of the chain)")
        ->check(real_range(-16, 16))
        ->capture_default_str();
    pf->add_option("--bright-threshold", p->bright_threshold,
                   "sum texels brighter than this many times the mean radiance explicitly (the sun), sample the rest, instead of --bright auto's choice")
        ->check(real_range(0, 1e12));
    pf->add_option("--bright-min-roughness", p->bright_min_roughness, "the wide-lobe mips (bright texels, --wide-samples-factor): roughness at least this")
        ->check(real_range(0, 1))
        ->capture_default_str();
    pf->add_option("--wide-samples-factor", p->wide_samples_factor, "multiply --samples on the mips of roughness >= --bright-min-roughness")
        ->transform(decimal_range(1, 64))
        ->capture_default_str();
    pf->add_option("--bright-max", p->bright_max, "at most this many explicit bright texels (the brightest)")
        ->transform(decimal_range(1, 1u << 20))
        ->capture_default_str();
    pf->add_option("--device", p->device, "run the kernel on OpenCL devices (default, all, N, name); without it, C++ on CPU threads");
    pf->add_option("--threads", p->threads, "CPU threads (0: all)")->transform(decimal_range(0, 1024));
    pf->add_option("--verify", p->verify, "compare K random texels with the brute-force oracle; fail (exit 1, nothing written) when one is outside its bars (Bonferroni)")
        ->transform(decimal_range(0, 100000));
    pf->add_flag("--verify-report", p->verify_report, "with --verify: record the comparison in ibl.json but never fail (benchmarks of estimators whose bars are not honest)");
    pf->add_option("--format", p->format, "specular chain: exr (DIR/specular_m<m>.exr crosses), ktx2 or dds (DIR/specular.<format>: one cubemap with every mip, RGBA, A = 1)")
        ->check(CLI::IsMember({"exr", "ktx2", "dds"}))
        ->capture_default_str();
    pf->add_option("--encoding", p->encoding, "ktx2 / dds texels: float16 (RGBA16F) or float32")
        ->check(CLI::IsMember({"float16", "float32"}))
        ->capture_default_str();
    pf->add_option("--irradiance-size", p->irradiance_size, "irradiance cubemap face size")->transform(decimal_range(1, 1024))->capture_default_str();
    pf->add_option("--dfg-size", p->dfg_size, "also bake the DFG LUT (N x N, default settings) into DIR/dfg.<format> (exr, ktx2 or dds)")
        ->transform(decimal_range(0, 4096));
    pf->add_option("--exposure", p->exposure, "previews: exposure before the tone map (0 to 1e12)")->check(real_range(0, 1e12))->capture_default_str();
    pf->add_flag("-q,--quiet", p->quiet, "no progress or summary");
    pf->callback([p] { run_prefilter(*p); });

    auto q = std::make_shared<IrradianceArgs>();
    auto* ir = ibl->add_subcommand("irradiance", "irradiance cubemap (E / pi) by direct clamped-cosine convolution, with error bounds and SH comparison");
    ir->add_option("ENV", q->env, "environment: equirectangular (2:1) or a 4:3 / 3:4 cross, .exr or Radiance .hdr");
    ir->add_option("--faces", q->faces, "instead of ENV: six square face files +X -X +Y -Y +Z -Z, .exr or .hdr")->expected(6);
    ir->add_option("--out", q->out, "output directory (created): irradiance.<format>, irradiance.json, irradiance_preview.png")->required();
    ir->add_option("--face-size", q->face_size, "output face size")->transform(decimal_range(1, 1024))->capture_default_str();
    ir->add_option("--source-size", q->source_size, "convolve the source reduced to this face size (at least; solid-angle means, bounded error)")
        ->transform(decimal_range(1, 8192))
        ->capture_default_str();
    ir->add_option("--format", q->format, "exr (horizontal cross), ktx2 or dds (cubemap, RGBA, A = 1)")
        ->check(CLI::IsMember({"exr", "ktx2", "dds"}))
        ->capture_default_str();
    ir->add_option("--encoding", q->encoding, "ktx2 / dds texels: float16 or float32")->check(CLI::IsMember({"float16", "float32"}))->capture_default_str();
    ir->add_option("--backend", q->backend, "opencl (the kernel) or oracle (exact convolution of the full source, C++ double)")
        ->check(CLI::IsMember({"opencl", "oracle"}))
        ->capture_default_str();
    ir->add_option("--device", q->device, "default, all, an index or part of a name")->capture_default_str();
    ir->add_option("--threads", q->threads, "oracle threads (0: all)")->transform(decimal_range(0, 1024));
    ir->add_option("--verify", q->verify, "compare K random texels with the exact convolution; fail if one exceeds its bound")
        ->transform(decimal_range(0, 100000));
    ir->add_option("--exposure", q->exposure, "preview: exposure before the tone map (0 to 1e12)")->check(real_range(0, 1e12))->capture_default_str();
    ir->add_flag("-q,--quiet", q->quiet, "no progress or summary");
    ir->callback([q] { run_irradiance(*q); });
}

}  // namespace ms::cli
