// microshadow::prefilter, irradiance and spherical_harmonics: `microshadow ibl prefilter | irradiance |
// sh` (cli/cmd_ibl.cpp) as calls. The same jobs run (jobs/ibl_prefilter.hpp, ibl_irradiance.hpp,
// ibl_env.hpp); the results are handed back, and save() writes the command's files.
#include <cmath>
#include <filesystem>
#include <set>
#include <algorithm>
#include <stdexcept>

#include "api/facade.hpp"
#include "env/cubemap.hpp"
#include "env/image.hpp"
#include "env/preview.hpp"
#include "env/sh.hpp"
#include "io/atomic_file.hpp"
#include "jobs/ibl_env.hpp"
#include "jobs/ibl_irradiance.hpp"
#include "jobs/ibl_prefilter.hpp"
#include "jobs/ibl_run.hpp"
#include "microshadow/ibl.hpp"
#include "sampling/point_set.hpp"

namespace microshadow {

namespace fs = std::filesystem;

namespace {

const char* const kIblCommandLine = "microshadow::ibl (library " MICROSHADOW_VERSION ")";
const char* const kShCrossCaption =
    "irradiance E / pi from order-2 SH, horizontal cross: +Y top; -X, +Z, +X, -Z middle; -Y bottom";

void check_source(const EnvironmentSource& e, const char* where) {
    if (e.image.empty() == e.faces.empty())
        throw std::invalid_argument(std::string(where) + ": give an environment: an image or six face files, one of them");
    if (!e.faces.empty() && e.faces.size() != 6)
        throw std::invalid_argument(std::string(where) + ": faces: " + std::to_string(e.faces.size()) +
                                    " files; six (+X -X +Y -Y +Z -Z)");
}

// The command's name of the source in provenance.
std::string source_name(const EnvironmentSource& e) { return ms::environment_name({e.image, e.faces}); }

CubeImage to_cube(const ms::env::Cubemap& c) {
    CubeImage out;
    out.size = c.size;
    out.texels.reserve(std::size_t(6) * c.size * c.size * 3);
    for (const auto& face : c.faces) out.texels.insert(out.texels.end(), face.data.begin(), face.data.end());
    return out;
}

std::vector<double> sh_values(const ms::env::Sh9& sh) {
    std::vector<double> out;
    for (const auto& k : sh)
        for (double v : k) out.push_back(v);
    return out;
}

// The output folder of save(): made if missing, and removed again (only if still empty) when the
// writing fails, so that a failed save leaves nothing behind.
class OutputFolder {
public:
    explicit OutputFolder(const std::string& dir) {
        if (dir.empty()) throw std::invalid_argument("save: an empty folder name");
        std::error_code ec;
        if (fs::exists(dir, ec)) {
            if (!fs::is_directory(dir, ec)) throw std::invalid_argument("save: " + dir + " exists and is not a folder");
            return;
        }
        for (fs::path p = fs::path(dir).lexically_normal(); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
            made_.push_back(p);
            if (p == p.parent_path()) break;
        }
        fs::create_directories(dir, ec);
        if (ec) throw std::invalid_argument("save: cannot create " + dir + " (" + ec.message() + ")");
    }
    ~OutputFolder() {
        if (kept_) return;
        std::error_code ec;
        for (const auto& p : made_) fs::remove(p, ec);  // deepest first; remove() leaves a non-empty folder
    }
    void keep() { kept_ = true; }

private:
    std::vector<fs::path> made_;
    bool kept_ = false;
};

// The environment as `ibl prefilter` reads it: resampled to `size` (0: the source's), a power of two.
ms::env::Cubemap prefilter_source(const EnvironmentSource& e, std::uint32_t size) {
    if (size && (size & (size - 1))) throw std::invalid_argument("microshadow::prefilter: size must be a power of two");
    ms::env::Cubemap source = e.faces.empty() ? ms::env::cubemap_from_image(ms::env::read_environment_image(e.image), size)
                                              : ms::env::read_cubemap_faces(e.faces);
    if (source.size & (source.size - 1))
        throw std::invalid_argument("microshadow::prefilter: the face size must be a power of two (it is " +
                                    std::to_string(source.size) + ")");
    if (size > source.size)
        throw std::invalid_argument("microshadow::prefilter: size " + std::to_string(size) + " is larger than the cross's faces (" +
                                    std::to_string(source.size) + ")");
    if (size && source.size != size)
        source = ms::env::mip_chain(source).at(std::size_t(std::log2(double(source.size) / size)));
    return source;
}

}  // namespace

// --- prefilter -------------------------------------------------------------------------------------------

struct PrefilteredEnvironment::Data {
    ms::PrefilterResult result;
    ms::IrradianceResult irradiance;
    nlohmann::json specular_metadata, irradiance_metadata;
};

PrefilteredEnvironment::PrefilteredEnvironment(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::PrefilteredEnvironment: no data");
}

PrefilteredEnvironment prefilter(const PrefilterOptions& o, const Progress& progress) {
    if (o.bright != "auto" && o.bright != "off")
        throw std::invalid_argument("microshadow::prefilter: bright = '" + o.bright + "' (auto or off)");
    check_source(o.environment, "microshadow::prefilter");
    if (o.replicates < 2) throw std::invalid_argument("microshadow::prefilter: replicates = " + std::to_string(o.replicates) + " (at least 2)");
    ms::PrefilterSpec spec;
    spec.mapping = ms::env::parse_roughness_mapping(o.mapping);
    spec.levels = o.levels;
    spec.plan.replicates = o.replicates;
    spec.plan.samples = ms::round_up_samples(o.samples, o.replicates);
    spec.plan.seed = o.seed;
    spec.options.filtered = o.fis;
    spec.options.lod_bias = o.lod_bias;
    spec.tolerance = o.tolerance;
    spec.max_samples = std::max(o.max_samples, o.samples);
    spec.bright_auto = o.bright == "auto";
    spec.bright_threshold = o.bright_threshold;
    spec.bright_max_texels = o.bright_max;
    spec.bright_min_roughness = o.bright_min_roughness;
    spec.wide_samples_factor = o.wide_samples_factor;
    // PrefilterOptions: no device names the C++ estimator on CPU threads (the oracle kind).
    spec.backend = detail::backend_spec(o.device.empty() ? Backend::oracle : Backend::opencl, o.device, o.threads);
    spec.source = source_name(o.environment);
    spec.command_line = kIblCommandLine;
    const ms::env::Cubemap source = prefilter_source(o.environment, o.size);
    if (spec.levels && (source.size >> (spec.levels - 1)) == 0)
        throw std::invalid_argument("microshadow::prefilter: levels " + std::to_string(spec.levels) + " is too many for faces of " +
                                    std::to_string(source.size));
    auto data = std::make_shared<PrefilteredEnvironment::Data>();
    data->result = detail::run_with_progress(progress, [&](const auto& report) {
        ms::PrefilterCallbacks callbacks;
        callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { report(done, total); };
        return ms::prefilter_cubemap(source, spec, callbacks);
    });
    data->specular_metadata = ms::prefilter_metadata(spec, data->result);
    if (o.verify > 0) {
        const ms::PrefilterVerification check = ms::verify_prefilter(source, data->result, o.verify);
        data->specular_metadata["verify"] = ms::verification_json(check);
        if (!check.passed)
            throw std::runtime_error("microshadow::prefilter: verification failed: worst z " + std::to_string(check.worst_z) +
                                     " beyond the Bonferroni bound " + std::to_string(check.z_bound) + " (" + check.worst_z_texel + ")");
    }
    data->irradiance = ms::compute_irradiance(source, o.irradiance_size);
    data->irradiance_metadata = ms::irradiance_metadata(data->irradiance, spec.source, kIblCommandLine);
    return PrefilteredEnvironment(std::move(data));
}

std::vector<double> PrefilteredEnvironment::mip_roughness() const { return data_->result.roughness; }
std::size_t PrefilteredEnvironment::mip_count() const { return data_->result.mips.size(); }
CubeImage PrefilteredEnvironment::mip(std::size_t m) const {
    if (m >= data_->result.mips.size())
        throw std::out_of_range("mip " + std::to_string(m) + ": the chain has " + std::to_string(data_->result.mips.size()));
    return to_cube(data_->result.mips[m]);
}
CubeImage PrefilteredEnvironment::irradiance() const { return to_cube(ms::env::cubemap_from_cross(data_->irradiance.irradiance_cross)); }
std::vector<double> PrefilteredEnvironment::sh() const { return sh_values(data_->irradiance.sh); }
std::string PrefilteredEnvironment::metadata_json() const {
    return nlohmann::json{{"specular", data_->specular_metadata}, {"irradiance", data_->irradiance_metadata}}.dump();
}

void PrefilteredEnvironment::save(const std::string& dir, const std::string& format, const std::string& encoding,
                                  double exposure) const {
    // The file set of `ibl prefilter` without --dfg-size (cli/cmd_ibl.cpp: run_prefilter).
    OutputFolder folder(dir);
    ms::OutputSet outputs;
    const auto levels = std::uint32_t(data_->result.mips.size());
    const ms::PrefilterFiles specular = ms::add_prefilter_files(outputs, dir, levels, format, encoding);
    const ms::lutfmt::TextureFiles irradiance_map = ms::add_irradiance_map(outputs, dir, format, encoding);
    const std::size_t irradiance_png = outputs.add(dir + "/irradiance_preview.png");
    const std::size_t sh_json = outputs.add(dir + "/sh.json");
    const std::size_t ibl_json = outputs.add(dir + "/ibl.json");
    const ms::IrradianceResult& irr = data_->irradiance;
    ms::write_prefilter_files(outputs, specular, data_->result, data_->specular_metadata, exposure);
    ms::write_irradiance_map(outputs, irradiance_map, irr.irradiance_cross, encoding, data_->irradiance_metadata);
    ms::env::write_png_file(outputs.temp_path(irradiance_png), ms::env::cross_preview_canvas(irr.irradiance_cross, exposure, kShCrossCaption));
    outputs.stream(sh_json) << data_->irradiance_metadata.dump(2) << "\n";
    outputs.stream(ibl_json) << nlohmann::json{{"specular", data_->specular_metadata}, {"irradiance", data_->irradiance_metadata}}.dump(2)
                             << "\n";
    ms::commit_outputs(outputs, ms::stale_prefilter_files(dir, ms::names_in(outputs, ibl_json + 1)));
    folder.keep();
}

// --- irradiance ------------------------------------------------------------------------------------------

struct IrradianceMap::Data {
    ms::IrradianceMapResult result;
    nlohmann::json metadata;
};

IrradianceMap::IrradianceMap(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::IrradianceMap: no data");
}

IrradianceMap irradiance(const IrradianceOptions& o, const Progress& progress) {
    check_source(o.environment, "microshadow::irradiance");
    ms::IrradianceMapSpec spec;
    spec.face_size = o.face_size;
    spec.source_size = o.source_size;
    spec.backend = detail::backend_spec(o.backend, o.device, o.threads);
    spec.source = source_name(o.environment);
    spec.command_line = kIblCommandLine;
    // As the command: an equirectangular image is resampled to a cubemap, crosses and faces kept.
    bool resampled = false;
    const ms::env::Cubemap source = [&] {
        if (!o.environment.faces.empty()) return ms::env::read_cubemap_faces(o.environment.faces);
        const ms::env::Image image = ms::env::read_environment_image(o.environment.image);
        resampled = image.width == 2 * image.height;
        return ms::env::cubemap_from_image(image);
    }();
    auto data = std::make_shared<IrradianceMap::Data>();
    data->result = detail::run_with_progress(progress, [&](const auto& report) {
        return ms::compute_irradiance_map(source, spec, [&](std::uint64_t done, std::uint64_t total) { report(done, total); });
    });
    data->metadata = ms::irradiance_map_metadata(spec, data->result);
    if (o.verify > 0) {
        const std::string reference =
            resampled ? "the exact convolution of the resampled cube (the equirectangular image resampled to " +
                            std::to_string(source.size) + "^2 faces), not of the image itself"
                      : "the exact convolution of the source cube as given";
        const ms::IrradianceVerification check = ms::verify_irradiance_map(source, data->result, o.verify);
        data->metadata["verify"] = {{"texels", check.checked}, {"failed", check.failed}, {"worst_ratio", check.worst_ratio},
                                    {"max_abs", check.max_abs}, {"worst", check.worst_texel}, {"reference", reference}};
        if (check.failed > 0)
            throw std::runtime_error("microshadow::irradiance: verification failed: " + std::to_string(check.failed) + " of " +
                                     std::to_string(check.checked) + " texels differ from " + reference +
                                     " by more than their bound (" + check.worst_texel + ")");
    }
    return IrradianceMap(std::move(data));
}

CubeImage IrradianceMap::map() const { return to_cube(data_->result.map); }
CubeImage IrradianceMap::bound() const { return to_cube(data_->result.bound); }
std::string IrradianceMap::metadata_json() const { return data_->metadata.dump(); }

void IrradianceMap::save(const std::string& dir, const std::string& format, const std::string& encoding, double exposure) const {
    OutputFolder folder(dir);
    ms::OutputSet outputs;
    const ms::IrradianceFiles files = ms::add_irradiance_files(outputs, dir, format, encoding);
    ms::write_irradiance_files(outputs, files, data_->result, data_->metadata, exposure);
    ms::commit_outputs(outputs, ms::stale_irradiance_files(dir, ms::names_in(outputs, files.preview + 1)));
    folder.keep();
}

// --- spherical harmonics ---------------------------------------------------------------------------------

struct ShIrradiance::Data {
    ms::IrradianceResult result;
    nlohmann::json metadata;
    std::string source;
};

ShIrradiance::ShIrradiance(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::ShIrradiance: no data");
}

ShIrradiance spherical_harmonics(const EnvironmentSource& e, std::uint32_t face_size) {
    check_source(e, "microshadow::spherical_harmonics");
    auto data = std::make_shared<ShIrradiance::Data>();
    // As `ibl sh`: an equirectangular image projected texel by texel, crosses and face files as cubemaps.
    if (!e.faces.empty()) {
        data->result = ms::compute_irradiance(ms::env::read_cubemap_faces(e.faces), face_size);
    } else {
        const ms::env::Image image = ms::env::read_environment_image(e.image);
        data->result = image.width == 2 * image.height ? ms::compute_irradiance(image, face_size)
                                                       : ms::compute_irradiance(ms::env::cubemap_from_image(image), face_size);
    }
    data->source = source_name(e);
    data->metadata = ms::irradiance_metadata(data->result, data->source, kIblCommandLine);
    return ShIrradiance(std::move(data));
}

std::vector<double> ShIrradiance::sh() const { return sh_values(data_->result.sh); }
CubeImage ShIrradiance::irradiance() const {
    if (data_->result.face_size == 0) return {};
    return to_cube(ms::env::cubemap_from_cross(data_->result.irradiance_cross));
}
std::string ShIrradiance::metadata_json() const { return data_->metadata.dump(); }

void ShIrradiance::save(const std::string& json_path, const std::string& irradiance_path, const std::string& preview_path,
                        const std::string& shader_path, const std::string& symbol) const {
    if ((!irradiance_path.empty() || !preview_path.empty()) && data_->result.face_size == 0)
        throw std::invalid_argument("save: the irradiance cubemap was not computed (face_size 0)");
    ms::OutputSet outputs;
    const std::size_t json = outputs.add(json_path);
    constexpr std::size_t kNone = ~std::size_t(0);
    const std::size_t irradiance = irradiance_path.empty() ? kNone : outputs.add(irradiance_path);
    const std::size_t preview = preview_path.empty() ? kNone : outputs.add(preview_path);
    if (!shader_path.empty()) ms::check_sh_shader_output(shader_path, symbol);
    const std::size_t shader = shader_path.empty() ? kNone : outputs.add(shader_path);
    outputs.stream(json) << data_->metadata.dump(2) << "\n";
    if (irradiance != kNone)
        ms::env::write_exr_file(outputs.temp_path(irradiance), irradiance_path, data_->result.irradiance_cross, data_->metadata);
    if (preview != kNone)
        ms::env::write_png_file(outputs.temp_path(preview), ms::env::cross_preview_canvas(data_->result.irradiance_cross, 1.0, kShCrossCaption));
    if (shader != kNone)
        outputs.stream(shader) << ms::sh_shader_source(data_->result.sh, shader_path, symbol,
                                                       "   source: " + data_->source + "\n   command: " + kIblCommandLine +
                                                           "\n   version: " + MICROSHADOW_VERSION);
    ms::commit_outputs(outputs);
}

}  // namespace microshadow
