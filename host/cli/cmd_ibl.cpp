// microshadow ibl: the image-based-lighting integrals of the split-sum approximation.
//   ibl dfg --out dfg.exr|.ktx2|.dds|.h [--size N] ...        the DFG LUT (scale, bias, E) by VNDF sampling, or the quadrature oracle
//   ibl prefilter ENV --out DIR                 GGX-prefiltered cubemap mips (cmgen roughness mapping), SH irradiance, previews
//   ibl sh ENV --out sh.json [--irradiance F]  order-2 SH of an environment (9 coefficients per channel) and its
//                                              irradiance cubemap faces through the clamped-cosine convolution
//   ibl irradiance ENV --out DIR               irradiance cubemap (E / pi) by direct convolution, with error bounds and SH comparison
//   (ENV, for sh / prefilter / irradiance, may instead be six face files: --faces PX NX PY NY PZ NZ)
// Each command's run is a job (jobs/ibl_run.hpp): this file turns flags into its spec and prints its summary.
#include <cmath>
#include <cstdlib>
#include <iostream>

#include "lut/formats/texture_format.hpp"
#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "jobs/ibl_run.hpp"

namespace ms::cli {

namespace {

// Runs a job with a progress display on stderr, and prints its summary unless quiet.
template <class Spec, class Run, class Summary>
void run_with_display(const char* label, bool quiet, const Spec& spec, Run run, Summary summary) {
    Progress progress(label, quiet);
    JobCallbacks callbacks;
    callbacks.progress = [&](std::uint64_t done, std::uint64_t total) { progress.update(done, total); };
    const auto result = [&] {
        struct Finish {
            Progress& p;
            ~Finish() { p.finish(); }
        } finish{progress};
        return run(spec, callbacks);
    }();
    if (!quiet) std::cerr << summary(spec, result);
}

// ENV or --faces (sh, prefilter, irradiance).
void add_environment_options(CLI::App* app, EnvironmentFiles& e, const std::string& env_help, const std::string& faces_help) {
    app->add_option("ENV", e.image, env_help);
    app->add_option("--faces", e.faces, "instead of ENV: six square face files +X -X +Y -Y +Z -Z" + faces_help)->expected(6);
}
// --format exr|ktx2|dds and --encoding float16|float32 of a cubemap output (prefilter, irradiance).
void add_cubemap_format_options(CLI::App* app, std::string& format, std::string& encoding, const std::string& format_help,
                                const std::string& encoding_help) {
    app->add_option("--format", format, format_help)
        ->check(CLI::IsMember(lutfmt::format_names(lutfmt::TextureUse::cubemap)))
        ->capture_default_str();
    app->add_option("--encoding", encoding, encoding_help)->check(CLI::IsMember({"float16", "float32"}))->capture_default_str();
}
void add_exposure_option(CLI::App* app, double& exposure, const std::string& what) {
    app->add_option("--exposure", exposure, what + ": exposure before the tone map (0 to 1e12)")->check(real_range(0, 1e12))->capture_default_str();
}

struct DfgArgs {
    DfgJobSpec job;
    std::string texel = "centres", backend, device = "default";
    unsigned threads = 0;  // host threads of the methods that run on the host
    std::string method = "sampled", channels = "scale,bias,E", parameterization = "linear";
    std::uint32_t size = 64, size_n_dot_v = 0, size_roughness = 0, replicates = 8;
    std::uint64_t samples = 65536, seed = 0;
    bool fast_math = false, double_kernels = false, quiet = false, samples_given = false, replicates_given = false;
};

void run_dfg(DfgArgs& a) {
    DfgBakeSpec& spec = a.job.bake;
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
        const std::string implied = backend_spec(a.backend, a.device).is_oracle() ? "quadrature" : "sampled";
        if (a.method != "sampled" && a.method != implied)
            throw std::invalid_argument("--backend " + a.backend + " contradicts --method " + a.method);
        method = implied;
    }
    spec.method = parse_dfg_method(method);
    spec.channels = parse_dfg_channels(a.channels);
    spec.parameterization = parse_dfg_parameterization(a.parameterization);
    if (!a.job.out.empty()) check_dfg_lut_output(a.job.out, spec.channels, a.job.symbol);
    spec.backend = backend_spec("opencl", a.device, a.threads);  // the method decides the kind (dfg_backend)
    spec.routine.build.fast_math = a.fast_math;
    spec.routine.build.double_precision = a.double_kernels;
    if (spec.method != DfgMethod::sampled && (a.fast_math || a.double_kernels))
        throw std::invalid_argument("--fast-math and --double-kernels build the kernel of --method sampled; --method " + method + " has none");
    if (spec.method != DfgMethod::sampled && (a.samples_given || a.replicates_given))
        throw std::invalid_argument("--samples and --replicates set --method sampled; --method " + method + " is deterministic");
    spec.command_line = command_line();
    run_with_display("ibl dfg", a.quiet, a.job, run_dfg_job, dfg_job_summary);
}

struct ShArgs {
    ShJobSpec job;
    bool quiet = false;
};

void run_sh(ShArgs& a) {
    a.job.command_line = command_line();
    const ShJobResult r = run_sh_job(a.job);
    if (!a.quiet) std::cerr << sh_job_summary(a.job, r);
}

struct PrefilterArgs {
    PrefilterJobSpec job;
    std::string mapping = "cmgen", bright = "auto";
    std::uint32_t replicates = 16;
    std::uint64_t samples = 256, seed = 0;
    bool no_fis = false, quiet = false;
    std::string device;  // empty: the C++ estimator on CPU threads
    unsigned threads = 0;
};

void run_prefilter(PrefilterArgs& a) {
    check_environment(a.job.environment);
    PrefilterSpec& spec = a.job.prefilter;
    spec.mapping = env::parse_roughness_mapping(a.mapping);
    spec.plan.replicates = a.replicates;
    spec.plan.samples = round_up_samples(a.samples, a.replicates);
    spec.plan.seed = a.seed;
    spec.options.filtered = !a.no_fis;
    if (spec.max_samples < a.samples)
        throw std::invalid_argument("--max-samples " + std::to_string(spec.max_samples) + " is below --samples " + std::to_string(a.samples));
    spec.bright_auto = a.bright == "auto";
    if (a.bright == "off" && spec.bright_threshold > 0) throw std::invalid_argument("--bright off and --bright-threshold together");
    // Without --device: the C++ estimator on CPU threads (the oracle kind); with it, the kernel there.
    spec.backend = backend_spec(a.device.empty() ? "oracle" : "opencl", a.device, a.threads);
    spec.command_line = command_line();
    // Test hook: a corrupted estimator (every value scaled by 1 + b, bars unchanged) that --verify must catch.
    if (const char* bias = std::getenv("MICROSHADOW_TEST_PREFILTER_BIAS")) {
        char* end = nullptr;
        spec.test_bias = std::strtod(bias, &end);
        if (end == bias || *end != '\0' || !std::isfinite(spec.test_bias))
            throw std::invalid_argument(std::string("MICROSHADOW_TEST_PREFILTER_BIAS must be a number, not '") + bias + "'");
    }
    run_with_display("ibl prefilter", a.quiet, a.job, run_prefilter_job, prefilter_job_summary);
}

struct IrradianceArgs {
    IrradianceJobSpec job;
    std::string backend = "opencl", device = "default";
    unsigned threads = 0;
    bool quiet = false;
};

void run_irradiance(IrradianceArgs& a) {
    a.job.map.backend = backend_spec(a.backend, a.device, a.threads);
    a.job.map.command_line = command_line();
    run_with_display("ibl irradiance", a.quiet, a.job, run_irradiance_job, irradiance_job_summary);
}

}  // namespace

void add_ibl_command(CLI::App& app) {
    auto* ibl = app.add_subcommand("ibl", "image-based lighting: the split-sum DFG LUT and environment irradiance");
    ibl->require_subcommand(1);

    auto d = std::make_shared<DfgArgs>();
    auto* dfg = ibl->add_subcommand("dfg", "bake the DFG LUT (x = NdotV, y = roughness; R, G, B = scale, bias, E) to OpenEXR, KTX2 or DDS");
    dfg->add_option("--out", d->job.out, "output file, the format by the extension: " + lutfmt::extension_list(lutfmt::TextureUse::dfg) +
                                             " (KTX2 / DDS: RG for 2 channels, else RGBA, DDS metadata in <file>.json; PNG 16-bit; "
                                             ".h: C header, .inc: C initialiser list)")
        ->required();
    dfg->add_option("--method", d->method, "exact (Gauss-Legendre, ~1e-12), sampled (the VNDF kernel, error bars) or quadrature (the independent check)")
        ->check(CLI::IsMember({"exact", "sampled", "quadrature"}))
        ->capture_default_str();
    dfg->add_option("--channels", d->channels, "channels in order, 1-4 of scale, bias, E (= scale + bias), sheen (cloth); Filament: bias,E,sheen")
        ->capture_default_str();
    dfg->add_option("--parameterization", d->parameterization, "x axis: linear (NdotV) or sqrt-n-dot-v (HDRP: x = sqrt(NdotV))")
        ->check(CLI::IsMember({"linear", "sqrt-n-dot-v"}))
        ->capture_default_str();
    dfg->add_option("--symbol", d->job.symbol, "C array name of a .h output (macros SYMBOL_WIDTH, _HEIGHT, _CHANNELS)")->capture_default_str();
    dfg->add_option("--size", d->size, "texels on both axes")->transform(decimal_range(1, 4096))->capture_default_str();
    add_hidden_alias(dfg, "--size-n-dot-v",
                     dfg->add_option("--n-dot-v-count", d->size_n_dot_v, "texels on the NdotV axis (default: --size)")->transform(decimal_range(1, 4096)));
    add_hidden_alias(dfg, "--size-roughness",
                     dfg->add_option("--roughness-count", d->size_roughness, "texels on the roughness axis (default: --size)")->transform(decimal_range(1, 4096)));
    dfg->add_option("--texel", d->texel, "centres (i + 0.5) / n or endpoints i / (n - 1)")
        ->check(CLI::IsMember({"centres", "centers", "endpoints"}))
        ->capture_default_str();
    PlanOptionLimits dfg_plan;
    dfg_plan.samples_help = "--method sampled: VNDF samples per texel (all replicates)";
    dfg_plan.replicates_help = "--method sampled: independent scrambles (error bars)";
    add_plan_options(dfg, d->samples, d->replicates, d->seed, dfg_plan);
    add_backend_option(dfg, d->backend, "older spelling of --method: opencl = sampled, oracle = quadrature");
    add_device_option(dfg, d->device, "default, all, an index or part of a name");
    add_threads_option(dfg, d->threads, "host threads of --method exact / quadrature (0: all)");
    add_verify_option(dfg, d->job.verify, "recompute K random texels by independent methods (exact: the quadrature to 1e-10 and the kernel within its bars); fail, writing nothing, on a disagreement");
    dfg->add_option("--preview", d->job.preview, "also write a PNG of the channels with axes, each on its own scale");
    dfg->add_option("--compare", d->job.compare, "report max and RMS differences from a reference LUT of the same size (e.g. --backend oracle's)");
    dfg->add_option("--warp", d->job.bake.routine.warp, "sample warp towards the VNDF cap's rim: 1 (none), 2, 3")
        ->check(CLI::Range(1, 3))
        ->capture_default_str();
    dfg->add_flag("--half", d->job.half, "16-bit half floats");
    add_kernel_build_flags(dfg, d->fast_math, d->double_kernels);
    add_quiet_flag(dfg, d->quiet, "no progress or summary");
    dfg->callback([d, dfg] {
        d->samples_given = dfg->count("--samples") > 0;
        d->replicates_given = dfg->count("--replicates") > 0;
        run_dfg(*d);
    });

    auto s = std::make_shared<ShArgs>();
    auto* sh = ibl->add_subcommand("sh", "order-2 spherical harmonics (9 per channel) and irradiance of an environment");
    add_environment_options(sh, s->job.environment, "equirectangular (2:1) or cross (4:3, 3:4) environment, .exr or Radiance .hdr, or a .ktx2 / .dds cubemap (its base level)",
                            " (docs/ibl.md: orientation)");
    sh->add_option("--out", s->job.out, "output JSON: coefficients, convolved irradiance coefficients, provenance")->required();
    sh->add_option("--irradiance", s->job.irradiance, "also write the irradiance cubemap (E / pi), the format by the extension: " +
                                                          lutfmt::extension_list(lutfmt::TextureUse::cubemap) +
                                                          " (.exr: a horizontal cross; .ktx2 / .dds: a cubemap, RGBA16F, A = 1)");
    sh->add_option("--face-size", s->job.face_size, "irradiance cubemap face size")->transform(decimal_range(1, 1024))->capture_default_str();
    sh->add_option("--preview", s->job.preview, "PNG of the irradiance cross (Reinhard tone map, sRGB)");
    sh->add_option("--shader", s->job.shader, "also write the irradiance as shader constants and a function (.glsl or .hlsl; cmgen --sh-shader's form)");
    sh->add_option("--symbol", s->job.symbol, "name of the shader constants (NAME[9], NAME_irradiance)")->capture_default_str();
    add_quiet_flag(sh, s->quiet, "no summary");
    sh->callback([s] { run_sh(*s); });

    auto p = std::make_shared<PrefilterArgs>();
    PrefilterSpec& ps = p->job.prefilter;
    auto* pf = ibl->add_subcommand("prefilter", "GGX-prefiltered specular cubemap mip chain (+ SH irradiance) of an environment, into a directory");
    add_environment_options(pf, p->job.environment, "environment: equirectangular (2:1) or a 4:3 / 3:4 cross, .exr or Radiance .hdr, or a .ktx2 / .dds cubemap (its base level)",
                            ", .exr or .hdr (docs/ibl.md: orientation)");
    pf->add_option("--out", p->job.out, "output directory (created)")->required();
    pf->add_option("--size", p->job.size, "base face size (power of two; default: from the source)")->transform(decimal_range(1, 4096));
    pf->add_option("--levels", ps.levels, "mips (default: down to 4 x 4)")->transform(decimal_range(1, 13));
    pf->add_option("--mapping", p->mapping, "roughness per mip: cmgen (r = 1 - sqrt(1 - m / (levels - 1))) or linear")
        ->check(CLI::IsMember({"cmgen", "linear"}))
        ->capture_default_str();
    pf->add_option("--tolerance", ps.tolerance,
                   "sample each texel until its relative 95% error bar (t over the replicates, + the explicit part's bound) is at most this; 0: a fixed --samples")
        ->check(real_range(0, 1))
        ->capture_default_str();
    PlanOptionLimits pf_plan;
    pf_plan.max_samples = 1u << 20;
    pf_plan.samples_help = "GGX samples per texel (all replicates): the first round's with a tolerance, else every texel's";
    add_plan_options(pf, p->samples, p->replicates, p->seed, pf_plan);
    pf->add_option("--max-samples", ps.max_samples, "with a tolerance, at most this many samples per texel")
        ->transform(decimal_range(16, 1u << 24))
        ->capture_default_str();
    pf->add_option("--bright", p->bright, "bright texels summed explicitly: auto (chosen for the tolerance) or off")
        ->check(CLI::IsMember({"auto", "off"}))
        ->capture_default_str();
    pf->add_flag("--no-fis", p->no_fis, "read every sample from the full-resolution source (brute-force importance sampling)");
    pf->add_option("--lod-bias", ps.options.lod_bias, "filtered importance sampling's LOD bias, -16 to 16 (beyond, every read clamps to an end of the chain)")
        ->check(real_range(-16, 16))
        ->capture_default_str();
    pf->add_option("--bright-threshold", ps.bright_threshold,
                   "sum texels brighter than this many times the mean radiance explicitly (the sun), sample the rest, instead of --bright auto's choice")
        ->check(real_range(0, 1e12));
    pf->add_option("--bright-min-roughness", ps.bright_min_roughness, "the wide-lobe mips (bright texels, --wide-samples-factor): roughness at least this")
        ->check(real_range(0, 1))
        ->capture_default_str();
    pf->add_option("--wide-samples-factor", ps.wide_samples_factor, "multiply --samples on the mips of roughness >= --bright-min-roughness")
        ->transform(decimal_range(1, 64))
        ->capture_default_str();
    pf->add_option("--bright-max", ps.bright_max_texels, "at most this many explicit bright texels (the brightest)")
        ->transform(decimal_range(1, 1u << 20))
        ->capture_default_str();
    add_device_option(pf, p->device, "run the kernel on OpenCL devices (default, all, N, name); without it, C++ on CPU threads");
    add_threads_option(pf, p->threads, "CPU threads (0: all)");
    add_verify_option(pf, p->job.verify, "compare K random texels with the brute-force oracle; fail (exit 1, nothing written) when one is outside its bars (Bonferroni)");
    pf->add_flag("--verify-report", p->job.verify_report, "with --verify: record the comparison in ibl.json but never fail (benchmarks of estimators whose bars are not honest)");
    add_cubemap_format_options(pf, p->job.format, p->job.encoding,
                               "specular chain: ktx2 or dds (DIR/specular.<format>: one cubemap with every mip, RGBA, A = 1; what engines load) "
                               "or exr (DIR/specular_m<m>.exr crosses, one per mip)",
                               "ktx2 / dds texels: float16 (RGBA16F) or float32");
    pf->add_option("--irradiance-size", p->job.irradiance_size, "irradiance cubemap face size")->transform(decimal_range(1, 1024))->capture_default_str();
    pf->add_option("--dfg-size", p->job.dfg_size, "also bake the DFG LUT (N x N, default settings) into DIR/dfg.<format> (" + lutfmt::format_list(lutfmt::TextureUse::cubemap) + ")")
        ->transform(decimal_range(0, 4096));
    add_exposure_option(pf, p->job.exposure, "previews");
    add_quiet_flag(pf, p->quiet, "no progress or summary");
    pf->callback([p] { run_prefilter(*p); });

    auto q = std::make_shared<IrradianceArgs>();
    auto* ir = ibl->add_subcommand("irradiance", "irradiance cubemap (E / pi) by direct clamped-cosine convolution, with error bounds and SH comparison");
    add_environment_options(ir, q->job.environment, "environment: equirectangular (2:1) or a 4:3 / 3:4 cross, .exr or Radiance .hdr, or a .ktx2 / .dds cubemap (its base level)",
                            ", .exr or .hdr");
    ir->add_option("--out", q->job.out, "output directory (created): irradiance.<format>, irradiance.json, irradiance_preview.png")->required();
    ir->add_option("--face-size", q->job.map.face_size, "output face size")->transform(decimal_range(1, 1024))->capture_default_str();
    ir->add_option("--source-size", q->job.map.source_size, "convolve the source reduced to this face size (at least; solid-angle means, bounded error)")
        ->transform(decimal_range(1, 8192))
        ->capture_default_str();
    add_cubemap_format_options(ir, q->job.format, q->job.encoding, "exr (horizontal cross), ktx2 or dds (cubemap, RGBA, A = 1)",
                               "ktx2 / dds texels: float16 or float32");
    add_backend_option(ir, q->backend, "opencl (the kernel) or oracle (exact convolution of the full source, C++ double)");
    add_device_option(ir, q->device, "default, all, an index or part of a name");
    add_threads_option(ir, q->threads, "oracle threads (0: all)");
    add_verify_option(ir, q->job.verify, "compare K random texels with the exact convolution; fail if one exceeds its bound");
    add_exposure_option(ir, q->job.exposure, "preview");
    add_quiet_flag(ir, q->quiet, "no progress or summary");
    ir->callback([q] { run_irradiance(*q); });
}

}  // namespace ms::cli
