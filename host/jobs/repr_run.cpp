#include "jobs/repr_run.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <tuple>

#include "lut/shader/compose.hpp"
#include "schedule/item_bytes.hpp"

namespace ms::repr {

ReprFormat repr_format(const std::string& path) {
    const auto format = lutfmt::format_for_extension(path);
    if (format && lutfmt::format_allowed(*format, lutfmt::TextureUse::representation)) return *format;
    // One message for every front end (the CLI, the C++ API and Python name the formats the same way).
    throw std::invalid_argument("a representation is written as " + lutfmt::extension_list(lutfmt::TextureUse::representation) +
                                ", not " + path);
}

ReprFileOutput::ReprFileOutput(OutputSet& outputs, const std::string& path)
    : files_(lutfmt::add_texture_files(outputs, path, repr_format(path))) {}

void ReprFileOutput::write(OutputSet& outputs, const Representation& r, bool half) const {
    lutfmt::write_texture(outputs, files_, r.texture_file(files_.format, half),
                          half ? lutfmt::PixelEncoding::float16 : lutfmt::PixelEncoding::float32);
}

std::string cost_line(const Representation& r) {
    const auto c = r.cost();
    std::ostringstream o;
    o << c.storage << ", " << c.bytes << " bytes (" << c.bytes / 1024.0 << " KiB), " << c.fetches_per_light
      << " fetches and about " << c.alu_per_light << " ALU operations per light";
    return o.str();
}

namespace {

// A [lo, hi] option of the domain: two values in [0, 1], lo < hi.
void check_repr_domain_range(const char* option, const std::vector<double>& v) {
    if (v.size() != 2 || !(v[0] >= 0 && v[0] < v[1] && v[1] <= 1))
        throw std::invalid_argument(std::string(option) + " must be LO,HI with 0 <= LO < HI <= 1");
}

// The representation bake split into work items, one per roughness node: item r bakes the grid of that
// node alone (a texel's query, and so its value, is the same in either bake: every query is sampled on
// the plan's one point set). Each item's payload: its values, errors, query counts and the metadata of
// its bake; the whole bake's metadata is the first item's with the counts summed.
AzimuthBake bake_repr_by_roughness(const AzimuthBakeSpec& spec, TermBackend& backend, const schedule::Distribution& d,
                                   const std::function<void(std::uint64_t, std::uint64_t)>& progress, bool* complete,
                                   schedule::ItemRunReport* report) {
    const auto start = std::chrono::steady_clock::now();
    const auto& g = spec.grid;
    const std::size_t nodes = g.roughness.size(), block = std::size_t(spec.azimuth_nodes) * g.visibility * g.n_dot_l * g.n_dot_v;
    AzimuthBake bake;
    bake.grid = g;
    bake.azimuth_nodes = spec.azimuth_nodes;
    bake.replicates = spec.plan.replicates;
    bake.value.assign(nodes * block, 0.f);
    bake.std_error.assign(nodes * block, 0.f);
    std::vector<nlohmann::json> metadata(nodes);
    schedule::ItemJob job;
    job.name = "repr bake";
    job.items = nodes;
    job.compute = [&](std::uint64_t r) {
        AzimuthBakeSpec one = spec;
        one.grid.roughness = {g.roughness[r]};
        const AzimuthBake b = bake_azimuth(one, backend);
        schedule::ItemWriter w;
        w.put_vector(b.value);
        w.put_vector(b.std_error);
        w.put_string(b.metadata.dump());
        return w.take();
    };
    job.accept = [&](std::uint64_t r, const std::string& payload) {
        schedule::ItemReader in(payload, "repr bake: roughness node " + std::to_string(r));
        const auto value = in.get_vector<float>(block), error = in.get_vector<float>(block);
        nlohmann::json meta = nlohmann::json::parse(in.get_string(), nullptr, false);
        in.finish();
        if (!meta.is_object()) throw std::runtime_error("repr bake: roughness node " + std::to_string(r) + ": its metadata is not JSON");
        std::copy(value.begin(), value.end(), bake.value.begin() + std::ptrdiff_t(r * block));
        std::copy(error.begin(), error.end(), bake.std_error.begin() + std::ptrdiff_t(r * block));
        metadata[r] = std::move(meta);
    };
    // A stored item is trusted once it reads back whole (values, errors, metadata); else it is set aside.
    job.check = [&](std::uint64_t r, const std::string& payload) -> std::string {
        try {
            job.accept(r, payload);
            return "";
        } catch (const std::exception& e) {
            return std::string("payload: ") + e.what();
        }
    };
    schedule::RunCallbacks callbacks;
    callbacks.progress = progress;
    *report = schedule::run_item_job(job, d.plan(), {backend.name()}, callbacks);
    *complete = report->complete;
    if (!report->complete) return bake;
    // The whole bake's metadata: the first node's, the counts summed and the largest error taken over
    // the nodes; the time and the devices are this run's.
    bake.metadata = metadata[0];
    for (const char* count : {"queries", "sampled", "exact_zero", "exact_one"}) {
        std::uint64_t sum = 0;
        for (const auto& m : metadata) sum += m.value(count, std::uint64_t(0));
        bake.metadata[count] = sum;
    }
    double worst = 0;
    for (const auto& m : metadata) worst = std::max(worst, m.value("max_std_error", 0.0));
    bake.metadata["max_std_error"] = worst;
    bake.metadata["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    bake.metadata["device"] = backend.name();
    bake.metadata["command_line"] = spec.command_line;
    return bake;
}

}  // namespace

void validate(const ReprBakeJobSpec& s) {
    if (!s.preset.empty()) return;  // a preset's layout is checked where it is defined (repr/presets.cpp)
    const auto kinds = representation_kinds();
    if (std::find(kinds.begin(), kinds.end(), s.kind) == kinds.end())
        throw std::invalid_argument("kind '" + s.kind + "' (azimuth-axis or azimuth-harmonics)");
    check_repr_domain_range("--domain-visibility", s.domain_visibility);
    check_repr_domain_range("--domain-n-dot-v", s.domain_n_dot_v);
    const std::size_t nodes = s.bake.grid.roughness.size();
    if (s.roughness_count && (s.roughness_count < 2 || s.roughness_count > nodes))
        throw std::invalid_argument("--roughness-count must be between 2 and the number of --roughness values");
    if (s.kind == "azimuth-axis" && (s.roughness_count ? s.roughness_count : nodes) > 4)
        throw std::invalid_argument("azimuth-axis holds 1 to 4 roughness nodes (RGBA): use --roughness-count 4");
    if (s.kind == "azimuth-harmonics" && s.bake.azimuth_nodes < 7)
        throw std::invalid_argument("azimuth-harmonics projects on cos(m phi), m <= 3: --azimuth-nodes must be at least 7");
}

ReprBakeJobResult run_repr_bake_job(ReprBakeJobSpec spec, const ReprBakeJobCallbacks& callbacks) {
    JobControl control(callbacks);
    AzimuthBakeSpec& bake_spec = spec.bake;
    LookupDomain domain;
    std::optional<Preset> preset;
    if (!spec.preset.empty()) {
        preset = repr::preset(spec.preset, bake_spec.term.ao_weighting);  // names the presets when unknown
        spec.kind = preset->kind;
        bake_spec.grid = preset->grid;
        bake_spec.azimuth_nodes = preset->azimuth_nodes;
        domain = preset->domain;
    } else {
        validate(spec);
        bake_spec.grid.weighting = bake_spec.term.ao_weighting;
        // A custom layout's domain: its roughness nodes' range (after roughness_count, the same ends)
        // and the visibility and NdotV ranges given.
        domain = grid_domain(bake_spec.grid, spec.domain_visibility[0], spec.domain_visibility[1], spec.domain_n_dot_v[0],
                             spec.domain_n_dot_v[1]);
    }
    // Every output checked before the bake (only the writer writes); all appear together or none.
    const bool write = spec.writer && !spec.out.empty();
    OutputSet outputs;
    std::optional<ReprFileOutput> file;
    std::size_t glsl = 0, hlsl = 0, wgsl = 0;
    if (write) {
        file.emplace(outputs, spec.out);
        glsl = spec.shader_glsl.empty() ? 0 : outputs.add(spec.shader_glsl);
        hlsl = spec.shader_hlsl.empty() ? 0 : outputs.add(spec.shader_hlsl);
        wgsl = spec.shader_wgsl.empty() ? 0 : outputs.add(spec.shader_wgsl);
    }
    auto backend = spec.make_backend();

    ReprBakeJobResult r;
    if (!spec.distributed) {
        r.bake = bake_azimuth(bake_spec, *backend, control.progress());
    } else {
        // Beyond one process (docs/cluster.md): the roughness nodes are the work items.
        const schedule::Distribution distribution(spec.distribution,
                                                  repr_cache_key(bake_spec, *backend).store_key(bake_spec.grid.roughness.size()),
                                                  spec.out + ".chunks", callbacks.warn);
        bool complete = false;
        schedule::ItemRunReport report;
        r.bake = bake_repr_by_roughness(bake_spec, *backend, distribution, control.progress(), &complete, &report);
        if (!distribution.writer() || !complete) {
            r.shard_note = distribution.shard_finished(report.loaded, report.run.done,
                                                       "write " + spec.out + " with the same command, --merge in place of --shard");
            return r;
        }
    }
    control.checkpoint();
    AzimuthBake& bake = r.bake;
    bake.metadata["domain"] = domain.to_json(preset ? "the preset's domain: its measured errors hold here; outside, its axes clamp"
                                                    : "the lookups this representation was made for; outside, its axes clamp");
    if (preset) bake.metadata["preset"] = spec.preset;
    if (spec.roughness_count) {
        const std::vector<double> dense = bake.grid.roughness;
        const auto keep = choose_roughness_nodes(bake, spec.roughness_count, &r.roughness_blend_rms);
        bake = bake.with_roughness(keep);
        bake.metadata["roughness_chosen_from"] = dense;
        r.chosen_roughness = bake.grid.roughness;
        bake.metadata["roughness_blend_rms"] = r.roughness_blend_rms;
    }
    // The values the file keeps against the tolerance asked of them: a value less accurate than asked
    // is flagged in the metadata (and by the command's exit status), never silent.
    r.tolerance.tolerance = bake_spec.plan.tolerance;
    for (const float e : bake.std_error) r.tolerance.add(e);
    if (r.tolerance.tolerance > 0) {
        if (bake_spec.plan.method == Method::sampled) bake.metadata["tolerance"] = r.tolerance.tolerance;
        bake.metadata["tolerance_met"] = r.tolerance.met();
        bake.metadata["queries_over_tolerance"] = r.tolerance.over;
    }
    r.representation = preset ? build_preset(*preset, bake, *backend) : build_representation(spec.kind, bake);
    if (!write) return r;
    // The archive (EXR) is FLOAT unless half_exr; the engine-facing textures (KTX2, DDS) are RGBA16F,
    // what an engine uploads and what the representations' memory figures count, unless float_texture.
    file->write(outputs, *r.representation, file->format() == ReprFormat::exr ? spec.half_exr : !spec.float_texture);
    const std::string name = std::filesystem::path(spec.out).filename().string();
    for (const auto& [path, index, language] : {std::tuple{spec.shader_glsl, glsl, lutshader::ShaderLanguage::glsl},
                                                std::tuple{spec.shader_hlsl, hlsl, lutshader::ShaderLanguage::hlsl},
                                                std::tuple{spec.shader_wgsl, wgsl, lutshader::ShaderLanguage::wgsl}})
        if (!path.empty())
            outputs.stream(index) << lutshader::compose(r.representation->shader(language, name), language,
                                                        spec.shader_prefix.empty() ? lutshader::default_prefix(path) : spec.shader_prefix);
    control.checkpoint();
    outputs.commit();
    r.written = true;
    return r;
}

std::string repr_bake_job_summary(const ReprBakeJobSpec& spec, const ReprBakeJobResult& r) {
    std::ostringstream o;
    if (!r.chosen_roughness.empty()) {
        o << "repr bake: roughness nodes chosen by error:";
        for (double x : r.chosen_roughness) o << " " << x;
        o << " (N.L-weighted RMS of the roughness blend over the dense nodes " << r.roughness_blend_rms << ")\n";
    }
    if (!r.representation) return o.str();
    const AzimuthBake& bake = r.bake;
    o << "repr bake: " << r.representation->name() << "\n  " << cost_line(*r.representation) << "\n  "
      << bake.metadata.value("queries", 0) << " texel x node queries in " << bake.metadata.value("seconds", 0.0) << " s ("
      << bake.metadata.value("method", std::string()) << " method), max "
      << (spec.bake.plan.method == Method::exact ? "estimated error " : "std error ") << bake.metadata.value("max_std_error", 0.0);
    const std::string tolerance = r.tolerance.summary();
    o << (tolerance.empty() ? "" : " " + tolerance) << "\n";
    return o.str();
}

}  // namespace ms::repr
