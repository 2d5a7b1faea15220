#include "jobs/design_study.hpp"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/cancel.hpp"
#include "fit/closed_form.hpp"
#include "io/csv.hpp"
#include "lut/formats/texture_writer.hpp"
#include "io/text.hpp"
#include "jobs/design_closed_form.hpp"
#include "jobs/eval.hpp"
#include "jobs/repr_bake.hpp"
#include "lut/shader/compose.hpp"
#include "repr/presets.hpp"
#include "repr/representation.hpp"

namespace ms::design {

namespace {

namespace fs = std::filesystem;

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

std::string cost_text(const approx::Cost& c) {
    return std::to_string(c.bytes) + " bytes, " + std::to_string(c.fetches_per_light) + " fetches, " +
           std::to_string(c.alu_per_light) + " ALU";
}

std::string fit_name(unsigned order) { return "closed-form-" + std::to_string(order); }

}  // namespace

std::pair<std::string, std::string> named_file(const std::string& option, const std::string& text) {
    const auto eq = text.find('=');
    const std::string file = eq == std::string::npos ? text : text.substr(eq + 1);
    const std::string name = eq == std::string::npos ? fs::path(text).stem().string() : text.substr(0, eq);
    if (name.empty() || file.empty()) throw std::invalid_argument(option + " " + text + ": expected FILE or NAME=FILE");
    try {
        check_candidate_name(name);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(option + " " + text + ": " + e.what() +
                                    (eq == std::string::npos ? " (the name is the file's stem: give one with NAME=FILE)" : ""));
    }
    return {name, file};
}

Candidate representation_candidate(const std::string& name, const std::string& file, const std::string& option) {
    std::shared_ptr<const repr::Representation> r;
    try {
        std::error_code ec;
        if (repr::is_preset(file) && !fs::exists(file, ec)) {
            auto backend = make_oracle_backend();
            r = repr::bake_preset(repr::preset(file), *backend, "preset " + file);
        } else {
            r = repr::open_representation(file);
        }
    } catch (const std::exception& e) {
        throw std::invalid_argument(option + " " + file + ": " + e.what());
    }
    Candidate c;
    c.name = name;
    c.kind = r->kind();
    c.cost = r->cost();
    // ALU counted from its GLSL like every other candidate (the representation's own estimate differs).
    c.cost.alu_per_light = count_alu(r->shader(repr::ShaderLanguage::glsl, file));
    c.value = [r](const approx::Inputs& in) { return (*r)(in); };
    c.domain = r->domain();
    c.provenance = r->provenance();
    c.provenance["name"] = name;
    c.provenance["file"] = json_safe(file);
    c.bake = [r](OutputSet& outputs, const std::string& prefix) {
        const std::string source = fs::path(prefix + ".exr").filename().string();
        const auto exr = lutfmt::TextureFormat::exr;
        lutfmt::write_texture(outputs, lutfmt::add_texture_files(outputs, prefix + ".exr", exr), r->texture_file(exr, /*half=*/true),
                              lutfmt::PixelEncoding::float16);
        for (const auto language : {lutshader::ShaderLanguage::glsl, lutshader::ShaderLanguage::hlsl})
            outputs.stream(outputs.add(prefix + "." + lutshader::to_string(language)))
                << lutshader::compose(r->shader(language, source), language, lutshader::default_prefix(prefix + ".glsl"));
    };
    return c;
}

ReferenceDefinition checked_definition(const std::string& spec, const std::string& backend_label,
                                       const std::function<void(const SamplingPlan&)>& check_sampling,
                                       const ocl::BuildConfig& build) {
    ReferenceDefinition def = parse_reference_spec_file(spec);
    def.backend_label = backend_label;
    def.build = build;
    try {
        if (def.plan.method == Method::sampled && check_sampling) check_sampling(def.plan);
        check_plan(def);
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(spec + ": [sampling]: " + e.what());
    }
    return def;
}

Study::Study(StudySpec spec) : spec_(std::move(spec)) {
    const OptionNames& n = spec_.names;
    const bool has_fit = !spec_.fit_reference.empty();
    if (spec_.reference.empty()) throw std::invalid_argument(n.reference + ": the reference spec is required");
    if (has_fit && spec_.fit_orders.empty()) throw std::invalid_argument(n.fit_orders + ": at least one order");
    for (unsigned order : spec_.fit_orders)
        if (order < 1 || order > fit::kMaxClosedFormOrder)
            throw std::invalid_argument(n.fit_orders + ": " + std::to_string(order) + " (1 to " +
                                        std::to_string(fit::kMaxClosedFormOrder) + ")");
    // Both reference specs in full before any work (a bad fit spec must not wait for the evaluation set).
    evaluation_ = checked_definition(spec_.reference, spec_.backend_label, spec_.check_sampling, spec_.build);
    if (has_fit) {
        fit_ = checked_definition(spec_.fit_reference, spec_.backend_label, spec_.check_sampling, spec_.build);
        if (fit_->options.ao_weighting != evaluation_.options.ao_weighting)
            throw std::invalid_argument(n.fit_reference + ": its AO weighting differs from " + n.reference + "'s");
    }
    // Every candidate that needs no reference, built now: a bad file stops before any work.
    if (spec_.analytic) candidates_ = analytic_candidates(evaluation_.options.ao_weighting);
    for (const auto& l : spec_.luts) {
        const auto [name, file] = named_file(n.lut, l);
        candidates_.push_back(lut_candidate(name, file));
    }
    for (const auto& r : spec_.reprs) {
        const auto [name, file] = named_file(n.repr, r);
        candidates_.push_back(representation_candidate(name, file, n.repr));
    }
    for (const auto& f : spec_.closed_forms) candidates_.push_back(closed_form_candidate(fit::read_closed_form(f), f));
    if (candidates_.empty() && !has_fit)
        throw std::invalid_argument("no candidates (part 1's terms left out, and no LUT, representation, closed form or fit reference)");
    check_unique_names();
    // The fits' names are known in advance: they must not collide either, and may be chosen.
    std::vector<std::string> known;
    for (const auto& c : candidates_) known.push_back(c.name);
    if (has_fit)
        for (unsigned order : spec_.fit_orders) {
            if (std::find(known.begin(), known.end(), fit_name(order)) != known.end())
                throw std::invalid_argument("two candidates named '" + fit_name(order) + "' (a closed form file and " +
                                            n.fit_orders + " " + std::to_string(order) + ")");
            known.push_back(fit_name(order));
        }
    if (!spec_.choose.empty() && std::find(known.begin(), known.end(), spec_.choose) == known.end()) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        throw std::invalid_argument(n.said(n.choose, spec_.choose) + ": no such candidate (candidates: " + list + ")");
    }
}

void Study::check_unique_names() const {
    std::set<std::string> names;
    for (const auto& c : candidates_)
        if (!names.insert(c.name).second)
            throw std::invalid_argument("two candidates named '" + c.name + "'; name LUTs with " + spec_.names.lut + " NAME=FILE");
}

void Study::add_fits(const ReferenceSet& training) {
    for (unsigned order : spec_.fit_orders) {
        throw_if_cancelled();
        fit::ClosedForm form = fit_closed_form(training, order);
        form.provenance["command_line"] = spec_.command_line;
        fits_.push_back(form.provenance);
        candidates_.push_back(closed_form_candidate(form, ""));
    }
    check_unique_names();
}

StudyResult Study::judge(const ReferenceSet& set, const std::function<void(const std::string&)>& warn,
                         const std::function<void(std::size_t, std::size_t)>& progress) const {
    StudyResult r;
    // Reference points outside each candidate's domain: counted, reported, refused with strict_domain.
    for (const auto& c : candidates_) {
        r.outside.push_back(count_outside_domain(c, set));
        const DomainCount& out = r.outside.back();
        if (spec_.strict_domain && c.domain)
            compare::refuse_outside_domain(spec_.reference, c.name, *c.domain, out.tally, out.first_outside);
        if (out.tally.outside > 0 && warn)
            warn(c.name + ": " + std::to_string(out.tally.outside) + " of " + std::to_string(out.tally.lookups) +
                 " reference points outside its domain (" + c.domain->describe() + "), e.g. " + out.first_outside);
    }
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
        throw_if_cancelled();
        r.metrics.push_back(evaluate_candidate(candidates_[i], set));
        if (progress) progress(i + 1, candidates_.size());
    }
    r.front = pareto_front(candidates_, r.metrics);
    if (!spec_.choose.empty()) {
        r.chosen = candidates_.size();
        for (std::size_t i = 0; i < candidates_.size(); ++i)
            if (candidates_[i].name == spec_.choose) r.chosen = i;
        if (r.chosen == candidates_.size())
            throw std::invalid_argument(spec_.names.said(spec_.names.choose, spec_.choose) + ": no such candidate");
        if (!spec_.budget.fits(candidates_[r.chosen].cost))
            throw std::invalid_argument(spec_.names.said(spec_.names.choose, spec_.choose) + ": over the budget (" +
                                        cost_text(candidates_[r.chosen].cost) + ")");
    } else {
        r.chosen = choose(candidates_, r.metrics, spec_.budget);
    }
    r.order.resize(candidates_.size());
    for (std::size_t i = 0; i < r.order.size(); ++i) r.order[i] = i;
    std::stable_sort(r.order.begin(), r.order.end(),
                     [&](auto a, auto b) { return r.metrics[a].weighted_rms < r.metrics[b].weighted_rms; });
    for (const auto& c : candidates_) r.by_roughness.push_back(evaluate_candidate_by_roughness(c, set, r.roughness_edges));
    return r;
}

std::string Study::pareto_markdown(const StudyResult& r) const {
    // Sorted by weighted RMS error; "*" marks the Pareto front, ">" the chosen candidate.
    const std::set<std::size_t> on_front(r.front.begin(), r.front.end());
    std::ostringstream md;
    md << "| | candidate | kind | storage | bytes | fetches | ALU | N.L-weighted RMS | p99 | max | outside domain |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (std::size_t i : r.order) {
        const auto& c = candidates_[i];
        const auto& m = r.metrics[i];
        md << "| " << (i == r.chosen ? ">" : "") << (on_front.count(i) ? "*" : "") << " | " << md_cell(c.name) << " | "
           << md_cell(c.kind) << " | " << md_cell(c.cost.storage) << " | " << bytes_text(c.cost.bytes) << " | "
           << c.cost.fetches_per_light << " | " << c.cost.alu_per_light << " | " << fixed(m.weighted_rms) << " | "
           << fixed(m.weighted_p99) << " | " << fixed(m.max_abs) << " | "
           << (c.domain ? std::to_string(r.outside[i].tally.outside) : std::string("-")) << " |\n";
    }
    return md.str();
}

std::string Study::pareto_csv(const StudyResult& r) const {
    const std::set<std::size_t> on_front(r.front.begin(), r.front.end());
    std::ostringstream csv;
    csv << "name,kind,storage,bytes,fetches_per_light,alu_per_light,weighted_rms,weighted_p99,max_abs,pareto,chosen,within_budget,"
           "outside_domain\n";
    for (std::size_t i : r.order) {
        const auto& c = candidates_[i];
        const auto& m = r.metrics[i];
        csv << csv_field(c.name) << "," << csv_field(c.kind) << "," << csv_quoted(c.cost.storage) << "," << c.cost.bytes << ","
            << c.cost.fetches_per_light << "," << c.cost.alu_per_light << "," << format_number(m.weighted_rms) << ","
            << format_number(m.weighted_p99) << "," << format_number(m.max_abs) << "," << (on_front.count(i) ? 1 : 0) << ","
            << (i == r.chosen ? 1 : 0) << "," << (spec_.budget.fits(c.cost) ? 1 : 0) << "," << r.outside[i].tally.outside << "\n";
    }
    return csv.str();
}

std::string Study::roughness_bands_markdown(const StudyResult& r) const {
    // Where the errors live: N.L-weighted RMS and max per roughness band.
    const std::vector<double>& edges = r.roughness_edges;
    std::ostringstream bands;
    bands << "| candidate |";
    for (std::size_t k = 0; k + 1 < edges.size(); ++k) bands << " roughness " << edges[k] << "-" << edges[k + 1] << " |";
    bands << "\n|---|";
    for (std::size_t k = 0; k + 1 < edges.size(); ++k) bands << "---|";
    bands << "\n";
    for (std::size_t i : r.order) {
        bands << "| " << md_cell(candidates_[i].name) << " |";
        for (const auto& m : r.by_roughness[i])
            bands << " " << (m.points ? fixed(m.weighted_rms, 3) + " (max " + fixed(m.max_abs, 2) + ")" : std::string("-")) << " |";
        bands << "\n";
    }
    return bands.str();
}

std::string Study::reference_summary(const ReferenceSet& set) {
    return "reference '" + set.definition.name + "': " + std::to_string(set.points.size()) + " points, term std error max " +
           fixed(set.max_std_error, 3) + ", RMS " + fixed(set.rms_std_error, 3);
}

nlohmann::json Study::metadata(const StudyResult& r, const ReferenceSet& set) const {
    nlohmann::json candidates_json = nlohmann::json::array();
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
        nlohmann::json j = candidates_[i].provenance;
        j["bytes"] = candidates_[i].cost.bytes;
        j["fetches_per_light"] = candidates_[i].cost.fetches_per_light;
        j["alu_per_light"] = candidates_[i].cost.alu_per_light;
        j["storage"] = candidates_[i].cost.storage;
        j["weighted_rms"] = r.metrics[i].weighted_rms;
        j["weighted_p99"] = r.metrics[i].weighted_p99;
        j["max_abs"] = r.metrics[i].max_abs;
        j["points"] = r.metrics[i].points;
        j.update(compare::domain_report(candidates_[i].domain, r.outside[i].tally));
        // Where the largest errors are (the reference point and the error there).
        nlohmann::json worst = nlohmann::json::array();
        for (const auto& [index, error] : worst_points(candidates_[i], set, 5)) {
            const auto& p = set.points[index];
            worst.push_back({{"visibility", p.visibility}, {"n_dot_l", p.n_dot_l}, {"n_dot_v", p.n_dot_v},
                             {"roughness", p.roughness}, {"relative_azimuth_deg", p.relative_azimuth * 180 / 3.14159265358979323846},
                             {"term", set.values[index].term}, {"error", error}});
        }
        j["worst_points"] = worst;
        candidates_json.push_back(j);
    }
    nlohmann::json meta = {{"program", "microshadow " MICROSHADOW_VERSION},
                           {"command_line", spec_.command_line},
                           {"reference", {{"spec", json_safe(spec_.reference)}, {"hash", set.definition.hash()},
                                          {"file", json_safe(set.file)}, {"definition", set.definition.canonical_text()},
                                          {"max_std_error", set.max_std_error}, {"rms_std_error", set.rms_std_error}}},
                           {"error", "comparator - term, weighted by weight x NdotL"},
                           {"budget", {{"max_bytes", spec_.budget.max_bytes}, {"max_fetches", spec_.budget.max_fetches},
                                       {"max_alu", spec_.budget.max_alu}}},
                           {"candidates", candidates_json},
                           {"chosen", candidates_[r.chosen].name}};
    if (fit_) meta["fits"] = fits_;
    nlohmann::json by_roughness = nlohmann::json::object();
    for (std::size_t i : r.order) {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& m : r.by_roughness[i])
            list.push_back({{"points", m.points}, {"weighted_rms", m.weighted_rms}, {"weighted_p99", m.weighted_p99}, {"max_abs", m.max_abs}});
        by_roughness[candidates_[i].name] = list;
    }
    meta["by_roughness"] = {{"edges", r.roughness_edges}, {"candidates", by_roughness}};
    return meta;
}

Study::Files Study::add_outputs(OutputSet& outputs, const std::string& dir) {
    Files f;
    f.csv = outputs.add((fs::path(dir) / "pareto.csv").string());
    f.markdown = outputs.add((fs::path(dir) / "pareto.md").string());
    f.json = outputs.add((fs::path(dir) / "design.json").string());
    return f;
}

std::string Study::write(OutputSet& outputs, const Files& files, const std::string& dir, const StudyResult& r,
                         const ReferenceSet& set) const {
    outputs.stream(files.csv) << pareto_csv(r);
    outputs.stream(files.markdown) << pareto_markdown(r) << "\n" << reference_summary(set)
                                   << ". `*` Pareto front over (N.L-weighted RMS, bytes, fetches, ALU); `>` chosen.\n\n"
                                   << "N.L-weighted RMS (max |error|) per roughness band:\n\n"
                                   << roughness_bands_markdown(r);
    nlohmann::json meta = metadata(r, set);
    const Candidate& chosen = candidates_[r.chosen];
    std::string prefix;
    if (chosen.bake) {
        prefix = (fs::path(dir) / ("chosen-" + chosen.name)).string();
        chosen.bake(outputs, prefix);
        meta["baked"] = prefix;
    } else {
        meta["baked"] = "nothing to bake: " + chosen.name + " is part 1's formula (docs/study.md)";
    }
    outputs.stream(files.json) << dump_json(meta, 2) << "\n";
    return prefix;
}

}  // namespace ms::design
