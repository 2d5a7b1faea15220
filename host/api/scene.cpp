// microshadow::scene: `microshadow scene` (cli/cmd_scene.cpp) as a call; the same job (jobs/scene.hpp)
// runs, and its images and report are handed back instead of written (SceneResult::save writes them).
#include "microshadow/scene.hpp"

#include <stdexcept>

#include "api/facade.hpp"
#include "core/memory.hpp"
#include "jobs/scene.hpp"
#include "scene/description.hpp"
#include "scene/inputs.hpp"

namespace microshadow {

struct SceneResult::Data {
    ms::scene::SceneResult result;
    nlohmann::json provenance;
};

SceneResult::SceneResult(std::shared_ptr<const Data> data) : data_(std::move(data)) {
    if (!data_) throw std::invalid_argument("microshadow::SceneResult: no data");
}

namespace {

// Half the physical memory, the command's limit on the output images (0: unknown, no limit).
std::uint64_t half_physical_memory() {
    return ms::physical_memory() / 2;
}

}  // namespace

SceneResult scene(const std::string& description_path, const SceneOptions& o, const Progress& progress) {
    if (o.tolerance != 0 && !(o.tolerance >= 1e-12 && o.tolerance <= 0.5))
        throw std::invalid_argument("microshadow::scene: tolerance = " + std::to_string(o.tolerance) + " (1e-12 to 0.5, or 0: the description's)");
    if (detail::backend_spec(o.backend, o.device).is_oracle() && o.fast_math)
        throw std::invalid_argument("microshadow::scene: fast_math builds kernels; the oracle has none");
    const ms::scene::SceneDescription description = ms::scene::load_scene(description_path);
    const ms::scene::SceneInputs inputs = ms::scene::SceneInputs::load(description);
    auto backend = detail::make_backend(o.backend, o.device, o.fast_math);

    ms::scene::SceneRunOptions options;
    options.skip = o.skip;
    options.tolerance = o.tolerance;
    if (o.method) {
        options.method_given = true;
        options.method = *o.method == Method::exact ? ms::Method::exact : ms::Method::sampled;
    }
    options.luts = o.luts;
    options.bake_seed_luts = o.seed_luts;
    options.strict_domain = o.strict_domain;
    options.memory_limit = half_physical_memory();

    auto data = std::make_shared<SceneResult::Data>();
    data->result = detail::run_with_progress(progress, [&](const auto& report) {
        options.progress = [&](const std::string&, std::size_t done, std::size_t total) { report(done, total); };
        return ms::scene::run_scene(inputs, *backend, options);
    });
    // The provenance the command records (cli/cmd_scene.cpp), with this call in place of its command line.
    data->provenance = {{"program", "microshadow " MICROSHADOW_VERSION},
                        {"command_line", "microshadow::scene (library " MICROSHADOW_VERSION ")"},
                        {"scene", description_path},
                        {"skip", o.skip},
                        {"form", ms::to_string(description.sampling.form)},
                        {"ao_weighting", ms::to_string(description.ao_weighting)},
                        {"min_samples", description.sampling.min_samples},
                        {"max_samples", description.sampling.max_samples},
                        {"seed", description.sampling.seed},
                        {"replicates", description.sampling.replicates},
                        {"dedup_step", description.sampling.dedup_step},
                        {"fast_math", o.fast_math}};
    return SceneResult(std::move(data));
}

std::uint32_t SceneResult::width() const { return data_->result.width; }
std::uint32_t SceneResult::height() const { return data_->result.height; }

std::vector<std::string> SceneResult::lights() const {
    std::vector<std::string> names;
    for (const auto& l : data_->result.lights) names.push_back(l.light);
    return names;
}

std::vector<std::string> SceneResult::comparators() const { return data_->result.comparators; }

std::vector<SceneLayer> SceneResult::layers() const {
    const ms::scene::SceneResult& r = data_->result;
    // The order of scene.exr (jobs/scene.cpp: write_scene_files, scene_exr_layers).
    std::vector<SceneLayer> out{{"mask", r.mask}};
    for (const auto& l : r.lights) {
        out.push_back({l.light + ".reference", l.reference});
        out.push_back({l.light + ".std_error", l.std_error});
        out.push_back({l.light + ".weight", l.weight});
        for (std::size_t k = 0; k < r.comparators.size(); ++k) {
            out.push_back({l.light + "." + r.comparators[k], l.approximation[k]});
            out.push_back({l.light + "." + r.comparators[k] + "_error", l.error[k]});
        }
    }
    return out;
}

std::string SceneResult::report_json() const {
    nlohmann::json report = ms::scene::scene_report(data_->result);
    report["provenance"] = data_->provenance;
    return report.dump();
}

void SceneResult::save(const std::string& dir) const {
    ms::scene::write_scene_outputs(data_->result, dir, data_->provenance);
}

}  // namespace microshadow
