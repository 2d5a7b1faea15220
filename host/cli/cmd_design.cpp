// microshadow design: every candidate representation against one cached reference set;
// the Pareto front of error against cost, the best candidate inside a budget, and its bake.
#include <nlohmann/json.hpp>


#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>

#include "cli/common.hpp"
#include "cli/plot_runner.hpp"
#include "cli/progress.hpp"
#include "core/cancel.hpp"
#include "fit/closed_form.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "jobs/design.hpp"
#include "jobs/design_closed_form.hpp"
#include "jobs/reference_set.hpp"
#include "repr/presets.hpp"
#include "jobs/repr_bake.hpp"
#include "repr/representation.hpp"


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

// A CSV field quoted, inner quotes doubled (RFC 4180).
std::string csv_quoted(const std::string& text) {
    std::string out = "\"";
    for (char ch : text) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return out + "\"";
}
// A CSV field, quoted only when it holds a comma, a quote or a line break.
std::string csv_field(const std::string& text) {
    return text.find_first_of(",\"\r\n") == std::string::npos ? text : csv_quoted(text);
}

// A Markdown table cell: '|' escaped, line breaks as spaces.
std::string md_cell(const std::string& text) {
    std::string out;
    for (char ch : text) {
        if (ch == '|') out += "\\|";
        else if (ch == '\n' || ch == '\r') out += ' ';
        else out += ch;
    }
    return out;
}

// A representation file (repr/representation.hpp) as a candidate: its own cost model, lookup and
// provenance; bake() writes its texture (HALF, as an engine uploads it) and its GLSL/HLSL.
design::Candidate representation_candidate(const std::string& name, const std::string& file) {
    std::shared_ptr<const repr::Representation> r;
    try {
        // A preset's name (no such file): baked here with the exact method.
        std::error_code ec;
        if (repr::is_preset(file) && !fs::exists(file, ec)) {
            auto backend = make_oracle_backend();
            r = repr::bake_preset(repr::preset(file), *backend, "preset " + file);
        } else {
            r = repr::open_representation(file);
        }
    } catch (const std::exception& e) {
        throw std::invalid_argument(std::string("--repr ") + file + ": " + e.what());
    }
    design::Candidate c;
    c.name = name;
    c.kind = r->kind();
    c.cost = r->cost();
    // ALU counted from its GLSL like every other candidate (the representation's own estimate differs).
    c.cost.alu_per_light = design::count_alu(r->shader(repr::ShaderLanguage::glsl, file));
    c.value = [r](const approx::Inputs& in) { return (*r)(in); };
    c.domain = r->domain();
    c.provenance = r->provenance();
    c.provenance["name"] = name;
    c.provenance["file"] = json_safe(file);
    c.bake = [r](OutputSet& outputs, const std::string& prefix) {
        const std::string source = fs::path(prefix + ".exr").filename().string();
        r->write(outputs.temp_path(outputs.add(prefix + ".exr", true)), /*half=*/true);
        outputs.stream(outputs.add(prefix + ".glsl")) << r->shader(repr::ShaderLanguage::glsl, source);
        outputs.stream(outputs.add(prefix + ".hlsl")) << r->shader(repr::ShaderLanguage::hlsl, source);
    };
    return c;
}

// NAME=FILE or FILE (named after its stem).
std::pair<std::string, std::string> named_file(const std::string& option, const std::string& text) {
    const auto eq = text.find('=');
    const std::string file = eq == std::string::npos ? text : text.substr(eq + 1);
    const std::string name = eq == std::string::npos ? fs::path(text).stem().string() : text.substr(0, eq);
    if (name.empty() || file.empty()) throw std::invalid_argument(option + " " + text + ": expected FILE or NAME=FILE");
    try {
        design::check_candidate_name(name);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(option + " " + text + ": " + e.what() +
                                    (eq == std::string::npos ? " (the name is the file's stem: give one with NAME=FILE)" : ""));
    }
    return {name, file};
}

std::string fixed(double v, int digits = 4) {
    std::ostringstream s;
    s << std::setprecision(digits) << v;
    return s.str();
}

std::string bytes_text(std::uint64_t b) {
    if (b == 0) return "0";
    if (b % (1024 * 1024) == 0) return std::to_string(b / (1024 * 1024)) + " MiB";
    if (b % 1024 == 0) return std::to_string(b / 1024) + " KiB";
    return std::to_string(b) + " B";
}

// A reference spec parsed and checked in full (its sampling as every sampling job checks it, and as the
// cache needs it), before anything is computed or written.
design::ReferenceDefinition checked_definition(const std::string& spec, const DesignArgs& args) {
    design::ReferenceDefinition def = design::parse_reference_spec_file(spec);
    def.backend_label = args.sampling.backend;
    try {
        if (def.plan.method == Method::sampled) check_sampling_size(def.plan);
        design::check_plan(def);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(spec + ": [sampling]: " + e.what());
    }
    return def;
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
    Progress progress(std::string("design: ") + what + " reference " + def.name, args.sampling.quiet);
    config.progress = [&](std::size_t done, std::size_t total) { progress.update(done, total); };
    design::CacheReport report;
    design::ReferenceSet set = design::load_or_compute(def, config, &report);
    progress.finish();
    if (!args.sampling.quiet)
        std::cerr << "design: " << what << " reference '" << def.name << "': " << set.points.size() << " points, "
                  << (def.plan.method == Method::exact ? std::string("exact method, max estimated error ")
                                                       : std::to_string(def.plan.samples) + " samples each, max std error ")
                  << ""<< fixed(set.max_std_error, 3) << ", RMS "
                  << fixed(set.rms_std_error, 3) << (report.from_cache ? " (cached: " : " (computed in " + fixed(report.seconds, 3) + " s: ")
                  << set.file << ")\n";
    return set;
}

void run_design(const DesignArgs& args) {
    design::Budget budget;
    budget.max_bytes = parse_bytes(args.max_bytes);
    budget.max_fetches = args.max_fetches;
    budget.max_alu = args.max_alu;
    const bool has_fit = !args.fit_reference.empty();
    if (has_fit && args.fit_orders.empty()) throw std::invalid_argument("--fit-orders: at least one order");

    // Every candidate that needs no reference is built first: a bad file stops before any work.
    std::vector<design::Candidate> candidates;
    // Both reference specs in full before any work (a bad fit spec must not wait for the evaluation set).
    const design::ReferenceDefinition evaluation_def = checked_definition(args.reference, args);
    design::ReferenceDefinition fit_def;
    if (has_fit) {
        fit_def = checked_definition(args.fit_reference, args);
        if (fit_def.options.ao_weighting != evaluation_def.options.ao_weighting)
            throw std::invalid_argument("--fit-reference: its AO weighting differs from --reference's");
    }
    if (!args.no_analytic) candidates = design::analytic_candidates(evaluation_def.options.ao_weighting);
    for (const auto& l : args.luts) {
        const auto [name, file] = named_file("--lut", l);
        candidates.push_back(design::lut_candidate(name, file));
    }
    for (const auto& l : args.reprs) {
        const auto [name, file] = named_file("--repr", l);
        candidates.push_back(representation_candidate(name, file));
    }
    for (const auto& f : args.closed_forms) candidates.push_back(design::closed_form_candidate(fit::read_closed_form(f), f));
    if (candidates.empty() && !has_fit) throw std::invalid_argument("no candidates (--no-analytic without --lut, --repr, --closed-form or --fit-reference)");

    // Outputs checked before any work.
    OutputSet outputs;
    std::size_t csv_out = 0, md_out = 0, json_out = 0;
    if (!args.out.empty()) {
        std::error_code ec;
        fs::create_directories(args.out, ec);
        if (ec) throw std::invalid_argument("--out " + args.out + ": cannot create the folder (" + ec.message() + ")");
        csv_out = outputs.add((fs::path(args.out) / "pareto.csv").string());
        md_out = outputs.add((fs::path(args.out) / "pareto.md").string());
        json_out = outputs.add((fs::path(args.out) / "design.json").string());
    }

    {
        // Names are checked before any work too: the fitted closed forms' names are known in advance.
        std::set<std::string> names;
        for (const auto& c : candidates)
            if (!names.insert(c.name).second)
                throw std::invalid_argument("two candidates named '" + c.name + "'; name LUTs with --lut NAME=FILE");
        if (has_fit)
            for (unsigned order : args.fit_orders)
                if (names.count("closed-form-" + std::to_string(order)))
                    throw std::invalid_argument("two candidates named 'closed-form-" + std::to_string(order) +
                                                "' (a --closed-form file and --fit-orders " + std::to_string(order) + ")");
    }
    if (!args.choose.empty()) {
        // --choose names a candidate known now (or a closed form this run fits): refused before the work.
        std::vector<std::string> names;
        for (const auto& c : candidates) names.push_back(c.name);
        if (has_fit)
            for (unsigned order : args.fit_orders) names.push_back("closed-form-" + std::to_string(order));
        if (std::find(names.begin(), names.end(), args.choose) == names.end()) {
            std::string list;
            for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
            throw std::invalid_argument("--choose " + args.choose + ": no such candidate (candidates: " + list + ")");
        }
    }

    TermBackend* backend = nullptr;
    std::unique_ptr<TermBackend> owned;
    const design::ReferenceSet set = reference_set(evaluation_def, args, backend, owned, "evaluation");
    nlohmann::json fits = nlohmann::json::array();
    if (has_fit) {
        const design::ReferenceSet training = reference_set(fit_def, args, backend, owned, "fit");
        for (unsigned order : args.fit_orders) {
            throw_if_cancelled();
            fit::ClosedForm form = design::fit_closed_form(training, order);
            form.provenance["command_line"] = command_line();
            design::Candidate c = design::closed_form_candidate(form, "");
            fits.push_back(form.provenance);
            candidates.push_back(std::move(c));
        }
    }
    {
        std::set<std::string> names;
        for (const auto& c : candidates)
            if (!names.insert(c.name).second)
                throw std::invalid_argument("two candidates named '" + c.name + "'; name LUTs with --lut NAME=FILE");
    }

    // Reference points outside each candidate's domain: counted, reported, refused with --strict-domain.
    std::vector<design::DomainCount> outside;
    for (const auto& c : candidates) {
        outside.push_back(design::count_outside_domain(c, set));
        if (args.strict_domain && c.domain)
            compare::refuse_outside_domain(args.reference, c.name, *c.domain, outside.back().tally, outside.back().first_outside);
        if (outside.back().tally.outside > 0)
            std::cerr << "design: warning: " << c.name << ": " << outside.back().tally.outside << " of " << outside.back().tally.lookups
                      << " reference points outside its domain (" << c.domain->describe() << "), e.g. "
                      << outside.back().first_outside << "; --strict-domain refuses them\n";
    }
    Progress progress("design: candidates", args.sampling.quiet);
    std::vector<design::Metrics> metrics;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        throw_if_cancelled();
        metrics.push_back(design::evaluate_candidate(candidates[i], set));
        progress.update(i + 1, candidates.size());
    }
    progress.finish();
    const std::vector<std::size_t> front = design::pareto_front(candidates, metrics);
    std::size_t chosen = candidates.size();
    if (!args.choose.empty()) {
        for (std::size_t i = 0; i < candidates.size(); ++i)
            if (candidates[i].name == args.choose) chosen = i;
        if (chosen == candidates.size()) {
            std::string names;
            for (const auto& c : candidates) names += (names.empty() ? "" : ", ") + c.name;
            throw std::invalid_argument("--choose " + args.choose + ": no such candidate (candidates: " + names + ")");
        }
        if (!budget.fits(candidates[chosen].cost))
            throw std::invalid_argument("--choose " + args.choose + ": over the budget (" +
                                        std::to_string(candidates[chosen].cost.bytes) + " bytes, " +
                                        std::to_string(candidates[chosen].cost.fetches_per_light) + " fetches, " +
                                        std::to_string(candidates[chosen].cost.alu_per_light) + " ALU)");
    } else {
        chosen = design::choose(candidates, metrics, budget);
    }

    // The table, sorted by weighted RMS error; "*" marks the Pareto front, ">" the chosen candidate.
    std::vector<std::size_t> order(candidates.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](auto a, auto b) { return metrics[a].weighted_rms < metrics[b].weighted_rms; });
    const std::set<std::size_t> on_front(front.begin(), front.end());
    std::ostringstream md, csv;
    md << "| | candidate | kind | storage | bytes | fetches | ALU | N.L-weighted RMS | p99 | max | outside domain |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|\n";
    csv << "name,kind,storage,bytes,fetches_per_light,alu_per_light,weighted_rms,weighted_p99,max_abs,pareto,chosen,within_budget,"
           "outside_domain\n";
    for (std::size_t i : order) {
        const auto& c = candidates[i];
        const auto& m = metrics[i];
        md << "| " << (i == chosen ? ">" : "") << (on_front.count(i) ? "*" : "") << " | " << md_cell(c.name) << " | "
           << md_cell(c.kind) << " | " << md_cell(c.cost.storage) << " | " << bytes_text(c.cost.bytes) << " | " << c.cost.fetches_per_light << " | "
           << c.cost.alu_per_light << " | " << fixed(m.weighted_rms) << " | " << fixed(m.weighted_p99) << " | "
           << fixed(m.max_abs) << " | " << (c.domain ? std::to_string(outside[i].tally.outside) : std::string("-")) << " |\n";
        csv << csv_field(c.name) << "," << csv_field(c.kind) << "," << csv_quoted(c.cost.storage) << "," << c.cost.bytes << "," << c.cost.fetches_per_light
            << "," << c.cost.alu_per_light << "," << format_number(m.weighted_rms) << "," << format_number(m.weighted_p99)
            << "," << format_number(m.max_abs) << "," << (on_front.count(i) ? 1 : 0) << "," << (i == chosen ? 1 : 0) << ","
            << (budget.fits(c.cost) ? 1 : 0) << "," << outside[i].tally.outside << "\n";
    }
    // Where the errors live: N.L-weighted RMS and max per roughness band.
    const std::vector<double> edges = {0.0, 0.2, 0.4, 0.6, 0.8, 1.0};
    std::ostringstream bands;
    bands << "| candidate |";
    for (std::size_t k = 0; k + 1 < edges.size(); ++k) bands << " roughness " << edges[k] << "-" << edges[k + 1] << " |";
    bands << "\n|---|";
    for (std::size_t k = 0; k + 1 < edges.size(); ++k) bands << "---|";
    bands << "\n";
    nlohmann::json by_roughness = nlohmann::json::object();
    for (std::size_t i : order) {
        const auto per = design::evaluate_candidate_by_roughness(candidates[i], set, edges);
        bands << "| " << md_cell(candidates[i].name) << " |";
        nlohmann::json list = nlohmann::json::array();
        for (const auto& m : per) {
            bands << " " << (m.points ? fixed(m.weighted_rms, 3) + " (max " + fixed(m.max_abs, 2) + ")" : std::string("-")) << " |";
            list.push_back({{"points", m.points}, {"weighted_rms", m.weighted_rms}, {"weighted_p99", m.weighted_p99}, {"max_abs", m.max_abs}});
        }
        bands << "\n";
        by_roughness[candidates[i].name] = list;
    }
    const std::string noise = "reference '" + set.definition.name + "': " + std::to_string(set.points.size()) +
                              " points, term std error max " + fixed(set.max_std_error, 3) + ", RMS " +
                              fixed(set.rms_std_error, 3);
    std::cout << md.str() << "\n" << noise << "; * Pareto front (weighted RMS, bytes, fetches, ALU), > chosen: "
              << candidates[chosen].name << "\n";

    if (!args.out.empty()) {
        outputs.stream(csv_out) << csv.str();
        outputs.stream(md_out) << md.str() << "\n" << noise << ". `*` Pareto front over (N.L-weighted RMS, bytes, "
                               << "fetches, ALU); `>` chosen.\n\nN.L-weighted RMS (max |error|) per roughness band:\n\n"
                               << bands.str();
        nlohmann::json candidates_json = nlohmann::json::array();
        for (std::size_t i = 0; i < candidates.size(); ++i) {
            nlohmann::json j = candidates[i].provenance;
            j["bytes"] = candidates[i].cost.bytes;
            j["fetches_per_light"] = candidates[i].cost.fetches_per_light;
            j["alu_per_light"] = candidates[i].cost.alu_per_light;
            j["storage"] = candidates[i].cost.storage;
            j["weighted_rms"] = metrics[i].weighted_rms;
            j["weighted_p99"] = metrics[i].weighted_p99;
            j["max_abs"] = metrics[i].max_abs;
            j["points"] = metrics[i].points;
            j.update(compare::domain_report(candidates[i].domain, outside[i].tally));
            // Where the largest errors are (the reference point and the error there).
            nlohmann::json worst = nlohmann::json::array();
            for (const auto& [index, error] : design::worst_points(candidates[i], set, 5)) {
                const auto& p = set.points[index];
                worst.push_back({{"visibility", p.visibility}, {"n_dot_l", p.n_dot_l}, {"n_dot_v", p.n_dot_v},
                                 {"roughness", p.roughness}, {"relative_azimuth_deg", p.relative_azimuth * 180 / 3.14159265358979323846},
                                 {"term", set.values[index].term}, {"error", error}});
            }
            j["worst_points"] = worst;
            candidates_json.push_back(j);
        }
        nlohmann::json meta = {{"program", "microshadow " MICROSHADOW_VERSION},
                               {"command_line", command_line()},
                               {"reference", {{"spec", json_safe(args.reference)}, {"hash", set.definition.hash()},
                                              {"file", json_safe(set.file)}, {"definition", set.definition.canonical_text()},
                                              {"max_std_error", set.max_std_error}, {"rms_std_error", set.rms_std_error}}},
                               {"error", "comparator - term, weighted by weight x NdotL"},
                               {"budget", {{"max_bytes", budget.max_bytes}, {"max_fetches", budget.max_fetches},
                                           {"max_alu", budget.max_alu}}},
                               {"candidates", candidates_json},
                               {"chosen", candidates[chosen].name}};
        if (has_fit) meta["fits"] = fits;
        meta["by_roughness"] = {{"edges", edges}, {"candidates", by_roughness}};
        if (candidates[chosen].bake) {
            const std::string prefix = (fs::path(args.out) / ("chosen-" + candidates[chosen].name)).string();
            candidates[chosen].bake(outputs, prefix);
            meta["baked"] = prefix;
        } else {
            meta["baked"] = "nothing to bake: " + candidates[chosen].name + " is part 1's formula (docs/study.md)";
        }
        outputs.stream(json_out) << dump_json(meta, 2) << "\n";
        outputs.commit();
        if (!args.sampling.quiet) std::cerr << "design: wrote " << args.out << "/pareto.{csv,md}, design.json"
                                            << (candidates[chosen].bake ? " and chosen-" + candidates[chosen].name + ".*" : std::string()) << "\n";
        if (args.plot) {
            const fs::path dir = fs::absolute(args.out).lexically_normal();
            run_plotter({"/usr/bin/python3", find_plot_script("plot_pareto.py"), (dir / "pareto.csv").string(), "--out", (dir / "pareto.png").string(),
                         "--title", "reference '" + set.definition.name + "', " + std::to_string(set.points.size()) + " points"},
                        "design", args.sampling.quiet, "the tables are written");
        }
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
    cmd->add_flag("--plot", args->plot, "with --out: draw OUT/pareto.png with plot_pareto.py (/usr/bin/python3, matplotlib)");
    cmd->add_flag("--strict-domain", args->strict_domain,
                  "refuse (exit status 2, nothing written) a candidate whose domain (a file's or a fit's roughness, visibility "
                  "and NdotV ranges) leaves out reference points; without it they are counted (\"outside domain\" in pareto.md/.csv, "
                  "design.json) and warned of");
    cmd->add_flag("--no-analytic", args->no_analytic, "leave part 1's terms out of the candidates");
    cmd->add_option("--backend", args->sampling.backend, "where a missing reference is computed: opencl or oracle")
        ->check(CLI::IsMember({"opencl", "oracle"}))->capture_default_str();
    cmd->add_option("--device", args->sampling.device, "OpenCL device(s): default, all, an index from `devices`, or part of a name")
        ->capture_default_str();
    cmd->add_flag("-q,--quiet", args->sampling.quiet, "no progress or summary on stderr");
    cmd->callback([args] {
        if (args->plot && args->out.empty()) throw std::invalid_argument("--plot needs --out");
        run_design(*args);
    });
}

}  // namespace ms::cli
