#include "jobs/ibl_run.hpp"


#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "env/image.hpp"
#include "env/preview.hpp"
#include "io/atomic_file.hpp"
#include "platform/files.hpp"

namespace ms {

namespace fs = std::filesystem;

namespace {

// An optional output: its index in the set, or kNoFile when no path was given.
constexpr std::size_t kNoFile = ~std::size_t(0);
std::size_t add_if_given(OutputSet& outputs, const std::string& path) { return path.empty() ? kNoFile : outputs.add(path); }

const char* const kShCrossCaption =
    "irradiance E / pi from order-2 SH, horizontal cross: +Y top; -X, +Z, +X, -Z middle; -Y bottom";

std::string to_chars(double v) {
    std::ostringstream s;
    s << std::setprecision(3) << v;
    return s.str();
}

}  // namespace

void check_environment(const EnvironmentFiles& e) {
    if (e.image.empty() && e.faces.empty()) throw std::invalid_argument("give an environment: ENV (one image) or --faces PX NX PY NY PZ NZ");
    if (!e.image.empty() && !e.faces.empty()) throw std::invalid_argument("ENV and --faces both given: use one");
}

std::string environment_name(const EnvironmentFiles& e) {
    if (!e.image.empty()) return e.image;
    std::string s = "faces";
    for (const auto& f : e.faces) s += " " + f;
    return s;
}

OutputFolder::OutputFolder(std::string dir) : dir_(std::move(dir)) {
    if (dir_.empty()) throw OutputError("--out: empty folder name");
    std::error_code ec;
    const fs::path p = fs::path(dir_).lexically_normal();
    if (fs::exists(p, ec)) {
        if (!fs::is_directory(p, ec)) throw OutputError("--out " + dir_ + " exists and is not a directory");
        if (!platform::can_create_in(p.string())) throw OutputError("--out " + dir_ + ": the folder is not writable (" + std::strerror(errno) + ")");
        return;
    }
    // The folders to make, deepest first, up to the first that exists.
    for (fs::path q = p; !q.empty() && !fs::exists(q, ec); q = q.parent_path()) {
        to_make_.push_back(q.string());
        if (q == q.parent_path()) break;
    }
    const fs::path last = to_make_.back();
    const fs::path parent = last.parent_path().empty() ? fs::path(".") : last.parent_path();
    if (!fs::is_directory(parent, ec)) throw OutputError("--out " + dir_ + ": " + parent.string() + " is not a directory");
    if (!platform::can_create_in(parent.string()))
        throw OutputError("--out " + dir_ + ": cannot create it in " + parent.string() + " (" + std::strerror(errno) + ")");
}

OutputFolder::~OutputFolder() {
    if (kept_) return;
    std::error_code ec;
    for (const auto& q : made_) fs::remove(q, ec);  // only empty folders go (remove fails on others)
}

void OutputFolder::make() {
    for (auto it = to_make_.rbegin(); it != to_make_.rend(); ++it) {
        std::error_code ec;
        if (!fs::create_directory(*it, ec) && ec) throw OutputError("--out " + dir_ + ": cannot create " + *it + " (" + ec.message() + ")");
        made_.insert(made_.begin(), *it);
    }
    to_make_.clear();
}

std::set<std::string> names_in(const OutputSet& outputs, std::size_t count) {
    std::set<std::string> names;
    for (std::size_t i = 0; i < count; ++i) names.insert(fs::path(outputs.target(i).named).filename().string());
    return names;
}

// --- ibl dfg ---------------------------------------------------------------------------------------------

DfgJobResult run_dfg_job(const DfgJobSpec& spec, const JobCallbacks& callbacks) {
    JobControl control(callbacks);
    if (!spec.out.empty()) check_dfg_lut_output(spec.out, spec.bake.channels, spec.symbol);
    validate(spec.bake);
    // Every output checked, and two at one path refused, before the bake.
    OutputSet outputs;
    DfgLutFiles lut_files;
    if (!spec.out.empty()) lut_files = add_dfg_lut_files(outputs, spec.out);
    const std::size_t preview = add_if_given(outputs, spec.preview);

    DfgJobResult r;
    DfgBakeCallbacks cb;
    cb.progress = control.progress();
    r.bake = bake_dfg(spec.bake, cb);
    control.checkpoint();
    r.metadata = dfg_metadata(spec.bake, r.bake);
    if (spec.verify > 0) {
        const DfgVerification& check = *(r.verification = verify_dfg(spec.bake, r.bake, spec.verify));
        r.metadata["verify"] = {{"texels", check.checked}, {"failed", check.failed}, {"reference", check.reference},
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
    if (!spec.compare.empty()) {
        const DfgComparison& cmp = *(r.comparison = compare_dfg(r.bake, spec.compare));
        r.metadata["compare"] = {{"reference", spec.compare},
                                 {"max_abs", {cmp.max_abs[0], cmp.max_abs[1], cmp.max_abs[2]}},
                                 {"rms", {cmp.rms[0], cmp.rms[1], cmp.rms[2]}}};
    }
    control.checkpoint();
    if (preview != kNoFile) write_dfg_preview_file(outputs.temp_path(preview), r.bake, spec.bake);
    if (!spec.out.empty()) write_dfg_lut(outputs, lut_files, r.bake, r.metadata, spec.half, spec.symbol);
    commit_outputs(outputs);
    return r;
}

std::string dfg_job_summary(const DfgJobSpec& spec, const DfgJobResult& r) {
    const DfgBakeResult& result = r.bake;
    std::ostringstream s;
    s << std::setprecision(3) << "ibl dfg: " << result.width << " x " << result.height << " (NdotV x roughness), "
      << (spec.bake.method == DfgMethod::sampled
              ? std::to_string(spec.bake.plan.samples) + " samples per texel, max std error " + to_chars(result.max_std_error)
              : std::string(to_string(spec.bake.method)) + ", max error estimate " + to_chars(result.max_exact_error))
      << ", computed in " << result.seconds << " s on " << result.backend << "\n";
    if (const auto& cmp = r.comparison)
        s << "compare: max |diff| scale " << cmp->max_abs[0] << " bias " << cmp->max_abs[1] << " E " << cmp->max_abs[2] << " (worst texel "
          << cmp->worst_x << ", " << cmp->worst_y << "); rms " << cmp->rms[0] << " " << cmp->rms[1] << " " << cmp->rms[2] << "; bake "
          << result.seconds << " s\n";
    if (const auto& check = r.verification)
        s << "verify: " << check->checked << " texels against " << check->reference << ": worst z " << check->worst_z << " (limit "
          << check->threshold << "), worst |diff| " << check->worst_abs_diff
          << (check->deterministic_tolerance > 0 ? ", worst deterministic |diff| " + to_chars(check->worst_deterministic_diff) +
                                                       " (limit " + to_chars(check->deterministic_tolerance) + ")"
                                                 : std::string())
          << "\n";
    return s.str();
}

// --- ibl sh ----------------------------------------------------------------------------------------------

ShJobResult run_sh_job(const ShJobSpec& spec) {
    check_environment(spec.environment);
    OutputSet outputs;  // all of the files or none; two at one path refused here
    const std::size_t json = outputs.add(spec.out);
    // The irradiance cubemap in the format its extension picks (.exr: a cross; .ktx2 / .dds: a cubemap, float16).
    std::optional<lutfmt::TextureFiles> irradiance;
    if (!spec.irradiance.empty())
        irradiance = lutfmt::add_texture_files(outputs, spec.irradiance,
                                               lutfmt::texture_format_for_path(spec.irradiance, lutfmt::TextureUse::cubemap));
    const std::size_t preview = add_if_given(outputs, spec.preview);
    if (!spec.shader.empty()) check_sh_shader_output(spec.shader, spec.symbol);
    const std::size_t shader = add_if_given(outputs, spec.shader);
    // Equirectangular images are projected texel by texel (exact texel integrals); crosses and face files as
    // cubemaps. The cross is needed for the EXR and for the preview alike.
    const std::uint32_t faces = spec.irradiance.empty() && spec.preview.empty() ? 0 : spec.face_size;
    ShJobResult r;
    if (!spec.environment.faces.empty()) {
        r.irradiance = compute_irradiance(env::read_cubemap_faces(spec.environment.faces), faces);
    } else {
        const env::Image image = env::read_environment_image(spec.environment.image);
        r.image_width = image.width, r.image_height = image.height;
        r.irradiance = image.width == 2 * image.height ? compute_irradiance(image, faces)
                                                       : compute_irradiance(env::cubemap_from_image(image), faces);
    }
    const std::string source = environment_name(spec.environment);
    const nlohmann::json meta = irradiance_metadata(r.irradiance, source, spec.command_line);
    outputs.stream(json) << meta.dump(2) << "\n";
    if (irradiance) write_irradiance_map(outputs, *irradiance, r.irradiance.irradiance_cross, "float16", meta);
    if (preview != kNoFile)
        env::write_png_file(outputs.temp_path(preview), env::cross_preview_canvas(r.irradiance.irradiance_cross, 1.0, kShCrossCaption));
    if (shader != kNoFile)
        outputs.stream(shader) << sh_shader_source(r.irradiance.sh, spec.shader, spec.symbol,
                                                   "   source: " + source + "\n   command: " + spec.command_line +
                                                       "\n   version: " + MICROSHADOW_VERSION);
    commit_outputs(outputs);
    return r;
}

std::string sh_job_summary(const ShJobSpec& spec, const ShJobResult& r) {
    std::ostringstream s;
    s << "ibl sh: "
      << (spec.environment.faces.empty() ? std::to_string(r.image_width) + " x " + std::to_string(r.image_height) + " environment"
                                         : "six " + std::to_string(r.irradiance.face_size) + "^2 faces")
      << ", 9 coefficients per channel; "
      << "irradiance SH vs brute force at 26 normals: max relative difference " << std::setprecision(3)
      << r.irradiance.max_relative_sh_error << "\n";
    return s.str();
}

// --- ibl prefilter ---------------------------------------------------------------------------------------

PrefilterJobResult run_prefilter_job(const PrefilterJobSpec& job, const JobCallbacks& callbacks) {
    JobControl control(callbacks);
    check_environment(job.environment);
    OutputFolder folder(job.out);
    if (job.size && (job.size & (job.size - 1))) throw std::invalid_argument("--size must be a power of two");
    PrefilterSpec spec = job.prefilter;
    spec.source = environment_name(job.environment);

    env::Cubemap source = job.environment.faces.empty() ? env::cubemap_from_image(env::read_environment_image(job.environment.image), job.size)
                                                        : env::read_cubemap_faces(job.environment.faces);
    if (source.size & (source.size - 1))
        throw std::invalid_argument("the face size must be a power of two (it is " + std::to_string(source.size) + ")");
    if (job.size > source.size)
        throw std::invalid_argument("--size " + std::to_string(job.size) + " is larger than the cross's faces (" + std::to_string(source.size) + ")");
    if (job.size && source.size != job.size) source = env::mip_chain(source).at(std::size_t(std::log2(double(source.size) / job.size)));
    if (spec.levels && (source.size >> (spec.levels - 1)) == 0)
        throw std::invalid_argument("--levels " + std::to_string(spec.levels) + " is too many for faces of " + std::to_string(source.size));
    const std::uint32_t levels = spec.levels ? spec.levels : default_levels(source.size);

    // Every file of the run is one set, checked before the work: this run's files, or the previous ones.
    folder.make();
    OutputSet outputs;
    const PrefilterFiles specular = add_prefilter_files(outputs, job.out, levels, job.format, job.encoding);
    // The SH irradiance in the chain's format: a cross for exr, one cubemap level for ktx2 / dds.
    const lutfmt::TextureFiles irradiance_map = add_irradiance_map(outputs, job.out, job.format, job.encoding);
    const std::size_t irradiance_png = outputs.add(job.out + "/irradiance_preview.png");
    const std::size_t sh_json = outputs.add(job.out + "/sh.json");
    const std::size_t ibl_json = outputs.add(job.out + "/ibl.json");
    DfgLutFiles dfg_files;
    std::size_t dfg_preview = kNoFile;
    if (job.dfg_size > 0) {
        dfg_files = add_dfg_lut_files(outputs, lutfmt::file_name(job.out + "/dfg", specular.format));
        dfg_preview = outputs.add(job.out + "/dfg_preview.png");
    }
    const std::size_t file_count = dfg_preview != kNoFile ? dfg_preview + 1 : ibl_json + 1;

    PrefilterJobResult r;
    r.source_size = source.size;
    PrefilterCallbacks cb;
    cb.progress = control.progress();
    r.result = prefilter_cubemap(source, spec, cb);
    control.checkpoint();
    r.metadata = prefilter_metadata(spec, r.result);
    if (job.verify > 0) {
        const PrefilterVerification& check = *(r.verification = verify_prefilter(source, r.result, job.verify));
        r.metadata["verify"] = verification_json(check);
        if (!check.passed && !job.verify_report) {
            std::ostringstream s;
            s << std::setprecision(3) << "verification failed: " << check.checked << " texels against the brute-force oracle, worst z "
              << check.worst_z << " beyond the Bonferroni bound " << check.z_bound << " (" << check.worst_z_texel << "); nothing was written";
            throw std::runtime_error(s.str());
        }
    }
    r.irradiance = compute_irradiance(source, job.irradiance_size);
    r.irradiance_metadata = irradiance_metadata(r.irradiance, spec.source, spec.command_line);
    DfgBakeSpec dspec;
    if (job.dfg_size > 0) {
        control.checkpoint();
        dspec.n_dot_v.count = dspec.roughness.count = job.dfg_size;
        dspec.command_line = spec.command_line;
        r.dfg = bake_dfg(dspec);
    }
    control.checkpoint();

    write_prefilter_files(outputs, specular, r.result, r.metadata, job.exposure);
    const env::Image& cross = r.irradiance.irradiance_cross;
    write_irradiance_map(outputs, irradiance_map, cross, job.encoding, r.irradiance_metadata);
    env::write_png_file(outputs.temp_path(irradiance_png), env::cross_preview_canvas(cross, job.exposure, kShCrossCaption));
    outputs.stream(sh_json) << r.irradiance_metadata.dump(2) << "\n";
    outputs.stream(ibl_json) << nlohmann::json{{"specular", r.metadata}, {"irradiance", r.irradiance_metadata}}.dump(2) << "\n";
    if (r.dfg) {
        write_dfg_preview_file(outputs.temp_path(dfg_preview), *r.dfg, dspec);
        write_dfg_lut(outputs, dfg_files, *r.dfg, dfg_metadata(dspec, *r.dfg));  // ktx2 / dds: float32
    }
    commit_outputs(outputs, stale_prefilter_files(job.out, names_in(outputs, file_count)));
    folder.keep();
    return r;
}

std::string prefilter_job_summary(const PrefilterJobSpec& job, const PrefilterJobResult& r) {
    const PrefilterResult& result = r.result;
    const PrefilterSpec& spec = job.prefilter;
    std::ostringstream s;
    s << std::setprecision(3) << "ibl prefilter: " << result.mips.size() << " mips from " << r.source_size << "^2 faces ("
      << to_string(spec.mapping) << " roughness), " << (spec.options.filtered ? "filtered" : "unfiltered") << " importance sampling, "
      << result.bright_texels << " bright texels summed explicitly (" << 100 * result.bright_power_fraction << "% of the power), "
      << double(result.samples) / double(std::max<std::uint64_t>(1, result.texels)) << " samples per texel on average, computed in " << result.seconds
      << " s (" << result.cpu_seconds << " CPU s); largest relative 95% bar " << result.max_relative_bar;
    if (spec.tolerance > 0)
        s << " (tolerance " << spec.tolerance
          << (result.unconverged ? ", " + std::to_string(result.unconverged) + " texels above it at --max-samples" : "") << ")";
    s << "\n";
    s << "ibl sh: irradiance SH vs brute force: max relative difference " << r.irradiance.max_relative_sh_error << "\n";
    if (const auto& check = r.verification)
        s << "verify: " << check->checked << " texels against the brute-force oracle: relative RMS " << check->rms_relative << ", max "
          << check->max_relative << ", worst z " << check->worst_z << " (Bonferroni bound " << check->z_bound << ")\n";
    return s.str();
}

// --- ibl irradiance --------------------------------------------------------------------------------------

IrradianceJobResult run_irradiance_job(const IrradianceJobSpec& job, const JobCallbacks& callbacks) {
    JobControl control(callbacks);
    check_environment(job.environment);
    OutputFolder folder(job.out);
    IrradianceMapSpec spec = job.map;
    spec.source = environment_name(job.environment);
    // Equirectangular images are resampled to a cubemap of height / 2 (a power of two), crosses and faces kept.
    bool resampled = false;
    const env::Cubemap source = [&] {
        if (!job.environment.faces.empty()) return env::read_cubemap_faces(job.environment.faces);
        const env::Image image = env::read_environment_image(job.environment.image);
        resampled = image.width == 2 * image.height;
        return env::cubemap_from_image(image);
    }();
    IrradianceJobResult r;
    // What verification compares with: the exact convolution of the cube the map is computed from, which
    // for an equirectangular image is its resampling, not the image itself (whose difference is larger).
    r.reference = resampled ? "the exact convolution of the resampled cube (ENV's equirectangular image resampled to " +
                                  std::to_string(source.size) + "^2 faces), not of the image itself"
                            : "the exact convolution of the source cube as given";
    folder.make();
    OutputSet outputs;  // this run's files or the previous ones, checked before the work
    const IrradianceFiles files = add_irradiance_files(outputs, job.out, job.format, job.encoding);
    r.result = compute_irradiance_map(source, spec, control.progress());
    control.checkpoint();
    r.metadata = irradiance_map_metadata(spec, r.result);
    if (job.verify > 0) {
        const IrradianceVerification& check = *(r.verification = verify_irradiance_map(source, r.result, job.verify));
        r.metadata["verify"] = {{"texels", check.checked}, {"failed", check.failed}, {"worst_ratio", check.worst_ratio},
                                {"max_abs", check.max_abs}, {"worst", check.worst_texel}, {"reference", r.reference}};
        if (check.failed > 0)
            throw std::runtime_error("verification failed: " + std::to_string(check.failed) + " of " + std::to_string(check.checked) +
                                     " texels differ from " + r.reference + " by more than their bound (" + check.worst_texel +
                                     "); nothing was written");
    }
    control.checkpoint();
    write_irradiance_files(outputs, files, r.result, r.metadata, job.exposure);
    commit_outputs(outputs, stale_irradiance_files(job.out, names_in(outputs, files.preview + 1)));
    folder.keep();
    return r;
}

std::string irradiance_job_summary(const IrradianceJobSpec&, const IrradianceJobResult& r) {
    const IrradianceMapResult& m = r.result;
    std::ostringstream s;
    s << std::setprecision(3) << "ibl irradiance: " << m.map.size << "^2 faces from " << m.source_size << "^2 (convolved at "
      << m.convolution_size << "^2), computed in " << m.seconds << " s on " << m.backend << "; max relative error bound " << m.max_relative_bound << "\n";
    s << "order-2 SH vs direct: max |diff| " << m.sh_max_abs << " (" << m.sh_max_relative << " of the largest value, RMS "
      << m.sh_rms_relative << "); SH truncation bound 3/32 int L / pi = " << m.sh_truncation_bound << "\n";
    if (const auto& check = r.verification)
        s << "verify: " << check->checked << " texels against " << r.reference << ": max |diff| " << check->max_abs
          << ", worst |diff| / bound " << check->worst_ratio << "\n";
    return s.str();
}

}  // namespace ms
