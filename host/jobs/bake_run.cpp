#include "jobs/bake_run.hpp"

#include <filesystem>
#include <iomanip>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "core/memory.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "io/atomic_file.hpp"
#include "io/text.hpp"
#include "lut/preview.hpp"
#include "scene/description.hpp"
#include "jobs/scene.hpp"

namespace ms {

namespace {

// What computed an exact bake's texels: the C++ evaluator (the oracle backend) or the OpenCL kernels.
std::string exact_engine_summary(const BakeSpec& spec) {
    if (spec.backend.is_oracle()) return "the C++ evaluator (double)";
    exact_term::ExactConfig engines;
    engines.force_float = spec.exact_single_precision;
    engines.kernel_on_cpu_devices = spec.exact_kernel_on_cpu;
    return exact_term::describe_engines(engines);
}

// "azimuth nodes per row: 5 (7267 rows), 9 (5425 rows)" (adaptive bakes choose per row), or
// "1 azimuth node" for a fixed angle.
std::string azimuth_summary(const BakeResult& result) {
    if (result.azimuth_cells) return std::to_string(result.azimuth_cells) + " azimuth cells (stratified)";
    if (result.azimuth_rows_by_intervals.empty()) return std::to_string(result.azimuth_nodes) + " azimuth node(s)";
    std::string s = "azimuth nodes per row:";
    const char* sep = " ";
    for (const auto& [intervals, rows] : result.azimuth_rows_by_intervals) {
        s += sep + std::to_string(intervals == 0 ? 1 : intervals + 1) + " (" + std::to_string(rows) + " rows)";
        sep = ", ";
    }
    return s;
}

}  // namespace

BakeJobResult run_bake_job(const BakeJobSpec& job, const std::function<void(const LutFile&)>& write_lut,
                           const BakeJobCallbacks& callbacks) {
    const BakeSpec& spec = job.bake;
    // Fail on a bad destination before the (long) bake, not after it.
    if (job.writer) {
        check_writable_destination(job.out);
        if (!job.preview.empty()) check_writable_destination(job.preview);
    }
    JobControl control(callbacks);
    BakeCallbacks bake_callbacks;
    const auto progress = control.progress();
    bake_callbacks.progress = [&](std::size_t done, std::size_t total) { progress(done, total); };
    schedule::Scheduler scheduler(spec.backend);
    // How the slices are split: a shard of a Slurm array (or --shard), a resumable store, the merge of a
    // store's shards, or the ranks of an MPI world. Checked before any work; nothing is written here.
    const schedule::Distribution distribution(job.distribution, bake_store_key(spec, scheduler), job.out + ".chunks", callbacks.warn);
    // Refuse what cannot fit before computing (a 4096^3 bake used to end in bad_alloc).
    if (const std::uint64_t need = bake_host_memory(spec, scheduler.places()), memory = physical_memory(); memory > 0 && need > memory / 2)
        throw std::invalid_argument("this bake needs about " + gib(need) + " of memory (the atlas and each place's tallies), "
                                    "more than the limit of " + gib(memory / 2) + " (half the " + gib(memory) +
                                    " of physical memory); use fewer texels, channels or samples");
    BakeJobResult r;
    r.bake = bake_lut(spec, scheduler, bake_callbacks, distribution.plan());
    const BakeResult& result = r.bake;
    if (!distribution.writer() || !result.complete) {
        if (const schedule::ItemStore* store = distribution.store())
            r.shard_note = "bake: shard " + std::to_string(distribution.shard().index) + "/" + std::to_string(distribution.shard().count) +
                           " finished in " + store->dir() + " (" + std::to_string(result.loaded_slices) + " of its slices found there, " +
                           std::to_string(result.computed_slices) + " computed); when every shard has, write " + job.out +
                           " with the same command, --merge in place of --shard\n";
        return r;
    }
    control.checkpoint();
    if (job.verify > 0) r.verification = verify_bake(spec, result, job.verify, 0, 0, job.verify_method);
    r.metadata = bake_metadata(spec, result);
    if (r.verification) {
        r.metadata["verify"] = verification_record(*r.verification);
        throw_if_failed(*r.verification);
    }
    control.checkpoint();
    // The preview, the LUT and whatever write_lut adds (shaders) are one set: each is written and synced
    // to its temporary, then all are renamed together; a failure (a full disk) leaves every old file.
    OutputGroup outputs;
    if (!job.preview.empty())
        write_lut_preview(job.preview, {result.width, spec.n_dot_l.count, spec.n_dot_v.count, result.channels, result.value.data(),
                                        {spec.visibility, spec.n_dot_l, spec.n_dot_v}, spec.roughness});
    write_lut(bake_lut_file(spec, result, r.metadata));
    outputs.commit();
    r.written = true;
    return r;
}

std::string bake_job_summary(const BakeJobSpec& job, const BakeJobResult& r) {
    const BakeSpec& spec = job.bake;
    const BakeResult& result = r.bake;
    std::ostringstream s;
    s << std::setprecision(3) << "bake: " << spec.visibility.count << " x " << spec.n_dot_l.count << " x " << spec.n_dot_v.count << " x "
      << result.channels << " (" << result.texels << " texels; skipped " << result.skipped_zero << " exact 0 in the zero region, "
      << result.skipped_one << " exact 1 at v = 1), " << result.slices << " slices, ";
    if (spec.method == Method::exact) {
        // The exact method has no samples or batches: it says what it integrated, with which rule, and
        // how far its per-texel estimate is from the tolerance.
        s << "exact method (" << exact_engine_summary(spec) << "): ";
        if (spec.azimuth_mean)
            s << "azimuth means of T on " << result.exact_quadrature_pieces << " azimuth pieces";
        else
            s << "T at " << spec.azimuth_degrees << " degrees";
        s << "; largest estimated texel error " << result.max_std_error << " against the tolerance " << result.exact_tolerance;
        if (result.tolerance_met)
            s << " (tolerance met)";
        else if (spec.exact_single_precision && !spec.backend.is_oracle())
            s << " (TOLERANCE NOT MET: the float kernel's rounding stops it; leave out --exact-float for the C++ "
                 "evaluator on CPU devices and the double kernel where a device has fp64, or give a looser --tolerance)";
        else
            s << " (TOLERANCE NOT MET: give a looser --tolerance)";
    } else {
        s << azimuth_summary(result) << ", " << result.samples_per_batch << " samples per batch, " << result.batches
          << " batches; max std error " << result.max_std_error;
        if (spec.tolerance > 0) s << (result.tolerance_met ? " (tolerance met)" : " (TOLERANCE NOT MET: raise --max-batches)");
    }
    // The time is this run's: a merge only reads slices computed by earlier runs, so it says so
    // rather than report a read of the store as compute time.
    if (result.computed_slices == 0 && result.loaded_slices > 0)
        s << "; merged " << result.loaded_slices << " slices computed by earlier runs (read in " << result.seconds << " s)\n";
    else if (result.loaded_slices > 0)
        s << "; " << result.computed_slices << " slices computed in " << result.seconds << " s on " << r.metadata["device"].get<std::string>()
          << ", " << result.loaded_slices << " found in the store\n";
    else
        s << "; computed in " << result.seconds << " s on " << r.metadata["device"].get<std::string>() << "\n";
    if (result.rerun_chunks)
        for (const auto& f : result.failed_devices) s << "bake: device failed, its chunks were rerun: " << f << "\n";
    if (const auto& check = r.verification)
        s << "verify: " << check->checked << " texels against the " << (check->reference == Method::exact ? "exact method" : "sampled oracle")
          << ", worst z " << check->worst_z << " (limit " << check->threshold << "), worst |diff| " << check->worst_abs_diff << "\n";
    return s.str();
}

SceneBakeJobResult run_scene_bake_job(const SceneBakeJobSpec& job, const SceneBakeJobCallbacks& callbacks) {
    BakeSpec base = job.base;
    const scene::SceneDescription description = scene::load_scene(job.scene);
    // The scene's AO weighting decides the cone, and its form the term: the LUT must be baked with them.
    base.term.ao_weighting = description.ao_weighting;
    base.term.form = description.sampling.form;
    if (job.writer) check_writable_destination(job.out);
    // The report folder and its files, before any work.
    if (job.writer) scene::check_output_folder(job.report);
    if (std::error_code ec; job.writer && std::filesystem::is_directory(job.report, ec)) {
        for (const char* f : {"histograms.json", "histograms.csv", "report.json", "report.md"})
            check_writable_destination((std::filesystem::path(job.report) / f).string());
        for (const auto& l : description.lights)
            check_writable_destination((std::filesystem::path(job.report) / ("histograms_" + l.name + ".png")).string());
    }
    const scene::SceneInputs inputs = scene::SceneInputs::load(description);
    OpenClBackendConfig config;
    config.build = base.build;
    const std::unique_ptr<TermBackend> backend = make_term_backend(
        base.backend, config);
    scene::SceneBakeOptions options = job.options;
    options.progress = callbacks.progress;
    const std::vector<scene::LightDomain> domain = scene::scene_domain(inputs);
    // The scene bake's slices split as asked (docs/cluster.md): the plan is the one run_scene_bake makes.
    const schedule::Distribution distribution(
        job.distribution, scene::scene_bake_store_key(scene::plan_scene_bake(domain, base, options.fit), backend->scheduler()),
        job.out + ".chunks", callbacks.warn);
    options.items = &distribution.plan();
    SceneBakeJobResult r;
    r.result = scene::run_scene_bake(inputs, domain, base, *backend, options);
    if (!distribution.writer() || !r.result.bake.complete) {
        r.shard_note = "bake --scene: " +
                       distribution.shard_finished(r.result.bake.loaded_slices, r.result.bake.computed_slices,
                                                   "write " + job.out + " and the report with the same command, --merge in place of --shard") +
                       "\n";
        return r;
    }
    throw_if_cancelled();
    const nlohmann::json provenance = {
        {"program", "microshadow " MICROSHADOW_VERSION}, {"command_line", job.command_line}, {"scene", json_safe(job.scene)}};
    scene::write_scene_bake_outputs(r.result, domain, job.out, job.report, provenance);
    r.written = true;
    return r;
}

std::string scene_bake_job_summary(const SceneBakeJobSpec& job, const SceneBakeJobResult& r) {
    const scene::SceneBakeResult& result = r.result;
    const auto& p = result.plan;
    std::ostringstream s;
    s << std::setprecision(3) << "bake --scene: baked " << p.baked_texels << " of " << p.texels << " texels (" << p.baked_rows << " of "
      << p.rows << " rows, " << p.baked_slices << " of " << p.slices << " slices, " << p.channels_touched.size() << " of "
      << p.spec.roughness.size() << " channels) in " << result.bake.seconds << " s";
    if (result.full_seconds > 0)
        s << "; full bake of the same layout " << result.full_seconds << " s (ratio " << result.bake.seconds / result.full_seconds << ")";
    s << "\n";
    if (result.bake.rerun_chunks)
        for (const auto& f : result.bake.failed_devices) s << "bake --scene: device failed, its chunks were rerun: " << f << "\n";
    for (const auto& e : result.errors)
        s << "bake --scene: " << e.light << ": weighted error on " << e.scene_lut.count << " sampled lookups: scene LUT max "
          << e.scene_lut.lit_max_abs << " RMS " << e.scene_lut.lit_rms << ", default LUT max " << e.default_lut.lit_max_abs << " RMS " << e.default_lut.lit_rms
          << " (reference bound " << e.reference_bound << ")\n";
    if (!result.errors.empty())
        s << "bake --scene: the default LUT " << (result.default_serves ? "serves" : "does not serve") << " this scene within "
          << result.serve_error << "\n";
    s << "bake --scene: wrote " << job.out << " and " << job.report << "/report.md\n";
    return s.str();
}

}  // namespace ms
