// microshadow repr: representations that keep the relative azimuth (host/repr/representation.hpp,
// docs/representations.md). `repr bake` bakes the term at K azimuth nodes per texel and builds one
// representation (file, shaders); `repr shader` regenerates the sampling code of a file; `repr info`
// prints its layout and cost; `repr export` writes a file's texture as KTX2 or DDS.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <optional>
#include <fstream>
#include <iostream>
#include <sstream>
#include <tuple>

#include "cli/common.hpp"
#include "lut/shader/compose.hpp"
#include "cli/mpi_world.hpp"
#include "cli/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/text.hpp"
#include "schedule/item_bytes.hpp"
#include "repr/presets.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/representation.hpp"

namespace ms::cli {

namespace {

struct ReprBakeArgs {
    std::string preset, kind, out, shader_glsl, shader_hlsl, shader_wgsl, shader_prefix;
    double edge_width = 2.0;
    std::vector<double> domain_visibility{0, 1}, domain_n_dot_v{0, 1};
    std::uint32_t visibility = 16, n_dot_l = 16, n_dot_v = 16, azimuth_nodes = 9, roughness_count = 0;
    std::vector<double> roughness{0.1, 0.4, 0.7, 1.0};
    std::string n_dot_v_warp = "linear", n_dot_l_warp = "linear", visibility_warp = "linear";
    bool half = false, float32 = false;
    SamplingOptions sampling;
    CLI::App* cmd = nullptr;
    DistributionArgs distribution;  // --shard --store --merge --mpi (docs/cluster.md)
};

// The representation bake split into work items, one per roughness node: item r bakes the grid of that
// node alone (a texel's query, and so its value, is the same in either bake: every query is sampled on
// the plan's one point set). Each item's payload: its values, errors, query counts and the metadata of
// its bake; the whole bake's metadata is the first item's with the counts summed.
repr::AzimuthBake bake_by_roughness(const repr::AzimuthBakeSpec& spec, TermBackend& backend, const schedule::Distribution& d,
                                    Progress& progress, bool* complete, schedule::ItemRunReport* report) {
    const auto start = std::chrono::steady_clock::now();
    const auto& g = spec.grid;
    const std::size_t nodes = g.roughness.size(), block = std::size_t(spec.azimuth_nodes) * g.visibility * g.n_dot_l * g.n_dot_v;
    repr::AzimuthBake bake;
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
        repr::AzimuthBakeSpec one = spec;
        one.grid.roughness = {g.roughness[r]};
        const repr::AzimuthBake b = repr::bake_azimuth(one, backend);
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
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
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

// The representation file formats, by --out's extension: the OpenEXR atlas (what `eval --compare` and
// sweeps open), or the 3D texture alone as an engine loads it (KTX2, DDS + `<file>.json`).
enum class ReprFormat { exr, ktx2, dds };
ReprFormat repr_format(const std::string& out) {
    const std::string ext = std::filesystem::path(out).extension().string();
    if (ext == ".exr") return ReprFormat::exr;
    if (ext == ".ktx2") return ReprFormat::ktx2;
    if (ext == ".dds") return ReprFormat::dds;
    throw std::invalid_argument("--out must be an .exr, .ktx2 or .dds file: " + out);
}

// The outputs of one representation file in `outputs` (a DDS adds its metadata sidecar `<out>.json`).
struct ReprOutput {
    ReprFormat format;
    std::size_t file = 0, sidecar = 0;
    ReprOutput(OutputSet& outputs, const std::string& out) : format(repr_format(out)) {
        file = outputs.add(out, true);
        if (format == ReprFormat::dds) sidecar = outputs.add(out + ".json");
    }
    // Writes the file into its temporary; all appear together at outputs.commit(). The archive (EXR)
    // is FLOAT unless `half`; the engine-facing textures (KTX2, DDS) are RGBA16F, what an engine uploads
    // and what the representations' memory figures count, unless `float32`.
    void write(OutputSet& outputs, const repr::Representation& r, bool half, bool float32) const {
        const std::string temp = outputs.temp_path(file);
        if (half && float32) throw std::invalid_argument("--half and --float contradict each other");
        if (format == ReprFormat::exr) return r.write(temp, half);
        half = !float32;
        if (format == ReprFormat::ktx2) return r.write_ktx2(temp, half);
        // The DDS writer puts the metadata beside its path: moved into the set's own `<out>.json`.
        try {
            r.write_dds(temp, half);
        } catch (...) {
            std::error_code ec;  // the writer's own sidecar of the temporary must not stay behind
            std::filesystem::remove(temp + ".json", ec);
            throw;
        }
        std::ifstream in(temp + ".json", std::ios::binary);
        outputs.stream(sidecar) << in.rdbuf();
        in.close();
        std::filesystem::remove(temp + ".json");
    }
};

std::string cost_line(const repr::Representation& r) {
    const auto c = r.cost();
    std::ostringstream o;
    o << c.storage << ", " << c.bytes << " bytes (" << c.bytes / 1024.0 << " KiB), " << c.fetches_per_light
      << " fetches and about " << c.alu_per_light << " ALU operations per light";
    return o.str();
}

// The options that choose a layout: a preset sets them all, so they are refused beside --preset.
const char* const kLayoutOptions[] = {"--kind", "--visibility-count", "--n-dot-l-count", "--n-dot-v-count", "--azimuth-nodes",
                                      "--roughness", "--roughness-count", "--n-dot-v-warp", "--n-dot-l-warp", "--visibility-warp",
                                      "--n-dot-l-edge-width", "--domain-visibility", "--domain-n-dot-v"};

// A [lo, hi] option of the domain: two values in [0, 1], lo < hi.
void check_range(const char* option, const std::vector<double>& v) {
    if (v.size() != 2 || !(v[0] >= 0 && v[0] < v[1] && v[1] <= 1))
        throw std::invalid_argument(std::string(option) + " must be LO,HI with 0 <= LO < HI <= 1");
}

// The bake's --shader-glsl / --shader-hlsl files, composable (lut/shader/compose.hpp).
void write_repr_shaders(OutputSet& outputs, const ReprBakeArgs& a, const repr::Representation& rep, const std::string& name,
                        std::size_t glsl, std::size_t hlsl, std::size_t wgsl) {
    for (const auto& [path, index, language] : {std::tuple{a.shader_glsl, glsl, lutshader::ShaderLanguage::glsl},
                                                std::tuple{a.shader_hlsl, hlsl, lutshader::ShaderLanguage::hlsl},
                                                std::tuple{a.shader_wgsl, wgsl, lutshader::ShaderLanguage::wgsl}})
        if (!path.empty())
            outputs.stream(index) << lutshader::compose(rep.shader(language, name), language,
                                                        a.shader_prefix.empty() ? lutshader::default_prefix(path) : a.shader_prefix);
}

void run_repr_bake(ReprBakeArgs a, MpiWorld* world) {
    const bool rank0 = !world || world->writer();
    // No layout option and no preset: the full-range preset, what a renderer that does not know its
    // content's roughness should ship.
    bool layout_given = false;
    for (const char* o : kLayoutOptions) layout_given = layout_given || a.cmd->count(o) > 0;
    if (!a.preset.empty() && layout_given)
        for (const char* o : kLayoutOptions)
            if (a.cmd->count(o) > 0)
                throw std::invalid_argument(std::string(o) + " conflicts with --preset " + a.preset +
                                            " (a preset sets the whole layout; bake a custom one with --kind)");
    if (a.preset.empty() && !layout_given) a.preset = "full-range";
    if (!a.preset.empty() && a.out.empty()) a.out = a.preset + ".exr";
    if (a.out.empty()) throw std::invalid_argument("--out is required for a custom layout (--kind ...)");
    if (a.preset.empty() && a.kind.empty()) throw std::invalid_argument("--kind is required for a custom layout (or name a --preset)");
    repr::AzimuthBakeSpec spec;
    spec.term = a.sampling.term_options();
    LookupDomain domain;
    if (!a.preset.empty()) {
        const repr::Preset p = repr::preset(a.preset, spec.term.ao_weighting);
        a.kind = p.kind;
        a.azimuth_nodes = p.azimuth_nodes;
        spec.grid = p.grid;
        domain = p.domain;
    } else {
        check_range("--domain-visibility", a.domain_visibility);
        check_range("--domain-n-dot-v", a.domain_n_dot_v);
    }
    if (a.preset.empty()) {
    spec.grid.visibility = a.visibility;
    spec.grid.n_dot_l = a.n_dot_l;
    spec.grid.n_dot_v = a.n_dot_v;
    spec.grid.roughness = a.roughness;
    spec.grid.warps.n_dot_v = repr::parse_n_dot_v_warp(a.n_dot_v_warp);
    spec.grid.warps.n_dot_l = repr::parse_n_dot_l_warp(a.n_dot_l_warp);
    spec.grid.warps.visibility = repr::parse_visibility_warp(a.visibility_warp);
    spec.grid.edge_width = a.edge_width;
    spec.grid.weighting = spec.term.ao_weighting;
    }
    spec.azimuth_nodes = a.azimuth_nodes;
    spec.plan = a.sampling.plan();
    note_unused_sampling_options(a.cmd, a.sampling);
    spec.command_line = command_line();
    if (a.preset.empty()) {
        // A custom layout's domain: its roughness nodes' range (after --roughness-count, the same ends)
        // and the visibility and NdotV ranges given.
        domain = repr::grid_domain(spec.grid, a.domain_visibility[0], a.domain_visibility[1], a.domain_n_dot_v[0], a.domain_n_dot_v[1]);
    }
    if (a.roughness_count && (a.roughness_count < 2 || a.roughness_count > a.roughness.size()))
        throw std::invalid_argument("--roughness-count must be between 2 and the number of --roughness values");
    if (a.kind == "azimuth-axis" && (a.roughness_count ? a.roughness_count : a.roughness.size()) > 4)
        throw std::invalid_argument("azimuth-axis holds 1 to 4 roughness nodes (RGBA): use --roughness-count 4");
    if (a.kind == "azimuth-harmonics" && a.azimuth_nodes < 7)
        throw std::invalid_argument("azimuth-harmonics projects on cos(m phi), m <= 3: --azimuth-nodes must be at least 7");
    // Every output checked before the bake (only rank 0 of an MPI world writes); all appear together or none.
    OutputSet outputs;
    std::optional<ReprOutput> file;
    std::size_t glsl = 0, hlsl = 0, wgsl = 0;
    if (rank0) {
        file.emplace(outputs, a.out);
        glsl = a.shader_glsl.empty() ? 0 : outputs.add(a.shader_glsl);
        hlsl = a.shader_hlsl.empty() ? 0 : outputs.add(a.shader_hlsl);
        wgsl = a.shader_wgsl.empty() ? 0 : outputs.add(a.shader_wgsl);
    }
    auto backend = a.sampling.make_backend();

    Progress progress("repr bake", a.sampling.quiet || !rank0);
    repr::AzimuthBake bake;
    if (!distribution_given(a.distribution)) {
        bake = repr::bake_azimuth(spec, *backend, [&](std::size_t done, std::size_t total) { progress.update(done, total); });
    } else {
        // Beyond one process (docs/cluster.md): the roughness nodes are the work items.
        const schedule::Distribution distribution(
            distribution_request(a.distribution, world), repr::repr_cache_key(spec, *backend).store_key(spec.grid.roughness.size()), a.out + ".chunks",
            [quiet = a.sampling.quiet](const std::string& w) {
                if (!quiet) std::cerr << "\nrepr bake: warning: " << w << "; computed again\n";
            });
        bool complete = false;
        schedule::ItemRunReport report;
        bake = bake_by_roughness(spec, *backend, distribution, progress, &complete, &report);
        if (!distribution.writer() || !complete) {
            progress.finish();
            if (!world && !a.sampling.quiet)
                std::cerr << "repr bake: "
                          << distribution.shard_finished(report.loaded, report.run.done,
                                                         "write " + a.out + " with the same command, --merge in place of --shard")
                          << "\n";
            return;
        }
    }
    progress.finish();
    bake.metadata["domain"] = domain.to_json(a.preset.empty() ? "the lookups this representation was made for; outside, its axes clamp"
                                                              : "the preset's domain: its measured errors hold here; outside, its axes clamp");
    if (!a.preset.empty()) bake.metadata["preset"] = a.preset;
    if (a.roughness_count) {
        double worst = 0;
        const auto keep = repr::choose_roughness_nodes(bake, a.roughness_count, &worst);
        bake = bake.with_roughness(keep);
        if (!a.sampling.quiet) {
            std::cerr << "repr bake: roughness nodes chosen by error:";
            for (double r : bake.grid.roughness) std::cerr << " " << r;
            std::cerr << " (N.L-weighted RMS of the roughness blend over the dense nodes " << worst << ")\n";
        }
        bake.metadata["roughness_chosen_from"] = a.roughness;
        bake.metadata["roughness_blend_rms"] = worst;
    }
    const auto rep = a.preset.empty() ? repr::build_representation(a.kind, bake)
                                      : repr::build_preset(repr::preset(a.preset, spec.term.ao_weighting), bake, *backend);
    const std::string name = std::filesystem::path(a.out).filename().string();
    file->write(outputs, *rep, a.half, a.float32);
    write_repr_shaders(outputs, a, *rep, name, glsl, hlsl, wgsl);
    outputs.commit();
    if (!a.sampling.quiet)
        std::cerr << "repr bake: " << rep->name() << "\n  " << cost_line(*rep) << "\n  " << bake.metadata.value("queries", 0)
                  << " texel x node queries in " << bake.metadata.value("seconds", 0.0) << " s ("
                  << bake.metadata.value("method", std::string()) << " method), max "
                  << (spec.plan.method == Method::exact ? "estimated error " : "std error ")
                  << bake.metadata.value("max_std_error", 0.0) << "\n";
}

struct ReprFileArgs {
    std::string file, lang = "glsl", out, prefix;
    bool half = false, float32 = false, json = false;
};

// `repr info`: a summary in the shape of `lut info` (kind, layout, cost, domain, provenance); --json
// gives the whole record.
std::string describe_representation(const repr::Representation& rep, const std::string& path) {
    const nlohmann::json p = rep.provenance();
    auto text = [&](const char* key) { return p.contains(key) && p.at(key).is_string() ? p.at(key).get<std::string>() : std::string(); };
    std::ostringstream o;
    o << path << ": representation " << text("representation");
    if (!text("preset").empty()) o << " (preset " << text("preset") << ")";
    o << "\nlayout: " << rep.name() << "\ncost: " << cost_line(rep) << "\n";
    if (p.contains("domain") && p.at("domain").is_object()) {
        const auto& d = p.at("domain");
        o << "domain:";
        const char* sep = " ";
        for (const auto& [key, label] : {std::pair{"roughness", "roughness"}, {"visibility", "visibility"}, {"n_dot_v", "NdotV"}, {"n_dot_l", "NdotL"}})
            if (d.contains(key) && d.at(key).is_array() && d.at(key).size() == 2 && d.at(key)[0].is_number() && d.at(key)[1].is_number()) {
                o << sep << label << " [" << d.at(key)[0].get<double>() << ", " << d.at(key)[1].get<double>() << "]";
                sep = ", ";
            }
        if (d.contains("outside") && d.at("outside").is_string()) o << "; queries outside it are " << d.at("outside").get<std::string>();
        o << "\n";
    }
    if (!text("method").empty()) o << "computed by: the " << text("method") << " method\n";
    o << "made by: microshadow " << (text("version").empty() ? "?" : text("version"));
    if (!text("command_line").empty()) o << ": " << text("command_line");
    o << "\n";
    return o.str();
}

std::unique_ptr<repr::Representation> open_or_bad_input(const std::string& path) {
    try {
        return repr::open_representation(path);
    } catch (const std::runtime_error& e) {
        throw std::invalid_argument(e.what());  // a bad input file: exit status 2
    }
}

}  // namespace

void add_repr_command(CLI::App& app) {
    auto* repr_cmd = app.add_subcommand("repr", "representations that keep the relative azimuth: bake, shader, info, export");
    repr_cmd->require_subcommand(1);

    auto a = std::make_shared<ReprBakeArgs>();
    auto* bake = repr_cmd->add_subcommand("bake", "bake the term at K azimuth nodes per texel and build a representation");
    a->cmd = bake;
    bake->add_option("--preset", a->preset,
                     "a named layout (the default, with no layout option: full-range): realistic (roughness 0.3-0.9, visibility "
                     "0.5-1, NdotV 0.2-1; 256 KiB), full-range (roughness 0.05-1, visibility 0.02-1, NdotV 0.02-1; 512 KiB) or "
                     "anisotropic (roughness 0.05-1 per axis, alpha ratio <= 25, any tangent-relative azimuths; 1 MiB, 4 fetches); "
                     "docs/representations.md gives their measured errors")
        ->check(CLI::IsMember(repr::preset_names()));
    bake->add_option("--kind", a->kind, "a custom layout: azimuth-axis or azimuth-harmonics")->check(CLI::IsMember(repr::representation_kinds()));
    bake->add_option("--out", a->out,
                     "the representation file: .exr (opened by eval --compare and sweeps), or the 3D texture alone as "
                     ".ktx2 or .dds (+ .dds.json metadata); default PRESET.exr for a preset");
    bake->add_option("--visibility-count", a->visibility, "visibility texels")->transform(decimal_range(2, 256))->capture_default_str();
    bake->add_option("--n-dot-l-count", a->n_dot_l, "NdotL texels")->transform(decimal_range(2, 256))->capture_default_str();
    bake->add_option("--n-dot-v-count", a->n_dot_v, "NdotV texels")->transform(decimal_range(2, 256))->capture_default_str();
    bake->add_option("--azimuth-nodes", a->azimuth_nodes, "azimuth nodes over [0, 180] degrees, ends included")
        ->transform(decimal_range(2, 64))->capture_default_str();
    bake->add_option("--roughness", a->roughness, "roughness nodes (increasing), or the dense reference with --roughness-count")
        ->delimiter(',')->capture_default_str();
    bake->add_option("--roughness-count", a->roughness_count, "keep this many of --roughness, chosen greedily by error")
        ->transform(decimal_range(2, 64));
    bake->add_option("--n-dot-v-warp", a->n_dot_v_warp, "linear or sqrt (texels uniform in sqrt(NdotV))")
        ->check(CLI::IsMember({"linear", "sqrt"}))->capture_default_str();
    bake->add_option("--n-dot-l-warp", a->n_dot_l_warp,
                     "linear, shadow-edge (NdotL measured from the zero region's edge), sqrt-top (u = 1 - sqrt(1 - NdotL)) or "
                     "edge-roughness (azimuth-harmonics: per roughness slab, asinh of the distance to the shadow edge in units of alpha)")
        ->check(CLI::IsMember({"linear", "shadow-edge", "sqrt-top", "edge-roughness"}))->capture_default_str();
    bake->add_option("--n-dot-l-edge-width", a->edge_width,
                     "edge-roughness warp (azimuth-harmonics): the shadow edge's width in units of alpha = roughness^2")
        ->check(CLI::Range(0.01, 100.0))->capture_default_str();
    bake->add_option("--domain-visibility", a->domain_visibility, "the visibility range the file is made for (its metadata's domain)")
        ->delimiter(',')->expected(2)->capture_default_str();
    bake->add_option("--domain-n-dot-v", a->domain_n_dot_v, "the NdotV range the file is made for (its metadata's domain)")
        ->delimiter(',')->expected(2)->capture_default_str();
    bake->add_option("--visibility-warp", a->visibility_warp, "linear or sqrt-top (u = 1 - sqrt(1 - v): texels dense near v = 1)")
        ->check(CLI::IsMember({"linear", "sqrt-top"}))->capture_default_str();
    bake->add_flag("--half", a->half, "EXR: store HALF channels (KTX2 and DDS are RGBA16F already)");
    bake->add_flag("--float", a->float32, "KTX2, DDS: RGBA32F in place of the default RGBA16F");
    bake->add_option("--shader-glsl", a->shader_glsl, "also write the GLSL sampling code");
    bake->add_option("--shader-hlsl", a->shader_hlsl, "also write the HLSL sampling code");
    bake->add_option("--shader-wgsl", a->shader_wgsl, "also write the WGSL sampling code");
    add_shader_prefix_option(bake, a->shader_prefix);
    // Measured on the project's 2-core CPU: ~10 us a texel x node query per core for the exact method at
    // 1e-10, ~45 us for the sampled default's 65536 samples at ~5e-4.
    a->sampling.method = "exact";
    add_sampling_options(bake, a->sampling,
                         "Default exact: at its default tolerance 1e-10 it takes ~10 us a texel x node query per core, "
                         "less than the sampled default's 65536 samples (~45 us a query per core for ~5e-4)");
    add_tolerance_option(bake, a->sampling);
    add_distribution_options(bake, a->distribution, "roughness nodes", "OUT.chunks");
    bake->callback([a] { with_distribution(a->distribution, [&](MpiWorld* world) { run_repr_bake(*a, world); }); });

    auto s = std::make_shared<ReprFileArgs>();
    auto* shader = repr_cmd->add_subcommand("shader", "write the GLSL or HLSL that samples a representation file");
    shader->add_option("file", s->file, "a file written by `microshadow repr bake`")->required();
    shader->add_option("--lang", s->lang, "glsl, hlsl or wgsl")->check(CLI::IsMember({"glsl", "hlsl", "wgsl"}))->capture_default_str();
    shader->add_option("--out", s->out, "output file (default: standard output)");
    add_shader_prefix_option(shader, s->prefix);
    shader->callback([s] {
        const auto rep = open_or_bad_input(s->file);
        const auto language = lutshader::parse_shader_language(s->lang);
        const auto text = lutshader::compose(rep->shader(language, std::filesystem::path(s->file).filename().string()), language,
                                             s->prefix.empty() ? lutshader::default_prefix(s->out) : s->prefix);
        if (s->out.empty()) {
            std::cout << text;
            return;
        }
        OutputSet outputs;
        outputs.stream(outputs.add(s->out)) << text;
        outputs.commit();
    });

    auto x = std::make_shared<ReprFileArgs>();
    auto* exp = repr_cmd->add_subcommand("export", "write a representation file's 3D texture as KTX2 or DDS (or EXR)");
    exp->add_option("file", x->file, "a file written by `microshadow repr bake`")->required();
    exp->add_option("--out", x->out, ".ktx2, .dds (+ .dds.json metadata) or .exr")->required();
    exp->add_flag("--half", x->half, "EXR: HALF channels (KTX2 and DDS are RGBA16F, what an engine uploads, by default)");
    exp->add_flag("--float", x->float32, "KTX2, DDS: RGBA32F in place of the default RGBA16F");
    exp->callback([x] {
        const auto rep = open_or_bad_input(x->file);
        OutputSet outputs;
        const ReprOutput file(outputs, x->out);
        file.write(outputs, *rep, x->half, x->float32);
        outputs.commit();
    });

    auto i = std::make_shared<ReprFileArgs>();
    auto* info = repr_cmd->add_subcommand("info", "print a representation file's layout, cost and provenance");
    info->add_option("file", i->file, "a file written by `microshadow repr bake`")->required();
    info->add_flag("--json", i->json, "print the whole provenance record (JSON) instead of the summary");
    info->callback([i] {
        const auto rep = open_or_bad_input(i->file);
        std::cout << (i->json ? rep->provenance().dump(2) + "\n" : describe_representation(*rep, i->file));
    });
}

}  // namespace ms::cli
