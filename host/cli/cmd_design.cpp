// microshadow design: the command's options and its output on the terminal; the study itself (every
// candidate against one cached reference set, the Pareto front, the best candidate inside a budget,
// its bake) is jobs/design_study.hpp's.
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/common.hpp"
#include "cli/mpi_world.hpp"
#include "cli/plot_runner.hpp"
#include "cli/progress.hpp"
#include "fit/closed_form.hpp"
#include "io/atomic_file.hpp"
#include "jobs/design_study.hpp"
#include "jobs/reference_set.hpp"

namespace ms::cli {

namespace {

namespace fs = std::filesystem;

struct DesignArgs {
    std::string reference, fit_reference, cache = "out/design-cache", out, choose;
    std::vector<std::string> luts, reprs, closed_forms;
    std::vector<unsigned> fit_orders = {1, 2, 3};
    std::string max_bytes = "unlimited";
    unsigned max_fetches = UINT32_MAX, max_alu = UINT32_MAX;
    bool plot = false, no_analytic = false, strict_domain = false;
    SamplingOptions sampling;
    // Beyond one process (docs/cluster.md): the reference sets' chunks split into shards, merged, or
    // shared among MPI ranks.
    DistributionArgs distribution;
    schedule::DistributionRequest request;  // of `distribution`, resolved in run_design
};

// "65536", "64KiB", "1.5MiB", "unlimited": bytes. Decimal digits with an optional fraction and unit,
// nothing else (std::stod would also take "0x10", " 5", "1e3" or "inf"). Throws std::invalid_argument.
std::uint64_t parse_bytes(const std::string& text) {
    if (text == "unlimited") return UINT64_MAX;
    std::size_t used = 0;
    while (used < text.size() && std::isdigit(static_cast<unsigned char>(text[used]))) ++used;
    const std::size_t whole_digits = used;
    if (used < text.size() && text[used] == '.') {
        const std::size_t dot = used++;
        while (used < text.size() && std::isdigit(static_cast<unsigned char>(text[used]))) ++used;
        if (used == dot + 1) used = 0;  // "5." has no fraction digits
    }
    const std::string unit = used ? text.substr(used) : std::string();
    double scale = 0;
    if (unit.empty() || unit == "B") scale = 1;
    else if (unit == "KiB") scale = 1024;
    else if (unit == "MiB") scale = 1024.0 * 1024;
    else if (unit == "GiB") scale = 1024.0 * 1024 * 1024;
    const double value = used && whole_digits ? std::strtod(text.substr(0, used).c_str(), nullptr) : -1;
    if (used == 0 || whole_digits == 0 || scale == 0 || !(value >= 0) || value * scale >= 1.8e19)
        throw std::invalid_argument("--max-bytes " + text +
                                    ": expected a size in bytes >= 0 (a decimal number with an optional B, KiB, MiB or GiB) or 'unlimited'");
    return std::uint64_t(value * scale);
}


std::string fixed(double v, int digits = 4) {
    std::ostringstream s;
    s << std::setprecision(digits) << v;
    return s.str();
}

design::ReferenceSet reference_set(const design::ReferenceDefinition& def, const DesignArgs& args, TermBackend*& backend,
                                   std::unique_ptr<TermBackend>& owned, const char* what) {
    design::CacheConfig config;
    config.dir = args.cache;
    config.command_line = command_line();
    // The backend (device start-up) only when something has to be computed.
    config.backend = backend;
    config.open_backend = [&]() {
        if (!owned) owned = args.sampling.make_backend();
        backend = owned.get();
        return backend;
    };
    config.warn = [&](const std::string& w) { std::cerr << "\ndesign: warning: " << w << "\n"; };
    config.shard = args.request.shard;
    config.merge = args.request.merge;
    config.transport = args.request.transport;
    const bool rank0 = !config.transport || config.transport->coordinator();
    Progress progress(std::string("design: ") + what + " reference " + def.name, args.sampling.quiet || !rank0);
    config.progress = [&](std::size_t done, std::size_t total) { progress.update(done, total); };
    design::CacheReport report;
    design::ReferenceSet set = design::load_or_compute(def, config, &report);
    progress.finish();
    if (!report.complete) {
        // A shard (or a rank that only computed): its chunks are in the chunk folder, the rest is the merge's.
        if (!config.transport && !args.sampling.quiet)
            std::cerr << "design: " << what << " reference '" << def.name << "': shard " << config.shard.index << "/"
                      << config.shard.count << " finished in " << report.chunk_folder << " (" << report.chunks_found
                      << " of its chunks found there, " << report.chunks_computed
                      << " computed); when every shard has, run the same command with --merge in place of --shard\n";
        set.points.clear();
        return set;
    }
    if (!args.sampling.quiet)
        std::cerr << "design: " << what << " reference '" << def.name << "': " << set.points.size() << " points, "
                  << (def.plan.method == Method::exact ? std::string("exact method, max estimated error ")
                                                       : std::to_string(def.plan.samples) + " samples each, max std error ")
                  << ""<< fixed(set.max_std_error, 3) << ", RMS "
                  << fixed(set.rms_std_error, 3) << (report.from_cache ? " (cached: " : " (computed in " + fixed(report.seconds, 3) + " s: ")
                  << set.file << ")\n";
    return set;
}


void run_design(DesignArgs args, MpiWorld* world) {
    args.request = distribution_request(args.distribution, world);
    if (world && !args.fit_reference.empty())
        throw std::invalid_argument("--mpi shares one reference set's chunks: compute the --fit-reference set first "
                                    "(design --reference FIT.toml --mpi ...), then run with both");
    // Only one process writes: not a shard, not an MPI rank other than 0.
    const bool writer = (!world || world->writer()) && args.request.shard.count == 1;
    design::StudySpec spec;
    spec.reference = args.reference;
    spec.fit_reference = args.fit_reference;
    spec.luts = args.luts;
    spec.reprs = args.reprs;
    spec.closed_forms = args.closed_forms;
    spec.fit_orders = args.fit_orders;
    spec.budget.max_bytes = parse_bytes(args.max_bytes);
    spec.budget.max_fetches = args.max_fetches;
    spec.budget.max_alu = args.max_alu;
    spec.choose = args.choose;
    spec.analytic = !args.no_analytic;
    spec.strict_domain = args.strict_domain;
    spec.backend_label = args.sampling.backend_spec().kind_name();
    spec.build = args.sampling.build_config();
    spec.command_line = command_line();
    spec.check_sampling = check_sampling_size;
    // Every input checked before any work, the outputs too.
    design::Study study(std::move(spec));

    OutputSet outputs;
    design::Study::Files files;
    // The output folder is made now (its files are checked before the work), and removed again if this
    // run made it and stops before writing: a refused or failed run leaves nothing behind.
    struct MadeFolder {
        fs::path path;
        bool keep = false;
        ~MadeFolder() {
            std::error_code ignored;
            if (!keep && !path.empty()) fs::remove(path, ignored);  // removes only an empty folder
        }
    } made_folder;
    if (!args.out.empty() && writer) {
        std::error_code ec;
        if (!fs::exists(args.out)) made_folder.path = args.out;
        fs::create_directories(args.out, ec);
        if (ec) throw std::invalid_argument("--out " + args.out + ": cannot create the folder (" + ec.message() + ")");
        files = design::Study::add_outputs(outputs, args.out);
    }

    TermBackend* backend = nullptr;
    std::unique_ptr<TermBackend> owned;
    const design::ReferenceSet set = reference_set(study.evaluation_definition(), args, backend, owned, "evaluation");
    if (!writer) {
        // A shard computes its part of both sets; the merge evaluates the candidates and writes.
        if (study.fit_definition()) reference_set(*study.fit_definition(), args, backend, owned, "fit");
        return;
    }
    if (study.fit_definition()) study.add_fits(reference_set(*study.fit_definition(), args, backend, owned, "fit"));

    Progress progress("design: candidates", args.sampling.quiet);
    const design::StudyResult result = study.judge(
        set, [](const std::string& w) { std::cerr << "design: warning: " << w << "; --strict-domain refuses them\n"; },
        [&](std::size_t done, std::size_t total) { progress.update(done, total); });
    progress.finish();
    const std::string chosen = study.candidates()[result.chosen].name;
    std::cout << study.pareto_markdown(result) << "\n" << design::Study::reference_summary(set)
              << "; * Pareto front (weighted RMS, bytes, fetches, ALU), > chosen: " << chosen << "\n";
    // Without a texture among the candidates the memory budget decided nothing: say so, and how to
    // weigh textures, rather than let "chosen" read as the answer to the budget.
    const auto& all = study.candidates();
    if (std::none_of(all.begin(), all.end(), [](const design::Candidate& c) { return c.cost.bytes > 0; }))
        std::cout << "note: no candidate stores a texture, so --max-bytes decided nothing and " << chosen
                  << " is the lowest error among formulas; add --lut FILE or --repr PRESET|FILE to weigh textures "
                     "(docs/study.md)\n";
    if (args.out.empty()) return;
    const std::string baked = study.write(outputs, files, args.out, result, set);
    outputs.commit();
    made_folder.keep = true;
    if (!args.sampling.quiet)
        std::cerr << "design: wrote " << args.out << "/pareto.{csv,md}, design.json"
                  << (baked.empty() ? std::string() : " and chosen-" + chosen + ".*") << "\n";
    if (args.plot) {
        const fs::path dir = fs::absolute(args.out).lexically_normal();
        run_plot_script("plot_pareto.py",
                        {(dir / "pareto.csv").string(), "--out", (dir / "pareto.png").string(), "--title",
                         "reference '" + set.definition.name + "', " + std::to_string(set.points.size()) + " points"},
                        "the tables are written");
    }
}

}  // namespace

void add_design_command(CLI::App& app) {
    auto args = std::make_shared<DesignArgs>();
    auto* cmd = app.add_subcommand(
        "design", "judge every representation (part 1's terms, LUTs, the fitted closed form) against a cached reference set: "
                  "Pareto front of N.L-weighted error against bytes, fetches and ALU; bake the best inside a budget");
    cmd->add_option("--reference", args->reference,
                    "reference spec (TOML: [points] region or csv, [sampling]; docs/study/design-*.toml); computed once, "
                    "cached by the hash of its definition (method included). Its sampling.method defaults to exact: "
                    "at 1e-10 it takes ~10 us a point per core, less than the sampled default's 65536 samples (~45 us "
                    "a point per core for ~5e-4), and references need accuracy")->required();
    cmd->add_option("--cache", args->cache, "folder of cached reference sets (resumable chunks while computing)")->capture_default_str();
    cmd->add_option("--lut", args->luts, "a baked LUT (.exr) as a candidate, FILE or NAME=FILE (repeatable)");
    cmd->add_option("--repr", args->reprs, "a representation as a candidate: a file (`microshadow repr bake`) or a preset's name (realistic, full-range, anisotropic; baked "
                    "here), FILE or NAME=FILE (repeatable)");
    cmd->add_option("--closed-form", args->closed_forms, "a fitted closed form (JSON written by design) as a candidate (repeatable)");
    cmd->add_option("--fit-reference", args->fit_reference,
                    "fit the closed form to this reference spec (use other points than --reference) at each --fit-orders");
    cmd->add_option("--fit-orders", args->fit_orders, "closed-form model orders to fit (1-" +
                    std::to_string(fit::kMaxClosedFormOrder) + ")")
        ->delimiter(',')->check(CLI::Range(1u, fit::kMaxClosedFormOrder))->capture_default_str();
    cmd->add_option("--max-bytes", args->max_bytes, "budget: texture bytes (B, KiB, MiB, GiB or 'unlimited')")->capture_default_str();
    cmd->add_option("--max-fetches", args->max_fetches, "budget: texture fetches per light")->transform(decimal_range(0, UINT32_MAX));
    cmd->add_option("--max-alu", args->max_alu, "budget: ALU instructions per light (counted from the GLSL)")->transform(decimal_range(0, UINT32_MAX));
    cmd->add_option("--choose", args->choose, "bake this candidate instead of the best inside the budget");
    cmd->add_option("--out", args->out, "folder for pareto.csv, pareto.md, design.json and the chosen candidate's files "
                                        "(chosen-NAME.*: its data and GLSL/HLSL)");
    cmd->add_flag("--plot", args->plot, "with --out: draw OUT/pareto.png with plot_pareto.py (Python 3 with matplotlib: MICROSHADOW_PYTHON, else python3 or py on PATH)");
    cmd->add_flag("--strict-domain", args->strict_domain,
                  "refuse (exit status 2, nothing written) a candidate whose domain (a file's or a fit's roughness, visibility "
                  "and NdotV ranges) leaves out reference points; without it they are counted (\"outside domain\" in pareto.md/.csv, "
                  "design.json) and warned of");
    cmd->add_flag("--no-analytic", args->no_analytic, "leave part 1's terms out of the candidates");
    add_backend_option(cmd, args->sampling.backend, "where a missing reference is computed: opencl or oracle");
    add_device_option(cmd, args->sampling.device);
    add_quiet_flag(cmd, args->sampling.quiet);
    add_distribution_options(cmd, args->distribution, "reference chunks", "");
    cmd->callback([args] {
        if (args->plot && args->out.empty()) throw std::invalid_argument("--plot needs --out");
        with_distribution(args->distribution, [&](MpiWorld* world) { run_design(*args, world); });
    });
}

}  // namespace ms::cli
