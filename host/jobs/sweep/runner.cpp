#include "jobs/sweep/runner.hpp"

#include "approx/analytic.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

#include "analytic/part1_terms.hpp"
#include "core/cancel.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "integrands/term/term_integrand.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/text.hpp"
#include "jobs/cache_keys.hpp"
#include "jobs/compare.hpp"
#include "lut/lookup.hpp"
#include "jobs/sweep/points.hpp"
#include "jobs/sweep/store.hpp"
#include "schedule/chunk_store.hpp"
#include "schedule/distributed.hpp"

namespace ms::sweep {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

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

// The sweep's rows, handed over a chunk at a time from the store (checked there like any input);
// nullopt: chunk c is missing or damaged, `problem` says which and where a damaged one went.
using ChunkSource = std::function<std::optional<std::string>(std::uint64_t c, std::string& problem)>;

// Writes sweep.csv from the chunks (in chunk order), then the summary and provenance. A missing or
// damaged chunk never reaches sweep.csv: the error (std::invalid_argument, bad input as a damaged item
// of any store is) names it with `remedy`, and none of the four outputs is written.
Summary assemble(const std::string& out_dir, const std::string& header, std::uint64_t chunks, const ChunkSource& chunk,
                 const std::string& remedy, double tolerance, json provenance) {
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
        throw_if_cancelled();
        std::string problem;
        const std::optional<std::string> rows = chunk(c, problem);
        if (!rows) throw std::invalid_argument(problem + "; " + remedy);
        out << *rows;
    }
    out.flush();
    if (!out) throw std::runtime_error((fs::path(out_dir) / "sweep.csv").string() + ": could not be written");
    // The temporary is read back in its own scope: Windows cannot rename a file that is still open, so
    // the reader must be closed before commit() renames it to sweep.csv.
    const Summary s = [&] {
        std::ifstream in(outputs.temp_path(csv), std::ios::binary);
        return summarise(in, (fs::path(out_dir) / "sweep.csv").string(), tolerance);
    }();
    outputs.stream(md) << summary_markdown(s) << domain_markdown(provenance);
    outputs.stream(sc) << summary_csv(s);
    provenance["max_std_error"] = s.max_std_error;
    if (s.tolerance.tolerance > 0) {
        provenance["tolerance_met"] = s.tolerance.met();
        provenance["points_over_tolerance"] = s.tolerance.over;
    }
    outputs.stream(js) << dump_json(provenance, 1) << "\n";
    outputs.commit();
    return s;
}

// A chunk of the store, checked: its rows for assemble().
ChunkSource store_chunks(const schedule::ItemStore& store, const std::function<std::string(std::uint64_t, const std::string&)>& check) {
    return [&store, check](std::uint64_t c, std::string& problem) -> std::optional<std::string> {
        std::string warning;
        auto rows = store.load(c, &warning, [&](const std::string& payload) { return check(c, payload); });
        if (!rows) problem = warning.empty() ? store.files().path(c) + ": missing (the chunk is not in the store)" : warning;
        return rows;
    };
}

// The sweep's chunks as work items of the shared item store: the term integrand (sampled or exact)
// computes a chunk's estimates, the sink turns them into the chunk's rows, and the rows are the item's
// payload the store keeps, ranks send and merges read back, checked like any input.
class SweepChunks final : public schedule::Integrand {
public:
    using Check = std::function<std::string(std::uint64_t, const std::string&)>;
    explicit SweepChunks(Check check) : check_(std::move(check)) {}
    void set_term(std::unique_ptr<schedule::Integrand> term) { term_ = std::move(term); }
    // From the term's sink: chunk c's rows, kept until the store (or rank 0) takes them.
    void put(std::uint64_t c, std::string rows) {
        std::lock_guard<std::mutex> lock(mutex_);
        rows_[c] = std::move(rows);
    }

    std::string name() const override { return "sweep"; }
    std::uint64_t work_items() const override { return term_->work_items(); }
    std::unique_ptr<schedule::Worker> device_worker(ocl::Device& device) override { return term_->device_worker(device); }
    std::unique_ptr<schedule::Worker> oracle_worker() override { return term_->oracle_worker(); }
    bool distributable() const override { return true; }
    // Taken once, when the chunk is stored or sent: the rows are not kept twice in memory.
    std::string save_item(std::uint64_t c) const override {
        std::lock_guard<std::mutex> lock(mutex_);
        const auto it = rows_.find(c);
        if (it == rows_.end()) throw std::logic_error("sweep: chunk " + std::to_string(c) + " was not computed");
        std::string rows = std::move(it->second);
        rows_.erase(it);
        return rows;
    }
    // Rows from the store or another rank: the chunk's points in the sweep's fields, or refused.
    // (sweep.csv is assembled from the store afterwards; nothing else is kept.)
    void load_item(std::uint64_t c, const std::string& rows) override {
        if (const std::string problem = check_(c, rows); !problem.empty())
            throw std::runtime_error("sweep chunk " + std::to_string(c) + " as received: " + problem);
    }
    std::string check_item(std::uint64_t c, const std::string& rows) const override { return check_(c, rows); }

private:
    Check check_;
    std::unique_ptr<schedule::Integrand> term_;
    mutable std::mutex mutex_;
    mutable std::map<std::uint64_t, std::string> rows_;
};

// The places a scheduler ran on, as the store's manifests record them.
std::vector<std::string> sweep_places(const schedule::Scheduler& scheduler) {
    return scheduler.is_oracle() ? std::vector<std::string>{scheduler.name()} : scheduler.device_labels();
}

// The tolerance a sweep's values are held to: the exact method always has one (its default when none is
// given); a sampled sweep is one of fixed samples and has none.
double checked_tolerance(const SamplingPlan& plan) {
    if (plan.method != Method::exact) return 0;
    return plan.tolerance > 0 ? plan.tolerance : exact::kDefaultTolerance;
}

// Everything a previous run left in `dir` goes (--restart): its items, chunks, manifests and outputs.
void discard_previous_sweep(const fs::path& dir) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return;
    for (const char* folder : {"items", "chunks", "figures"}) fs::remove_all(dir / folder);
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if ((name.rfind("manifest", 0) == 0 && entry.path().extension() == ".json") || name == "sweep.csv" || name == "sweep.json" ||
            name == "summary.md" || name == "summary.csv" || name == kSweepDescriptionFile)
            fs::remove(entry.path());
    }
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
    result.shard_chunks = result.chunks > config.shard.index
                              ? (result.chunks - config.shard.index + config.shard.count - 1) / config.shard.count
                              : 0;
    const std::uint64_t chunk_size = spec.chunk_size;
    auto chunk_end = [&](std::uint64_t c) { return std::min(result.points, (c + 1) * chunk_size); };
    const std::string header = csv_header(spec);
    const std::size_t fields = std::size_t(std::count(header.begin(), header.end(), ',')) + 1;
    const auto check = [&](std::uint64_t c, const std::string& rows) -> std::string {
        if (c >= result.chunks) return "index: chunk " + std::to_string(c) + " is not a chunk of this sweep";
        return check_chunk_rows(rows, c * chunk_size, chunk_end(c), fields);
    };

    // Chunks are the term integrand's work items (one per chunk either way: the exact integrand has the
    // sampled one's source/sink contract); the sink turns a computed chunk's estimates into its rows.
    SweepChunks chunks(check);
    auto chunk_queries = [&](std::uint64_t c) { return computer.queries(c * chunk_size, chunk_end(c)); };
    auto sink = [&](std::uint64_t c, std::vector<Estimate>&& est) { chunks.put(c, computer.rows(c * chunk_size, chunk_end(c), est)); };
    if (config.plan.method == Method::exact) {
        exact_term::ExactConfig exact;
        exact.tolerance = checked_tolerance(config.plan);
        exact.build = config.backend->config().build;
        exact.force_float = config.plan.single_precision;
        exact.kernel_on_cpu_devices = config.plan.kernel_on_cpu_devices;
        chunks.set_term(std::make_unique<exact_term::ExactTermIntegrand>(result.chunks, chunk_queries, sink, exact));
    } else {
        chunks.set_term(std::make_unique<term::TermIntegrand>(result.chunks, chunk_queries, sink, config.plan, config.backend->config()));
    }

    // Only rank 0 of an MPI world keeps the store (the other ranks compute and touch no file).
    const bool rank0 = !config.transport || config.transport->coordinator();
    const double tolerance = checked_tolerance(config.plan);
    json description;
    schedule::StoreKey key{"sweep", "", result.chunks};
    auto warn = [&](const std::string& w) {
        result.warnings.push_back(w);
        if (config.warn) config.warn(w);
    };
    if (rank0) {
        result.spec_hash = key.spec_hash = sweep_cache_key(spec, config).hash();
        const fs::path dir(config.out_dir);
        if (config.restart) {
            discard_previous_sweep(dir);
        } else {
            // A folder of the format before the item store: its sound chunks become items.
            upgrade_old_sweep_folder(config.out_dir, result.spec_hash, warn);
            std::error_code ec;
            if (fs::exists(dir / kSweepDescriptionFile, ec) && read_sweep_description(config.out_dir)["spec_hash"] != result.spec_hash)
                throw std::invalid_argument((dir / kSweepDescriptionFile).string() +
                                            ": this directory holds a different sweep (spec, method, sampling, backend or comparator "
                                            "files changed); use another --out, or --restart to discard it");
        }
        description = {{"format", kSweepDescriptionFormat},
                       {"spec_hash", result.spec_hash},
                       {"spec", spec.source},
                       {"name", spec.name},
                       {"canonical_spec", canonical_text(spec)},
                       {"header", header},
                       {"points", result.points},
                       {"chunk_size", spec.chunk_size},
                       {"chunks", result.chunks},
                       {"sampling", sampling_provenance(config.plan)},
                       {"tolerance", tolerance},
                       {"backend", config.backend->scheduler().results_label()},
                       {"fast_math", config.backend->config().build.fast_math},
                       {"double_kernels", config.backend->config().build.double_precision},
                       {"command_line", config.command_line},
                       {"comparator_files", computer.file_provenance()}};
    }
    // The shared item store in the output folder, for this shard (schedule/distributed.hpp): it refuses a
    // folder of another sweep (spec, method, sampling, backend or comparator files) or of another split.
    schedule::DistributionRequest request;
    request.shard = config.shard;
    request.shard_given = config.shard.count > 1;
    request.store = config.out_dir;
    request.transport = config.transport;
    // (The store's warnings say what follows them: computed again, or the shard to rerun.)
    schedule::Distribution distribution(request, key, config.out_dir, warn);
    const schedule::ItemStore* store = distribution.store();
    if (store) {
        // (Under MPI rank 0 still runs the exchange, with nothing to hand out, so the other ranks stop.)
        if (config.shard.count == 1 && !config.transport && store->unfinished_shards().empty() &&
            fs::exists(fs::path(config.out_dir) / "sweep.csv")) {
            result.skipped = result.chunks;
            result.complete = result.assembled = true;
            // A finished sweep asked again still says whether its values met the tolerance.
            const std::string csv = (fs::path(config.out_dir) / "sweep.csv").string();
            std::ifstream in(csv, std::ios::binary);
            result.tolerance = summarise(in, csv, tolerance).tolerance;
            return result;
        }
        write_sweep_description(config.out_dir, description);
    }

    schedule::ItemPlan plan = distribution.plan();
    plan.max_items = config.max_chunks;
    schedule::RunCallbacks callbacks;
    if (config.progress)
        callbacks.progress = [&](std::uint64_t done, std::uint64_t) { config.progress(std::min(done, result.shard_chunks), result.shard_chunks); };
    const schedule::ItemRunReport report = schedule::run_items(config.backend->scheduler(), chunks, plan, callbacks);
    result.computed = report.run.done;
    result.skipped = report.loaded;
    if (!store) return result;  // a computing rank: rank 0 reports and writes
    // An MPI world's rank 0 records its finished store as a single process's run would.
    if (config.transport) store->write_manifest(true, sweep_places(config.backend->scheduler()), report.rerun);
    result.complete = report.shard_complete;
    if (!result.complete || config.shard.count > 1) return result;

    json provenance = description;
    provenance["complete"] = true;
    try {
        const Summary s = assemble(config.out_dir, header, result.chunks, store_chunks(*store, check),
                                   "sweep.csv was not written: rerun the same command to compute it again", tolerance, provenance);
        result.tolerance = s.tolerance;
    } catch (const std::invalid_argument&) {
        // A chunk found damaged was set aside: the store is no longer complete, and the rerun computes it.
        store->write_manifest(false, sweep_places(config.backend->scheduler()), report.rerun);
        throw;
    }
    // The items stay: they are the evidence sweep.csv was assembled from (sweep --restart or removing the
    // directory frees the space).
    result.assembled = true;
    return result;
}

MergeResult merge_shards(const std::vector<std::string>& shard_dirs, const std::string& out_dir, const std::string& command_line,
                         const std::string& expected_spec_hash, const std::function<void(const std::string&)>& warn) {
    if (shard_dirs.empty()) throw std::invalid_argument("merge: no sweep folders given");
    // Folders of the format before the item store are upgraded first (their chunks become items).
    json description;
    for (const auto& d : shard_dirs) {
        std::error_code ec;
        if (!fs::is_directory(d, ec)) throw std::invalid_argument(d + ": not a directory");
        upgrade_old_sweep_folder(d, expected_spec_hash, warn);
        const json found = read_sweep_description(d);
        if (!expected_spec_hash.empty() && found["spec_hash"] != expected_spec_hash)
            throw std::invalid_argument(d + ": holds another sweep (spec hash " + found["spec_hash"].get<std::string>() +
                                        ", this one's is " + expected_spec_hash + "); merge the folder its shards ran in");
        if (description.is_null()) description = found;
        else if (found["spec_hash"] != description["spec_hash"])
            throw std::invalid_argument(d + ": shards of a different sweep (spec hash " + found["spec_hash"].get<std::string>() +
                                        ", the first folder's is " + description["spec_hash"].get<std::string>() + ")");
    }
    const schedule::StoreKey key = sweep_store_key(description);
    const std::string header = description["header"];
    const std::size_t fields = std::size_t(std::count(header.begin(), header.end(), ',')) + 1;
    const std::uint64_t points = description["points"], chunk_size = description["chunk_size"];
    const auto check = [&](std::uint64_t c, const std::string& rows) -> std::string {
        if (c >= key.items) return "index: chunk " + std::to_string(c) + " is not a chunk of this sweep";
        return check_chunk_rows(rows, c * chunk_size, std::min(points, (c + 1) * chunk_size), fields);
    };
    // A merge refused writes nothing: not even the output folder it created.
    std::error_code ec;
    const bool created = !fs::exists(out_dir, ec);
    try {
        fs::create_directories(out_dir);
        // Shards run in separate folders are gathered into the output folder's store first (each shard's
        // items from the folder whose manifest says it finished), so that one store holds the whole sweep.
        std::string store_dir = shard_dirs.front();
        if (shard_dirs.size() > 1) {
            store_dir = out_dir;
            std::map<std::uint32_t, std::string> owner;
            std::uint32_t count = 0;
            std::vector<schedule::ItemStore> sources;
            for (const auto& d : shard_dirs) {
                sources.push_back(schedule::ItemStore::open_for_merge(d, key, {}, warn));
                const std::uint32_t n = sources.back().merge_shard_count();
                if (count && n != count)
                    throw std::invalid_argument(d + ": the sweep was split into " + std::to_string(n) + " shards here but into " +
                                                std::to_string(count) + " in " + shard_dirs.front());
                count = n;
                const auto unfinished = sources.back().unfinished_shards();
                for (std::uint32_t i = 0; i < n; ++i) {
                    if (std::find(unfinished.begin(), unfinished.end(), i) != unfinished.end()) continue;
                    if (owner.count(i) && !fs::equivalent(owner[i], d))
                        throw std::invalid_argument("shard " + std::to_string(i) + "/" + std::to_string(n) + " found twice: in " +
                                                    owner[i] + " and " + d);
                    owner[i] = d;
                }
            }
            for (std::uint32_t i = 0; i < count; ++i)
                if (!owner.count(i))
                    throw std::invalid_argument("merge: shard " + std::to_string(i) + "/" + std::to_string(count) +
                                                " is missing or unfinished in every folder given; run it first");
            for (std::size_t k = 0; k < sources.size(); ++k) {
                if (fs::equivalent(shard_dirs[k], out_dir, ec)) continue;
                for (std::uint32_t i = 0; i < count; ++i) {
                    if (owner[i] != shard_dirs[k]) continue;
                    const schedule::ItemStore gathered(out_dir, key, {i, count}, schedule::CommitPolicy{}, {}, warn);
                    for (std::uint64_t c = i; c < key.items; c += count) {
                        std::string warning;
                        const auto rows = sources[k].load(c, &warning, [&](const std::string& p) { return check(c, p); });
                        if (!rows) {  // damaged (set aside, and said) or missing: the merge below names its shard
                            if (warn && !warning.empty()) warn(warning);
                            continue;
                        }
                        gathered.save(c, *rows);
                    }
                    gathered.write_manifest(true, sources[k].recorded_devices(), 0);
                }
            }
            write_sweep_description(out_dir, description);
        }
        // The shared merge (schedule/distributed.hpp): every chunk in the store and sound, or the shards
        // to rerun are named (a damaged chunk is set aside, so the rerun computes it).
        const schedule::ItemStore store = schedule::ItemStore::open_for_merge(store_dir, key, {}, warn);
        schedule::ItemPlan plan;
        plan.store = &store;
        plan.merge_only = true;
        plan.warn = warn;
        schedule::ItemJob job;
        job.name = "sweep";
        job.items = key.items;
        job.accept = [](std::uint64_t, const std::string&) {};  // assembled from the store below
        job.check = check;
        schedule::run_item_job(job, plan, {});
        json provenance = description;
        provenance["merged_from"] = shard_dirs;
        provenance["command_line"] = command_line;
        provenance["complete"] = true;
        MergeResult result;
        result.spec_hash = key.spec_hash;
        result.points = points;
        result.chunks = key.items;
        const Summary s = assemble(out_dir, header, key.items, store_chunks(store, check),
                                   "rerun its shard (it computes the chunk again), then merge", description["tolerance"], provenance);
        result.tolerance = s.tolerance;
        return result;
    } catch (...) {
        if (created) fs::remove_all(out_dir, ec);
        throw;
    }
}

Summary summarise(std::istream& csv, const std::string& name, double tolerance) {
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
    s.tolerance.tolerance = tolerance;
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
        const double std_error = std::stod(f[se]);
        s.max_std_error = std::max(s.max_std_error, std_error);
        s.tolerance.add(std_error);
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
      << " points; max std error of the term " << fmt(s.max_std_error)
      << (s.tolerance.tolerance > 0 ? " " + s.tolerance.summary() : std::string()) << ".\n\n"
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
