// microshadow repr: representations that keep the relative azimuth (host/repr/representation.hpp,
// docs/representations.md). `repr bake` bakes the term at K azimuth nodes per texel and builds one
// representation (file, shaders); `repr shader` regenerates the sampling code of a file; `repr info`
// prints its layout and cost; `repr export` writes a file's texture as KTX2 or DDS.
#include <algorithm>
#include <filesystem>
#include <optional>
#include <iostream>
#include <sstream>

#include "cli/common.hpp"
#include "lut/shader/compose.hpp"
#include "cli/mpi_world.hpp"
#include "cli/progress.hpp"
#include "io/atomic_file.hpp"
#include "io/text.hpp"
#include "repr/presets.hpp"
#include "jobs/repr_run.hpp"
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
    bool half = false, float32 = false, allow_tolerance_miss = false;
    SamplingOptions sampling;
    CLI::App* cmd = nullptr;
    DistributionArgs distribution;  // --shard --store --merge --mpi (docs/cluster.md)
};

// Writes a representation file (its format by --out's extension) into `outputs`: the EXR archive in
// HALF with --half, the engine textures (KTX2, DDS) in RGBA32F with --float (else RGBA16F).
void check_repr_out(const std::string& out) {
    try {
        (void)repr::repr_format(out);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(std::string("--out: ") + e.what());
    }
}

void write_repr_file(OutputSet& outputs, const std::string& out, const repr::Representation& r, bool half, bool float32) {
    if (half && float32) throw std::invalid_argument("--half and --float contradict each other");
    check_repr_out(out);
    const repr::ReprFileOutput file(outputs, out);
    file.write(outputs, r, file.format() == repr::ReprFormat::exr ? half : !float32);
}

// The options that choose a layout: a preset sets them all, so they are refused beside --preset.
const char* const kLayoutOptions[] = {"--kind", "--visibility-count", "--n-dot-l-count", "--n-dot-v-count", "--azimuth-nodes",
                                      "--roughness", "--roughness-count", "--n-dot-v-warp", "--n-dot-l-warp", "--visibility-warp",
                                      "--n-dot-l-edge-width", "--domain-visibility", "--domain-n-dot-v"};

// Returns the written values against their tolerance (nothing asked where nothing was written: a shard,
// an MPI rank other than 0).
ToleranceCheck run_repr_bake(ReprBakeArgs a, MpiWorld* world) {
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
    if (a.half && a.float32) throw std::invalid_argument("--half and --float contradict each other");
    repr::ReprBakeJobSpec spec;
    spec.preset = a.preset;
    spec.kind = a.kind;
    spec.bake.term = a.sampling.term_options();
    spec.bake.grid.visibility = a.visibility;
    spec.bake.grid.n_dot_l = a.n_dot_l;
    spec.bake.grid.n_dot_v = a.n_dot_v;
    spec.bake.grid.roughness = a.roughness;
    spec.bake.grid.warps.n_dot_v = repr::parse_n_dot_v_warp(a.n_dot_v_warp);
    spec.bake.grid.warps.n_dot_l = repr::parse_n_dot_l_warp(a.n_dot_l_warp);
    spec.bake.grid.warps.visibility = repr::parse_visibility_warp(a.visibility_warp);
    spec.bake.grid.edge_width = a.edge_width;
    spec.bake.azimuth_nodes = a.azimuth_nodes;
    spec.bake.plan = a.sampling.plan(repr::kReferenceTolerance);
    note_unused_sampling_options(a.cmd, a.sampling);
    spec.bake.command_line = command_line();
    spec.roughness_count = a.roughness_count;
    spec.domain_visibility = a.domain_visibility;
    spec.domain_n_dot_v = a.domain_n_dot_v;
    spec.out = a.out;
    spec.shader_glsl = a.shader_glsl;
    spec.shader_hlsl = a.shader_hlsl;
    spec.shader_wgsl = a.shader_wgsl;
    spec.shader_prefix = a.shader_prefix;
    spec.half_exr = a.half;
    spec.float_texture = a.float32;
    spec.writer = rank0;
    spec.distributed = distribution_given(a.distribution);
    if (spec.distributed) spec.distribution = distribution_request(a.distribution, world);
    spec.make_backend = [&] { return a.sampling.make_backend(); };
    if (rank0) check_repr_out(a.out);  // before the bake, as every output is

    Progress progress("repr bake", a.sampling.quiet || !rank0);
    repr::ReprBakeJobCallbacks callbacks;
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    callbacks.warn = [quiet = a.sampling.quiet](const std::string& w) {
        if (!quiet) std::cerr << "\nrepr bake: warning: " << w << "\n";
    };
    const repr::ReprBakeJobResult result = repr::run_repr_bake_job(spec, callbacks);
    progress.finish();
    if (!result.shard_note.empty()) {
        if (!world && !a.sampling.quiet) std::cerr << "repr bake: " << result.shard_note << "\n";
        return {};
    }
    if (!a.sampling.quiet && result.written) std::cerr << repr::repr_bake_job_summary(spec, result);
    return result.written ? result.tolerance : ToleranceCheck{};
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
    if (p.contains("tolerance_met") && p.at("tolerance_met") == false)
        o << "accuracy: TOLERANCE NOT MET (" << p.value("queries_over_tolerance", std::uint64_t(0))
          << " texel x node values above the tolerance asked)\n";
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
                     "the representation file, the format by the extension: " + lutfmt::extension_list(lutfmt::TextureUse::representation) +
                         " (.exr: the atlas that eval --compare and sweeps open; .ktx2 / .dds: the 3D texture alone, .dds with "
                         ".dds.json metadata); default PRESET.exr for a preset");
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
    // Measured on the project's 2-core CPU: ~4 us a texel x node query per core for the exact method at
    // 1e-9, ~45 us for the sampled default's 65536 samples at ~5e-4.
    a->sampling.method = "exact";
    add_sampling_options(bake, a->sampling,
                         "Default exact: at its default tolerance 1e-9 it takes ~4 us a texel x node query per core, "
                         "less than the sampled default's 65536 samples (~45 us a query per core for ~5e-4)");
    add_tolerance_option(bake, a->sampling);
    add_distribution_options(bake, a->distribution, "roughness nodes", "OUT.chunks");
    add_tolerance_miss_option(bake, a->allow_tolerance_miss);
    bake->callback([a] {
        ToleranceCheck tolerance;
        with_distribution(a->distribution, [&](MpiWorld* world) { tolerance = run_repr_bake(*a, world); });
        // After the world has ended: a flag is not a failure of the ranks.
        finish_tolerance_check("repr bake", "texel x node queries", tolerance, a->allow_tolerance_miss);
    });

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
    exp->add_option("--out", x->out, lutfmt::extension_list(lutfmt::TextureUse::representation) + " (.dds: + .dds.json metadata)")->required();
    exp->add_flag("--half", x->half, "EXR: HALF channels (KTX2 and DDS are RGBA16F, what an engine uploads, by default)");
    exp->add_flag("--float", x->float32, "KTX2, DDS: RGBA32F in place of the default RGBA16F");
    exp->callback([x] {
        const auto rep = open_or_bad_input(x->file);
        OutputSet outputs;
        write_repr_file(outputs, x->out, *rep, x->half, x->float32);
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
