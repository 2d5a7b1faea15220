#include "jobs/sweep/runner.hpp"

#include "approx/analytic.hpp"

#include "core/digest.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>

#include "analytic/part1_terms.hpp"
#include "core/cancel.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "integrands/term/term_integrand.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/input_file.hpp"
#include "io/text.hpp"
#include "jobs/cache_keys.hpp"
#include "jobs/compare.hpp"
#include "lut/lookup.hpp"
#include "jobs/sweep/points.hpp"
#include "schedule/chunk_store.hpp"

namespace ms::sweep {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Format 2 records each finished chunk's row count and FNV-1a digest ("digests"); format 1 manifests
// are still read, and their chunks checked by structure only.
constexpr const char* kManifestFormat = "microshadow-sweep-manifest/2";

// Manifests and LUT files read whole, with the input checks of io/input_file.hpp (regular files, a size limit).
std::string read_all(const std::string& path) { return read_input_file(path, std::uint64_t(1) << 31, "file"); }

// A sweep's chunks in the chunk store (schedule/chunk_store.hpp): chunks/chunk-XXXXXXXXXX.csv, the bare
// rows, their digests recorded in the manifest; damaged ones go to chunks/rejected/.
schedule::ChunkLayout chunk_layout(const std::string& dir) {
    schedule::ChunkLayout layout;
    layout.folder = (fs::path(dir) / "chunks").string();
    layout.prefix = "chunk-";
    layout.suffix = ".csv";
    layout.seal = schedule::ItemSeal::recorded;
    return layout;
}

// The manifest's record of a chunk: {rows, fnv1a64}.
json digest_json(const schedule::ItemDigest& d) { return {{"rows", d.rows}, {"fnv1a64", hex16(d.fnv1a)}}; }

// Checks a chunk's rows: exactly the rows of points [first, last), each with `fields` fields and its
// point index first. Returns "" when they are, else the reason (a short tag first: "rows", "index",
// "fields").
// A stored row's numbers, checked like any input (anyone can recompute a chunk's digest): the query's
// parameters finite, the term a fraction in [0, 1], its standard error finite and >= 0. The columns are
// csv_header's: point, form, ao_weighting, then the numbers from roughness to visibility, term, std_error.
std::string check_row_values(const std::string& line) {
    constexpr std::size_t kFirstNumber = 3, kTerm = 12, kStdError = 13;
    std::size_t begin = 0;
    for (std::size_t field = 0; field <= kStdError; ++field) {
        const std::size_t end = line.find(',', begin);
        if (end == std::string::npos && field < kStdError) return "";  // fewer fields: the field count check says so
        if (field >= kFirstNumber) {
            const std::string text = line.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
            char* stop = nullptr;
            const double v = std::strtod(text.c_str(), &stop);
            if (text.empty() || *stop != '\0' || !std::isfinite(v)) return "field " + std::to_string(field + 1) + " '" + text + "' is not a finite number";
            if (field == kTerm && !(v >= 0 && v <= 1)) return "term " + text + " is not a fraction in [0, 1]";
            if (field == kStdError && !(v >= 0 && v <= 1)) return "std_error " + text + " is not in [0, 1]";
        }
        if (end == std::string::npos) break;
        begin = end + 1;
    }
    return "";
}

std::string check_chunk_text(const std::string& text, std::uint64_t first, std::uint64_t last, std::size_t fields) {
    std::uint64_t expect = first;
    std::size_t line_start = 0;
    while (line_start < text.size()) {
        const std::size_t end = text.find('\n', line_start);
        if (end == std::string::npos) return "rows: the last row is cut off (no line end)";
        const std::string line = text.substr(line_start, end - line_start);
        line_start = end + 1;
        if (expect >= last) return "rows: more rows than the chunk's " + std::to_string(last - first);
        const std::size_t n = std::size_t(std::count(line.begin(), line.end(), ',')) + 1;
        if (n != fields)
            return "fields: row of point " + std::to_string(expect) + " has " + std::to_string(n) + " fields, not " +
                   std::to_string(fields);
        if (line.compare(0, line.find(','), std::to_string(expect)) != 0)
            return "index: expected point " + std::to_string(expect) + ", found '" + line.substr(0, line.find(',')) + "'";
        if (const std::string problem = check_row_values(line); !problem.empty())
            return "values: row of point " + std::to_string(expect) + ": " + problem;
        ++expect;
    }
    if (expect != last) return "rows: " + std::to_string(expect - first) + " rows, not " + std::to_string(last - first);
    return "";
}

// Chunk c of `files` checked against its recorded digest (when the manifest has one: format-1 manifests
// do not) and its rows. Returns "" when sound; else the warning: the chunk "missing" (listed as
// finished, but gone), or damaged and set aside (the path, the reason and where it went).
std::string check_chunk(const schedule::ChunkFiles& files, std::uint64_t c, std::uint64_t first, std::uint64_t last,
                        std::size_t fields, const json* recorded) {
    std::error_code ec;
    if (!fs::exists(files.path(c), ec)) return "missing: the file is gone";
    std::string warning;
    const auto rows = files.read(c, &warning, [&](const std::string& text) -> std::string {
        if (recorded) {
            const json d = digest_json(schedule::digest_of(text));
            if (d != *recorded)
                return "digest: its " + std::to_string(d["rows"].get<std::uint64_t>()) + " rows and digest " +
                       d["fnv1a64"].get<std::string>() + " are not the " +
                       std::to_string((*recorded)["rows"].get<std::uint64_t>()) + " rows and digest " +
                       (*recorded)["fnv1a64"].get<std::string>() + " recorded when it was written";
        }
        return check_chunk_text(text, first, last, fields);
    });
    return rows ? std::string() : warning;
}

std::string manifest_name(const Shard& s) {
    if (s.count == 1) return "manifest.json";
    return "manifest.shard-" + std::to_string(s.index) + "-of-" + std::to_string(s.count) + ".json";
}

// Reads a manifest and checks its shape (what every reader below relies on), so a damaged or crafted
// manifest is refused naming the file, never with a bare JSON type error.
json read_json(const std::string& path) {
    json m;
    try {
        m = json::parse(read_all(path));
    } catch (const json::exception& e) {
        throw std::runtime_error(path + ": not a valid manifest (" + e.what() + "); remove it or use --restart");
    }
    auto bad = [&](const std::string& what) {
        return std::runtime_error(path + ": not a valid manifest (" + what + "); remove it or use --restart");
    };
    if (!m.is_object()) throw bad("not a JSON object");
    if (!m.contains("spec_hash") || !m["spec_hash"].is_string()) throw bad("no spec_hash string");
    if (m.contains("complete") && !m["complete"].is_boolean()) throw bad("complete is not true or false");
    if (!m.contains("finished") || !m["finished"].is_array()) throw bad("no finished list");
    for (const auto& c : m["finished"])
        if (!c.is_number_unsigned()) throw bad("finished holds " + c.dump() + ", not a chunk number");
    if (m.contains("digests")) {
        if (!m["digests"].is_object()) throw bad("digests is not an object");
        for (const auto& [key, d] : m["digests"].items())
            if (!d.is_object() || !d.contains("rows") || !d["rows"].is_number_unsigned() || !d.contains("fnv1a64") ||
                !d["fnv1a64"].is_string())
                throw bad("digest of chunk " + key + " is not {rows, fnv1a64}");
    }
    if (m.contains("shard")) {
        const json& sh = m["shard"];
        if (!sh.is_object() || !sh.contains("index") || !sh["index"].is_number_unsigned() || !sh.contains("count") ||
            !sh["count"].is_number_unsigned() || sh["count"].get<std::uint64_t>() == 0 ||
            sh["index"].get<std::uint64_t>() >= sh["count"].get<std::uint64_t>() || sh["count"].get<std::uint64_t>() > 1000000)
            throw bad("shard is not {index, count} with index < count");
    }
    for (const char* key : {"header", "format"})
        if (m.contains(key) && !m[key].is_string()) throw bad(std::string(key) + " is not a string");
    for (const char* key : {"chunks", "points", "chunk_size"})
        if (m.contains(key) && !m[key].is_number_unsigned()) throw bad(std::string(key) + " is not a count");
    return m;
}

void write_json(const std::string& path, const json& j) {
    AtomicFile f(path);
    f.stream() << dump_json(j, 1) << "\n";  // paths may hold bytes that are not UTF-8
    f.commit();
}

// The [[comparators.lut]] files opened: a part 2 LUT or a representation (host/repr/):
// compare::Comparator tells them apart by the file's metadata.
// A file that cannot be used (missing, truncated, not a LUT) is bad input naming the comparator.
std::vector<compare::Comparator> open_comparator_files(const Spec& spec) {
    std::vector<compare::Comparator> files;
    for (std::size_t i = 0; i < spec.luts.size(); ++i) {
        const auto& l = spec.luts[i];
        try {
            files.push_back(l.preset.empty() ? compare::Comparator::open_file(l.name, l.file)
                                             : compare::Comparator::open_named(l.name, l.preset));
        } catch (const std::exception& e) {
            const std::string what = e.what();
            // The readers name the file themselves; say it once.
            throw std::invalid_argument(spec.source + ": comparators.lut[" + std::to_string(i) + "] '" + l.name + "': " +
                                        (what.find(l.file) == std::string::npos ? l.file + ": " : std::string()) + what);
        }
    }
    return files;
}

// What decided the values: the exact method's tolerance and rule, or the sampled method's point set.
json sampling_provenance(const SamplingPlan& plan) {
    if (plan.method == Method::exact) return exact_provenance(plan);
    return {{"method", "sampled"},
            {"samples", plan.samples},
            {"replicates", plan.replicates},
            {"seed", plan.seed},
            {"sequence", to_string(plan.sequence)}};
}

class ChunkComputer {
public:
    ChunkComputer(const Spec& spec, const RunConfig& config)
        : spec_(spec), grid_(spec, config.defaults.form, config.defaults.ao_weighting), files_(open_comparator_files(spec)) {}
    // Each file comparator's provenance (kind, file, version, command line; a representation's cost).
    json file_provenance() const {
        json out = json::array();
        for (std::size_t k = 0; k < files_.size(); ++k) {
            const auto& c = files_[k];
            json j = c.provenance();
            // Counted over the whole sweep (every shard the same): what its columns stand on.
            j.update(compare::domain_report(c.domain(), tallies_[k]));
            const approx::Cost cost = c.cost();
            j["cost"] = {{"bytes", cost.bytes},
                         {"fetches_per_light", cost.fetches_per_light},
                         {"alu_per_light", cost.alu_per_light},
                         {"storage", cost.storage}};
            out.push_back(j);
        }
        return out;
    }
    const PointGrid& grid() const { return grid_; }

    // Each file comparator's lookups outside its domain over the whole sweep, counted once up front so
    // --strict-domain refuses before anything is written.
    void count_domains() {
        tallies_.assign(files_.size(), DomainTally{});
        first_outside_.assign(files_.size(), std::string());
        if (files_.empty()) return;
        std::vector<std::optional<LookupDomain>> domains;
        for (const auto& c : files_) domains.push_back(c.domain());
        for (std::uint64_t i = 0; i < grid_.size(); ++i) {
            const Point p = grid_.at(i);
            const approx::Inputs in = inputs(p);
            for (std::size_t k = 0; k < files_.size(); ++k) {
                if (!domains[k]) continue;
                const bool inside = domains[k]->contains(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
                tallies_[k].add(inside);
                if (!inside && first_outside_[k].empty())
                    first_outside_[k] = "point " + std::to_string(p.index) + ": " +
                                        domains[k]->first_outside(in.visibility, in.n_dot_l, in.n_dot_v, in.roughness, in.alpha_x, in.alpha_y);
            }
        }
    }
    void refuse_outside_domain(const std::string& where) const {
        for (std::size_t k = 0; k < files_.size(); ++k)
            if (const auto d = files_[k].domain()) compare::refuse_outside_domain(where, files_[k].name(), *d, tallies_[k], first_outside_[k]);
    }
    // "NAME: M of N points outside its domain (...)" per comparator with any, for warnings.
    std::vector<std::string> outside_domain_lines() const {
        std::vector<std::string> out;
        for (std::size_t k = 0; k < files_.size(); ++k)
            if (tallies_[k].outside > 0)
                out.push_back(files_[k].name() + ": " + std::to_string(tallies_[k].outside) + " of " + std::to_string(tallies_[k].lookups) +
                              " points outside its domain (" + files_[k].domain()->describe() + "), e.g. " + first_outside_[k]);
        return out;
    }

    // A point's comparator inputs, as eval --compare computes them from a query.
    approx::Inputs inputs(const Point& p) const {
        approx::Inputs in{p.visibility, p.n_dot_l, p.n_dot_v, p.roughness, p.weighting};
        // delta_phi in degrees, folded to [0, 180] (the term is even and 360-periodic in it).
        const double folded = std::fabs(std::remainder(p.delta_phi, 360.0));
        in.relative_azimuth = folded * (3.14159265358979323846 / 180.0);
        // A direction along the normal has no azimuth: 0, as eval --compare reads it from the query's
        // directions (approx::inputs_of), so a representation column equals eval's at such points.
        if (p.n_dot_v >= 1 || p.n_dot_l >= 1) in.relative_azimuth = 0;
        // The surface and the tangent-relative azimuths, as the point's query has them (to_query): what
        // a representation of the anisotropic term reads.
        in.alpha_x = p.alpha_x;
        in.alpha_y = p.alpha_y;
        in.view_azimuth = p.n_dot_v >= 1 ? 0.0 : p.phi_i * (3.14159265358979323846 / 180.0);
        in.light_azimuth = p.n_dot_l >= 1 ? 0.0 : p.phi_o * (3.14159265358979323846 / 180.0);
        return in;
    }

    // The term's queries of points [first, last), each with its own form and AO weighting.
    term::Batch queries(std::uint64_t first, std::uint64_t last) const {
        term::Batch batch;
        for (std::uint64_t i = first; i < last; ++i) {
            const Point p = grid_.at(i);
            batch.queries.push_back(to_query(p));
            batch.options.push_back(TermOptions{p.form, p.weighting});
        }
        return batch;
    }

    // The rows of points [first, last) with their estimates, in the fixed text format.
    std::string rows(std::uint64_t first, std::uint64_t last, const std::vector<Estimate>& est) const {
        std::vector<Point> points;
        points.reserve(last - first);
        for (std::uint64_t i = first; i < last; ++i) points.push_back(grid_.at(i));
        std::string out;
        for (std::size_t k = 0; k < points.size(); ++k) {
            const Point& p = points[k];
            std::string line = std::to_string(p.index) + "," + to_string(p.form) + "," + to_string(p.weighting);
            for (double v : {p.roughness, p.alpha_x, p.alpha_y, p.n_dot_v, p.phi_i, p.phi_o, p.delta_phi, p.n_dot_l,
                             p.visibility, est[k].term, est[k].std_error})
                line += "," + format_number(v);
            // The comparators as eval --compare computes them (jobs/compare.hpp): Activision's adjusted
            // term reads its own roughness of the point's isotropic-equivalent alpha (see points.hpp).
            const approx::Inputs in = inputs(p);
            for (auto t : spec_.analytic) line += "," + format_number(approx::analytic_value(t, in));
            for (const auto& c : files_) line += "," + format_number(c(in));
            out += line + "\n";
        }
        return out;
    }

private:
    const Spec& spec_;
    PointGrid grid_;
    std::vector<compare::Comparator> files_;  // spec.luts, in order
    std::vector<DomainTally> tallies_;        // per file: lookups outside its domain (count_domains)
    std::vector<std::string> first_outside_;
};

// The summary's paragraph on lookups outside each comparator file's domain (from the provenance's
// comparator_files), or "" when the sweep has no file comparators.
std::string domain_markdown(const json& provenance) {
    if (!provenance.contains("comparator_files") || provenance["comparator_files"].empty()) return "";
    std::string o = "\nLookups outside each comparator file's domain (its metadata's roughness, visibility and NdotV "
                    "ranges; answered there by clamping, so its errors above include them):\n\n"
                    "| comparator | domain | points outside | points |\n|---|---|---|---|\n";
    for (const auto& f : provenance["comparator_files"]) {
        std::string domain = "none";
        if (f.contains("domain") && f["domain"].is_object()) domain = LookupDomain::from_json(f["domain"], "sweep.json").describe();
        o += "| " + f.value("name", std::string()) + " | " + domain + " | " + std::to_string(f.value("outside_domain", 0)) + " | " +
             std::to_string(f.value("lookups", 0)) + " |\n";
    }
    return o;
}

// Writes sweep.csv from the chunk files (in chunk order), then the summary and provenance.
// Every chunk is checked first (`check` returns "" or the problem, already set aside and named), so a
// damaged chunk never reaches sweep.csv: the error names the chunk, and sweep.csv is not written.
void assemble(const std::string& out_dir, const std::string& header, std::uint64_t chunks,
              const std::function<std::string(std::uint64_t)>& chunk_file,
              const std::function<std::string(std::uint64_t)>& check, json provenance) {
    // A damaged chunk is bad input (exit status 2), as a damaged item of any other store is.
    for (std::uint64_t c = 0; c < chunks; ++c)
        if (const std::string problem = check(c); !problem.empty()) throw std::invalid_argument(problem);
    // The four outputs appear together or not at all (one OutputSet): sweep.csv is written to its
    // temporary, summarised from there, and renamed with the summaries and the provenance.
    OutputSet outputs;
    const std::size_t csv = outputs.add((fs::path(out_dir) / "sweep.csv").string(), true);
    const std::size_t md = outputs.add((fs::path(out_dir) / "summary.md").string());
    const std::size_t sc = outputs.add((fs::path(out_dir) / "summary.csv").string());
    const std::size_t js = outputs.add((fs::path(out_dir) / "sweep.json").string());
    std::ostream& out = outputs.stream(csv);
    out << header << "\n";
    for (std::uint64_t c = 0; c < chunks; ++c) {
        std::ifstream in(chunk_file(c), std::ios::binary);
        if (!in) throw std::runtime_error(chunk_file(c) + ": missing chunk file");
        out << in.rdbuf();
    }
    out.flush();
    if (!out) throw std::runtime_error((fs::path(out_dir) / "sweep.csv").string() + ": could not be written");
    // The temporary is read back in its own scope: Windows cannot rename a file that is still open, so
    // the reader must be closed before commit() renames it to sweep.csv.
    const Summary s = [&] {
        std::ifstream in(outputs.temp_path(csv), std::ios::binary);
        return summarise(in, (fs::path(out_dir) / "sweep.csv").string());
    }();
    outputs.stream(md) << summary_markdown(s) << domain_markdown(provenance);
    outputs.stream(sc) << summary_csv(s);
    provenance["max_std_error"] = s.max_std_error;
    outputs.stream(js) << dump_json(provenance, 1) << "\n";
    outputs.commit();
}

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> f;
    std::size_t a = 0;
    while (true) {
        const std::size_t b = line.find(',', a);
        f.push_back(line.substr(a, b == std::string::npos ? std::string::npos : b - a));
        if (b == std::string::npos) return f;
        a = b + 1;
    }
}

}  // namespace

void check_comparator_files(const Spec& spec) { open_comparator_files(spec); }

Shard parse_shard(const std::string& text) { return schedule::parse_shard(text, "--shard"); }

std::string csv_header(const Spec& spec) {
    std::string h = "point,form,ao_weighting,roughness,alpha_x,alpha_y,n_dot_v,phi_i,phi_o,delta_phi,n_dot_l,visibility,term,std_error";
    for (const auto& n : comparator_names(spec)) h += "," + n;
    return h;
}

RunResult run_sweep(const Spec& spec, const RunConfig& config) {
    if (!config.backend) throw std::invalid_argument("run_sweep: no backend");
    if (config.shard.count == 0 || config.shard.index >= config.shard.count) throw std::invalid_argument("bad shard");
    if (config.transport && config.shard.count != 1) throw std::invalid_argument("--mpi shares the chunks among the ranks: it takes no --shard");
    ChunkComputer computer(spec, config);
    computer.count_domains();
    if (config.strict_domain) computer.refuse_outside_domain(spec.source);
    RunResult result;
    result.warnings_outside_domain = computer.outside_domain_lines();
    result.points = computer.grid().size();
    result.chunks = (result.points + spec.chunk_size - 1) / spec.chunk_size;
    // Chunks are the term integrand's work items (one per chunk either way: the exact integrand has the
    // sampled one's source/sink contract); `sink` receives each computed chunk's estimates.
    const std::uint64_t chunk_size = spec.chunk_size;
    auto chunk_end = [&](std::uint64_t c) { return std::min(result.points, (c + 1) * chunk_size); };
    auto chunk_queries = [&](std::uint64_t c) { return computer.queries(c * chunk_size, chunk_end(c)); };
    auto make_integrand = [&](std::function<void(std::uint64_t, std::vector<Estimate>&&)> sink) -> std::unique_ptr<schedule::Integrand> {
        if (config.plan.method == Method::exact) {
            exact_term::ExactConfig exact;
            exact.tolerance = config.plan.tolerance > 0 ? config.plan.tolerance : exact::kDefaultTolerance;
            exact.build = config.backend->config().build;
            exact.force_float = config.plan.single_precision;
            exact.kernel_on_cpu_devices = config.plan.kernel_on_cpu_devices;
            return std::make_unique<exact_term::ExactTermIntegrand>(result.chunks, chunk_queries, std::move(sink), exact);
        }
        return std::make_unique<term::TermIntegrand>(result.chunks, chunk_queries, std::move(sink), config.plan,
                                                     config.backend->config());
    };
    if (config.transport && !config.transport->coordinator()) {
        // A computing rank: chunks come from rank 0, their rows (the chunk file's text) go back to it.
        std::mutex rows_mutex;
        std::map<std::uint64_t, std::string> rows;  // computed, until on_done sends them
        auto integrand = make_integrand([&](std::uint64_t c, std::vector<Estimate>&& est) {
            std::string text = computer.rows(c * chunk_size, chunk_end(c), est);
            std::lock_guard<std::mutex> lock(rows_mutex);
            rows[c] = std::move(text);
        });
        schedule::WorkSelection selection;
        selection.next_item = [&](std::uint64_t& c) { return config.transport->next_item(c); };
        schedule::RunCallbacks callbacks;
        callbacks.on_done = [&](std::uint64_t c) {
            std::string text;
            {
                std::lock_guard<std::mutex> lock(rows_mutex);
                text = std::move(rows.at(c));
                rows.erase(c);
            }
            config.transport->send_result(c, text);
            ++result.computed;
        };
        try {
            config.backend->scheduler().run(*integrand, selection, callbacks);
        } catch (const Cancelled&) {
            config.transport->finish("cancelled");
            throw;
        } catch (const std::exception& e) {
            config.transport->finish(e.what());
            throw;
        }
        config.transport->finish("");
        return result;
    }
    result.shard_chunks = result.chunks > config.shard.index
                              ? (result.chunks - config.shard.index + config.shard.count - 1) / config.shard.count
                              : 0;
    result.spec_hash = sweep_cache_key(spec, config).hash();

    const fs::path dir(config.out_dir);
    fs::create_directories(dir / "chunks");
    const std::string manifest_path = (dir / manifest_name(config.shard)).string();

    // Every manifest in the directory must describe this sweep: chunk files are shared by name.
    std::set<std::uint64_t> finished;
    json digests = json::object();  // chunk id (text) -> {rows, fnv1a64}, recorded as chunks are written
    bool complete_before = false;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("manifest", 0) != 0 || entry.path().extension() != ".json") continue;
        const json m = read_json(entry.path().string());
        if (m.value("spec_hash", "") != result.spec_hash) {
            if (!config.restart)
                throw std::invalid_argument(entry.path().string() +
                                            ": this directory holds a different sweep (spec, method, sampling, backend or comparator "
                                            "files changed); use another --out, or --restart to discard it");
            continue;
        }
        if (entry.path().string() == manifest_path) {
            complete_before = m.value("complete", false);
            for (std::uint64_t c : m.at("finished")) finished.insert(c);
            if (m.contains("digests") && m["digests"].is_object()) digests = m["digests"];
        }
    }
    if (config.restart) {
        // Everything the old sweep wrote goes: a new spec's manifest beside the old sweep.csv, summary
        // and provenance would describe two different sweeps in one directory.
        for (const auto& entry : fs::directory_iterator(dir / "chunks"))
            if (entry.is_regular_file()) fs::remove(entry.path());
        for (const auto& entry : fs::directory_iterator(dir)) {
            const std::string name = entry.path().filename().string();
            if (name.rfind("manifest", 0) == 0 || name == "sweep.csv" || name == "sweep.json" || name == "summary.md" ||
                name == "summary.csv")
                fs::remove(entry.path());
        }
        fs::remove_all(dir / "figures");
        finished.clear();
        digests = json::object();
        complete_before = false;
    }

    json manifest = {{"format", kManifestFormat},
                     {"spec_hash", result.spec_hash},
                     {"spec", spec.source},
                     {"name", spec.name},
                     {"canonical_spec", canonical_text(spec)},
                     {"header", csv_header(spec)},
                     {"points", result.points},
                     {"chunk_size", spec.chunk_size},
                     {"chunks", result.chunks},
                     {"shard", {{"index", config.shard.index}, {"count", config.shard.count}}},
                     {"sampling", sampling_provenance(config.plan)},
                     {"backend", config.backend->scheduler().results_label()},
                     {"fast_math", config.backend->config().build.fast_math},
                     {"double_kernels", config.backend->config().build.double_precision},
                     {"command_line", config.command_line},
                     {"comparator_files", computer.file_provenance()},
                     {"complete", false},
                     {"finished", json::array()}};
    auto save_manifest = [&](bool complete) {
        manifest["finished"] = json(std::vector<std::uint64_t>(finished.begin(), finished.end()));
        manifest["digests"] = digests;
        manifest["complete"] = complete;
        write_json(manifest_path, manifest);
    };

    const bool unsharded = config.shard.count == 1;
    const std::string csv_path = (dir / "sweep.csv").string();
    // (Under MPI rank 0 still runs the exchange, with nothing to hand out, so the other ranks stop.)
    if (unsharded && complete_before && fs::exists(csv_path) && !config.transport) {
        result.skipped = result.chunks;
        result.complete = result.assembled = true;
        return result;
    }

    // Chunks are the term integrand's work items: the scheduler deals the unfinished ones of this shard
    // to the places; each worker writes its chunk file (atomically, in the chunk store) as soon as the
    // chunk is computed, and the manifest names it only once it is synced, a group at a time
    // (schedule/chunk_store.hpp), so a kill costs at most recomputing one group of chunks.
    // Every chunk the manifest lists is checked before it is trusted: a damaged one is set aside (kept in
    // chunks/rejected/ as evidence), named in the result's warnings, and computed again.
    schedule::CommitPolicy commit_policy;
    commit_policy.automatic = false;  // synced where the manifest records them (on_done)
    schedule::ChunkFiles files(chunk_layout(config.out_dir), commit_policy);
    const std::string header = csv_header(spec);
    const std::size_t fields = std::size_t(std::count(header.begin(), header.end(), ',')) + 1;
    for (auto it = finished.begin(); it != finished.end();) {
        const std::uint64_t c = *it;
        const std::string key = std::to_string(c);
        const json* recorded = digests.contains(key) ? &digests[key] : nullptr;
        const std::string path = files.path(c);
        const std::string problem = c >= result.chunks ? "" : check_chunk(files, c, c * chunk_size, chunk_end(c), fields, recorded);
        if (problem.empty()) {
            ++it;
            continue;
        }
        result.warnings.push_back(problem.rfind("missing", 0) == 0 ? path + ": listed as finished but " + problem.substr(9) +
                                                                         "; computed again"
                                                                   : problem + "; computed again");
        if (config.warn) config.warn(result.warnings.back());
        digests.erase(key);
        it = finished.erase(it);
    }
    std::uint64_t found = 0;
    for (std::uint64_t c = config.shard.index; c < result.chunks; c += config.shard.count) found += finished.count(c);
    result.skipped = found;
    auto chunk_done = [&](std::uint64_t c) { return finished.count(c) > 0; };
    std::mutex digest_mutex;
    std::map<std::uint64_t, json> fresh;  // digests of chunks written in this run, until on_done records them
    auto store_rows = [&](std::uint64_t c, const std::string& rows) {
        const schedule::ItemDigest d = files.write(c, rows);
        std::lock_guard<std::mutex> lock(digest_mutex);
        fresh[c] = digest_json(d);
    };
    auto write_chunk = [&](std::uint64_t c, std::vector<Estimate>&& est) {
        store_rows(c, computer.rows(c * chunk_size, chunk_end(c), est));
    };
    std::unique_ptr<schedule::Integrand> integrand = make_integrand(write_chunk);
    schedule::WorkSelection selection;
    selection.shard_index = config.shard.index;
    selection.shard_count = config.shard.count;
    selection.already_done = chunk_done;
    selection.max_items = config.max_chunks;
    schedule::RunCallbacks callbacks;
    callbacks.on_done = [&](std::uint64_t c) {
        {
            std::lock_guard<std::mutex> lock(digest_mutex);
            digests[std::to_string(c)] = fresh.at(c);
            fresh.erase(c);
        }
        finished.insert(c);
        // The manifest is rewritten when a group of chunks is synced, not after every chunk: it grows
        // with the chunk count, and rewriting it per chunk made a long sweep quadratic.
        if (files.commit_if_due()) save_manifest(false);
        ++result.computed;
    };
    if (config.progress)
        callbacks.progress = [&](std::uint64_t done, std::uint64_t) { config.progress(found + done, result.shard_chunks); };
    // The manifest of this run from the start (the chunks found sound), so a run stopped before its
    // first group still names what it kept; and on the way out of a stopped run, every chunk finished.
    save_manifest(false);
    try {
        if (config.transport) {
            // Rank 0 of an MPI world: the other ranks compute the unfinished chunks; each one that comes
            // back is written and recorded exactly as a local place's would be.
            std::deque<std::uint64_t> pending;
            for (std::uint64_t c = 0; c < result.chunks; ++c)
                if (!chunk_done(c)) pending.push_back(c);
            config.transport->coordinate(
                std::move(pending),
                [&](std::uint64_t c, const std::string& rows) {
                    if (c >= result.chunks) throw std::runtime_error("chunk " + std::to_string(c) + " is not a chunk of this sweep");
                    // The rows must be the chunk's points in the sweep's fields before they are trusted.
                    const std::string problem = check_chunk_text(rows, c * chunk_size, chunk_end(c), fields);
                    if (!problem.empty()) throw std::runtime_error("chunk " + std::to_string(c) + " as received: " + problem);
                    store_rows(c, rows);
                    callbacks.on_done(c);
                },
                [&](std::uint64_t done, std::uint64_t) {
                    if (config.progress) config.progress(found + done, result.shard_chunks);
                });
        } else {
            config.backend->scheduler().run(*integrand, selection, callbacks);
        }
    } catch (...) {
        try {
            files.commit();
            save_manifest(false);
        } catch (const std::exception&) {
            // The first error is the one to report; the chunks not recorded are computed again.
        }
        throw;
    }
    files.commit();
    std::uint64_t mine = 0;
    for (std::uint64_t c : finished) mine += (c % config.shard.count == config.shard.index && c < result.chunks);
    result.complete = mine == result.shard_chunks;
    if (!result.complete) {
        save_manifest(false);
        return result;
    }
    save_manifest(!unsharded);
    if (unsharded) {
        json prov = manifest;
        prov.erase("finished");
        prov.erase("digests");
        prov["complete"] = true;
        auto check = [&](std::uint64_t c) -> std::string {
            const std::string key = std::to_string(c);
            const std::string problem = check_chunk(files, c, c * chunk_size, chunk_end(c), fields,
                                                    digests.contains(key) ? &digests[key] : nullptr);
            if (problem.empty()) return "";
            // Forget it, so the next run computes it again.
            finished.erase(c);
            digests.erase(key);
            save_manifest(false);
            return (problem.rfind("missing", 0) == 0 ? files.path(c) + ": " + problem : problem) +
                   "; sweep.csv was not written: rerun the same command to compute it again";
        };
        assemble(config.out_dir, csv_header(spec), result.chunks, [&](std::uint64_t c) { return files.path(c); }, check, prov);
        save_manifest(true);
        // The chunk files stay: they are the evidence sweep.csv was assembled from, checked against the
        // digests in the manifest (sweep --restart or removing the directory frees the space).
        result.assembled = true;
    }
    return result;
}

void merge_shards(const std::vector<std::string>& shard_dirs, const std::string& out_dir,
                  const std::string& command_line) {
    struct Found {
        std::string dir;
        json manifest;
    };
    std::map<std::uint32_t, Found> shards;
    std::string hash;
    std::uint32_t count = 0;
    for (const auto& d : shard_dirs) {
        if (!fs::is_directory(d)) throw std::invalid_argument(d + ": not a directory");
        for (const auto& entry : fs::directory_iterator(d)) {
            const std::string name = entry.path().filename().string();
            if (name.rfind("manifest.shard-", 0) != 0 || entry.path().extension() != ".json") continue;
            json m = read_json(entry.path().string());
            const std::string format = m.value("format", "");
            if (format != kManifestFormat && format != "microshadow-sweep-manifest/1")
                throw std::invalid_argument(entry.path().string() + ": not a sweep manifest");
            for (const char* key : {"shard", "chunks", "header", "points", "chunk_size"})
                if (!m.contains(key)) throw std::invalid_argument(entry.path().string() + ": a shard manifest without " + key);
            const std::uint32_t i = m.at("shard").at("index"), n = m.at("shard").at("count");
            if (hash.empty()) {
                hash = m.at("spec_hash");
                count = n;
            }
            if (m.at("spec_hash") != hash)
                throw std::invalid_argument(entry.path().string() + ": shard of a different sweep (spec hash " +
                                            m.at("spec_hash").get<std::string>() + ", the first shard's is " + hash + ")");
            if (n != count)
                throw std::invalid_argument(entry.path().string() + ": the sweep was split into " + std::to_string(n) +
                                            " shards here but into " + std::to_string(count) + " in the first shard found");
            if (!m.value("complete", false))
                throw std::invalid_argument(entry.path().string() + ": shard " + std::to_string(i) + "/" +
                                            std::to_string(n) + " is not finished; rerun it first");
            if (shards.count(i) && fs::equivalent(shards[i].dir, d) == false)
                throw std::invalid_argument("shard " + std::to_string(i) + "/" + std::to_string(n) + " found twice: in " +
                                            shards[i].dir + " and " + d);
            shards[i] = {d, m};
        }
    }
    if (shards.empty()) throw std::invalid_argument("merge: no shard manifests (manifest.shard-I-of-N.json) found");
    for (std::uint32_t i = 0; i < count; ++i)
        if (!shards.count(i))
            throw std::invalid_argument("merge: shard " + std::to_string(i) + "/" + std::to_string(count) + " is missing");
    const json& first = shards.begin()->second.manifest;
    const std::uint64_t chunks = first.at("chunks");
    json prov = first;
    prov.erase("finished");
    prov.erase("shard");
    prov["merged_from"] = shard_dirs;
    prov["command_line"] = command_line;
    prov["complete"] = true;
    prov.erase("digests");
    const std::string header = first.at("header");
    const std::size_t fields = std::size_t(std::count(header.begin(), header.end(), ',')) + 1;
    const std::uint64_t points = first.at("points"), chunk_size = first.at("chunk_size");
    // Each shard's chunks as its own chunk store holds them.
    std::map<std::uint32_t, std::unique_ptr<schedule::ChunkFiles>> files;
    for (const auto& [i, shard] : shards) files[i] = std::make_unique<schedule::ChunkFiles>(chunk_layout(shard.dir));
    auto check = [&](std::uint64_t c) -> std::string {
        const std::uint32_t i = std::uint32_t(c % count);
        const Found& shard = shards.at(i);
        const std::string key = std::to_string(c);
        const json* recorded =
            shard.manifest.contains("digests") && shard.manifest["digests"].contains(key) ? &shard.manifest["digests"][key] : nullptr;
        const std::string path = files.at(i)->path(c);
        const std::string problem = check_chunk(*files.at(i), c, c * chunk_size, std::min(points, (c + 1) * chunk_size), fields, recorded);
        if (problem.empty()) return "";
        return (problem.rfind("missing", 0) == 0 ? path + ": " + problem : problem) + "; rerun shard " +
               std::to_string(c % count) + "/" + std::to_string(count) + " in " + shard.dir +
               " (it computes the chunk again), then merge";
    };
    // A merge refused for a damaged chunk writes nothing: not even the output folder it created.
    std::error_code ec;
    const bool created = !fs::exists(out_dir, ec) && fs::create_directories(out_dir);
    try {
        assemble(out_dir, header, chunks, [&](std::uint64_t c) { return files.at(std::uint32_t(c % count))->path(c); }, check, prov);
    } catch (...) {
        if (created) fs::remove(out_dir, ec);  // only when empty: what assemble wrote is its own to keep or not
        throw;
    }
}

Summary summarise(std::istream& csv, const std::string& name) {
    std::string line;
    if (!std::getline(csv, line)) throw std::runtime_error(name + ": empty sweep CSV");
    const auto header = split(line);
    auto column = [&](const std::string& c) {
        const auto it = std::find(header.begin(), header.end(), c);
        if (it == header.end()) throw std::runtime_error(name + ": no column '" + c + "'");
        return std::size_t(it - header.begin());
    };
    const std::size_t term = column("term"), se = column("std_error"), rough = column("roughness");
    Summary s;
    s.comparators.assign(header.begin() + se + 1, header.end());
    s.errors = GroupedErrorStats(s.comparators.size(), 1);
    std::size_t line_no = 1;
    while (std::getline(csv, line)) {
        ++line_no;
        if (line.empty()) continue;
        const auto f = split(line);
        if (f.size() != header.size())
            throw std::runtime_error(name + ":" + std::to_string(line_no) + ": " + std::to_string(f.size()) +
                                     " fields, the header has " + std::to_string(header.size()));
        const double t = std::stod(f[term]);
        s.max_std_error = std::max(s.max_std_error, std::stod(f[se]));
        const double roughness = std::stod(f[rough]);
        auto group = s.roughness_groups.find(roughness);
        if (group == s.roughness_groups.end()) group = s.roughness_groups.emplace(roughness, s.errors.add_group()).first;
        const std::size_t groups[2] = {0, group->second};
        for (std::size_t k = 0; k < s.comparators.size(); ++k) s.errors.add(k, groups, 2, std::stod(f[se + 1 + k]) - t);
        ++s.points;
    }
    return s;
}

namespace {
std::string fmt(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", v);
    return b;
}
}  // namespace

std::string summary_markdown(const Summary& s) {
    std::ostringstream o;
    o << "Error of each comparator against the generic term (comparator - term), " << s.points
      << " points; max std error of the term " << fmt(s.max_std_error) << ".\n\n"
      << "| comparator | roughness | points | max abs | mean abs | RMS | bias |\n"
      << "|---|---|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < s.comparators.size(); ++k) {
        auto row = [&](const std::string& r, const ErrorStats& e) {
            o << "| " << s.comparators[k] << " | " << r << " | " << e.count() << " | " << fmt(e.max_abs()) << " | "
              << fmt(e.mean_abs()) << " | " << fmt(e.rms()) << " | " << fmt(e.bias()) << " |\n";
        };
        row("all", s.errors.at(k, 0));
        for (const auto& [r, g] : s.roughness_groups) row(fmt(r), s.errors.at(k, g));
    }
    return o.str();
}

std::string summary_csv(const Summary& s) {
    std::ostringstream o;
    o << "comparator,roughness,points,max_abs_error,mean_abs_error,rms_error,bias\n";
    for (std::size_t k = 0; k < s.comparators.size(); ++k) {
        auto row = [&](const std::string& r, const ErrorStats& e) {
            o << s.comparators[k] << "," << r << "," << e.count() << "," << format_number(e.max_abs()) << ","
              << format_number(e.mean_abs()) << "," << format_number(e.rms()) << "," << format_number(e.bias()) << "\n";
        };
        row("all", s.errors.at(k, 0));
        for (const auto& [r, g] : s.roughness_groups) row(format_number(r), s.errors.at(k, g));
    }
    return o.str();
}

schedule::CacheKey sweep_cache_key(const Spec& spec, const RunConfig& config) {
    schedule::CacheKey key("sweep");
    key.add("visibility", spec.visibility)
        .add("n_dot_l", spec.n_dot_l)
        .add("n_dot_v", spec.n_dot_v)
        .add("by_roughness", spec.by_roughness)
        .add("roughness", spec.roughness)
        .add("alpha_x", spec.alpha_x)
        .add("alpha_y", spec.alpha_y)
        .add("phi_i", spec.phi_i)
        .add("relative_azimuth", spec.relative_azimuth)
        .add("phi_o_or_delta", spec.phi_o_or_delta);
    std::vector<std::string> forms, weightings, analytic;
    for (Form f : spec.forms) forms.push_back(to_string(f));
    for (AoWeighting w : spec.weightings) weightings.push_back(to_string(w));
    for (const auto& a : spec.analytic) analytic.push_back(analytic::to_string(a));
    key.add("forms", forms).add("weightings", weightings).add("analytic", analytic);
    // A comparator file by its bytes (a re-baked LUT must not resume old chunks); a preset by its name
    // (its bake is deterministic: the exact method, a fixed grid, and the key holds the version).
    for (std::size_t i = 0; i < spec.luts.size(); ++i) {
        const auto& l = spec.luts[i];
        const std::string name = "luts." + std::to_string(i);
        key.add(name + ".name", l.name);
        if (l.preset.empty()) key.add_file(name + ".file", l.file);
        else key.add(name + ".preset", l.preset);
    }
    // The chunk size decides which points a chunk file holds (the manifests name chunks by number).
    key.add("chunk_size", spec.chunk_size);
    add_sampling_plan(key, config.plan);
    add_term_options(key, config.defaults);
    add_build(key, config.backend->config().build);
    add_results_place(key, config.backend->scheduler());
    return key;
}

const std::vector<std::string>& sweep_cache_key_exclusions() {
    static const std::vector<std::string> excluded = {
        "Spec::name, Spec::source: recorded in the outputs; the file's values are keyed, not its name or path",
        "Spec::max_points: a limit that refuses a sweep before it runs, never changes a point",
        "Spec::samples, seed, replicates, sequence, method, tolerance: defaults the front end resolves into "
        "RunConfig::plan, which is keyed",
        "RunConfig::out_dir, command_line: where the outputs go and their provenance",
        "RunConfig::shard, max_chunks, restart, transport: how the chunks are split and run, not what they hold",
        "RunConfig::strict_domain: refuses a sweep before it writes a chunk, never changes a point",
        "RunConfig::warn, progress: callbacks, told of the work, not part of it",
    };
    return excluded;
}

}  // namespace ms::sweep
