// microshadow scene: the reference term of every pixel of a scene description against the
// approximations (host/jobs/scene.hpp; the format in docs/scenes.md).
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "cli/common.hpp"
#include "cli/mpi_world.hpp"
#include "cli/progress.hpp"
#include "io/text.hpp"
#include "jobs/scene.hpp"

namespace ms::cli {

namespace {

struct SceneArgs {
    std::string scene, out;
    double tolerance = 0;
    std::string method;  // empty: the description's sampling.method
    bool no_skip = false, no_seed_luts = false, quiet = false, fast_math = false, strict_domain = false;
    std::vector<std::string> luts;
    std::string backend = "opencl", device = "default";
    DistributionArgs distribution;  // --shard --store --merge --mpi (docs/cluster.md)
};

void run_scene_command(const SceneArgs& args, MpiWorld* world) {
    const bool rank0 = !world || world->writer();
    // A destination that cannot be a folder is refused before any work (the outputs are written together
    // at the end, through one OutputSet).
    std::error_code ec;
    if (std::filesystem::exists(args.out, ec) && !std::filesystem::is_directory(args.out, ec))
        throw std::invalid_argument(args.out + ": exists and is not a folder (--out names the output folder)");
    scene::check_output_folder(args.out);
    const scene::SceneDescription description = scene::load_scene(args.scene);
    const scene::SceneInputs inputs = scene::SceneInputs::load(description);
    OpenClBackendConfig config;
    config.build.fast_math = args.fast_math;
    const std::unique_ptr<TermBackend> backend = make_term_backend(backend_spec(args.backend, args.device), config);

    scene::SceneRunOptions options;
    options.skip = !args.no_skip;
    options.tolerance = args.tolerance;
    if (!args.method.empty()) {
        options.method_given = true;
        options.method = parse_method(args.method);
    }
    options.luts = args.luts;
    options.bake_seed_luts = !args.no_seed_luts;
    options.strict_domain = args.strict_domain;
    // Every output name and the folder are checked once the comparators are known, before any work.
    options.check_outputs = [&](const std::vector<std::string>& comparators) {
        std::vector<std::string> lights;
        for (const auto& l : description.lights) lights.push_back(l.name);
        scene::check_scene_outputs(args.out, lights, comparators);
    };
    options.memory_limit = physical_memory() / 2;
    std::unique_ptr<Progress> progress;
    std::string phase;
    options.progress = [&](const std::string& p, std::size_t done, std::size_t total) {
        if (p != phase) {
            if (progress) progress->finish();
            progress = std::make_unique<Progress>("scene: " + p, args.quiet || !rank0);
            phase = p;
        }
        progress->update(done, total);
    };
    // The tiles split as asked (docs/cluster.md): shards of a Slurm array, a resumable store, the merge
    // of a store's shards, or the ranks of an MPI world. Checked before any work; nothing is written here.
    // The store key digests every pixel: computed only when a store is kept.
    const schedule::DistributionRequest request = distribution_request(args.distribution, world);
    const bool keeps_items = request.shard.count > 1 || request.merge || !request.store.empty();
    const schedule::Distribution distribution(
        request, keeps_items ? scene::scene_store_key(inputs, options, *backend) : schedule::StoreKey{},
        (std::filesystem::path(args.out) / "chunks").string(), [quiet = args.quiet](const std::string& w) {
            if (!quiet) std::cerr << "\nscene: warning: " << w << "\n";
        });
    options.items = &distribution.plan();
    const scene::SceneResult result = scene::run_scene(inputs, *backend, options);
    if (progress) progress->finish();
    if (!distribution.writer() || !result.complete) {
        if (!world && !args.quiet)
            std::cerr << "scene: " << distribution.shard_finished(result.loaded_items, result.computed_items,
                                                                  "write " + args.out + " with the same command, --merge in place of --shard")
                      << "\n";
        return;
    }

    nlohmann::json provenance = {{"program", "microshadow " MICROSHADOW_VERSION},
                                 {"command_line", command_line()},
                                 {"scene", json_safe(args.scene)},
                                 {"skip", !args.no_skip},
                                 {"form", to_string(description.sampling.form)},
                                 {"ao_weighting", to_string(description.ao_weighting)},
                                 {"min_samples", description.sampling.min_samples},
                                 {"max_samples", description.sampling.max_samples},
                                 {"seed", description.sampling.seed},
                                 {"replicates", description.sampling.replicates},
                                 {"dedup_step", description.sampling.dedup_step},
                                 {"fast_math", args.fast_math}};
    scene::write_scene_outputs(result, args.out, provenance);

    if (!args.quiet) {
        const auto& c = result.counts;
        std::cerr << std::setprecision(3) << "scene: " << result.width << " x " << result.height << " pixels, "
                  << result.lights.size() << " light(s): " << c.pixel_lights << " pixel-lights, skipped "
                  << 100 * c.skipped_fraction() << " % (masked " << c.masked << ", view below horizon " << c.view_below_horizon
                  << ", light below horizon " << c.light_below_horizon << ", zero region " << c.zero_region << ", v = 1 "
                  << c.v_one << ", duplicates " << c.duplicates << "), " << c.sampled << " sampled";
        if (c.tolerance_missed) std::cerr << " (" << c.tolerance_missed << " above the tolerance at the sample limit)";
        std::cerr << "; " << result.seconds << " s (LUT bakes " << result.lut_seconds << " s, sampling "
                  << result.sampling_seconds << " s) on " << result.backend << "\n";
        for (const auto& l : result.lights)
            for (std::size_t k = 0; k < result.comparators.size(); ++k) {
                const auto& s = l.stats[k][0];
                std::cerr << "scene: " << l.light << ": " << result.comparators[k] << ": weighted error max " << s.lit_max_abs
                          << ", RMS " << s.lit_rms << ", p99 " << s.lit_p99 << "\n";
            }
        for (std::size_t k = 0; k < result.comparators.size() && k < result.outside_domain.size(); ++k)
            if (result.outside_domain[k].outside > 0)
                std::cerr << "scene: warning: " << result.comparators[k] << ": " << result.outside_domain[k].outside << " of "
                          << result.outside_domain[k].lookups << " lit pixel-lights outside its domain ("
                          << result.domains[k]->describe() << "), e.g. " << result.first_outside[k] << "; --strict-domain refuses them\n";
        std::cerr << "scene: wrote " << args.out << "/report.md, scene.exr and the PNG images\n";
    }
}

}  // namespace

void add_scene_command(CLI::App& app) {
    auto args = std::make_shared<SceneArgs>();
    auto* cmd = app.add_subcommand("scene", "the term of every pixel of a scene against the approximations (docs/scenes.md)");
    cmd->add_option("scene", args->scene, "scene description (TOML)")->required();
    cmd->add_option("--out", args->out, "output folder: scene.exr, report.md/.json, PNG images (created if missing)")->required();
    cmd->add_option("--tolerance", args->tolerance, "per-pixel error bound of the reference (overrides sampling.tolerance; "
                                                     "the exact method's estimated error, or the sampled 99.9 % bound)")
        ->check(real_range(1e-12, 0.5));
    cmd->add_option("--method", args->method,
                    "how the per-pixel reference is computed (overrides sampling.method; default exact: on the 1024^2 example "
                    "scene it reaches 1e-6 faster than sampling reaches 2e-3, docs/exact-method.md)")
        ->check(CLI::IsMember({"exact", "sampled"}));
    cmd->add_option("--lut", args->luts, "a LUT file to compare as well (repeatable)");
    cmd->add_flag("--no-skip", args->no_skip, "send every unmasked pixel's own query to the integrand (no classification "
                                              "here, no deduplication): the baseline that skipping is measured against");
    cmd->add_flag("--strict-domain", args->strict_domain,
                  "refuse (exit status 2, nothing written) when a lit pixel's lookup lies outside a comparator's domain (the "
                  "roughness, visibility and NdotV ranges its metadata records); without it they are counted in report.md/.json");
    cmd->add_flag("--no-seed-luts", args->no_seed_luts, "do not bake the seed's 3D and 2D LUTs as comparators");
    add_backend_option(cmd, args->backend, "opencl kernels or the scalar double oracle");
    add_device_option(cmd, args->device);
    add_fast_math_flag(cmd, args->fast_math);
    add_quiet_flag(cmd, args->quiet);
    add_distribution_options(cmd, args->distribution, "tiles (a light's sampling.tile_pixels pixels)", "OUT/chunks");
    cmd->callback([args] { with_distribution(args->distribution, [&](MpiWorld* world) { run_scene_command(*args, world); }); });
}

}  // namespace ms::cli
