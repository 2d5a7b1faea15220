#include "jobs/sweep/runner.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <set>
#include <sstream>

#include "analytic/part1_terms.hpp"
#include "core/cancel.hpp"
#include "integrands/term/term_integrand.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "lut/lookup.hpp"
#include "jobs/sweep/points.hpp"

namespace ms::sweep {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kManifestFormat = "microshadow-sweep-manifest/1";

std::uint64_t fnv1a(const std::string& bytes, std::uint64_t h = 1469598103934665603ULL) {
    for (unsigned char c : bytes) {
        h ^= c;
        h *= 1099511628211ULL;
    }
    return h;
}

std::string hex(std::uint64_t v) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016" PRIx64, v);
    return buf;
}

std::string read_all(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot read");
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

std::string chunk_path(const std::string& dir, std::uint64_t c) {
    char name[64];
    std::snprintf(name, sizeof name, "chunk-%010" PRIu64 ".csv", c);
    return (fs::path(dir) / "chunks" / name).string();
}

std::string manifest_name(const Shard& s) {
    if (s.count == 1) return "manifest.json";
    return "manifest.shard-" + std::to_string(s.index) + "-of-" + std::to_string(s.count) + ".json";
}

json read_json(const std::string& path) {
    try {
        return json::parse(read_all(path));
    } catch (const json::exception& e) {
        throw std::runtime_error(path + ": not a valid manifest (" + e.what() + "); remove it or use --restart");
    }
}

void write_json(const std::string& path, const json& j) {
    AtomicFile f(path);
    f.stream() << j.dump(1) << "\n";
    f.commit();
}

// Every input that decides the bits of the rows: the spec's values, the sampling plan, the
// defaults, the backend and the LUT contents (a re-baked LUT must not resume old chunks).
std::string compute_spec_hash(const Spec& spec, const RunConfig& c) {
    std::ostringstream s;
    s << canonical_text(spec) << "samples=" << c.plan.samples << "\nreplicates=" << c.plan.replicates
      << "\nseed=" << c.plan.seed << "\nsequence=" << to_string(c.plan.sequence)
      << "\ndefault_form=" << to_string(c.defaults.form) << "\ndefault_ao=" << to_string(c.defaults.ao_weighting)
      << "\nbackend=" << c.backend_label << "\nfast_math=" << c.fast_math << "\n";
    std::uint64_t h = fnv1a(s.str());
    for (const auto& l : spec.luts) h = fnv1a(read_all(l.file), h);
    return hex(h);
}

// Roughness for Activision's adjusted term: its own non-standard roughness of the point's
// isotropic-equivalent alpha (see points.hpp).
double activision_roughness(const Point& p) {
    return analytic::activision_roughness_from_alpha(p.roughness * p.roughness);
}

class ChunkComputer {
public:
    ChunkComputer(const Spec& spec, const RunConfig& config)
        : spec_(spec), grid_(spec, config.defaults.form, config.defaults.ao_weighting) {
        for (const auto& l : spec.luts) luts_.push_back(std::make_unique<LutLookup>(LutLookup::open(l.file)));
    }
    const PointGrid& grid() const { return grid_; }

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
            analytic::AnalyticInputs in;
            in.visibility = p.visibility;
            in.n_dot_l = p.n_dot_l;
            in.n_dot_v = p.n_dot_v;
            in.ao_weighting = p.weighting;
            const bool needs_act = std::find(spec_.analytic.begin(), spec_.analytic.end(),
                                             analytic::AnalyticTerm::activision_adjusted) != spec_.analytic.end();
            in.roughness = needs_act ? activision_roughness(p) : 0.5;
            for (auto t : spec_.analytic) line += "," + format_number(analytic::evaluate(t, in));
            for (const auto& l : luts_) line += "," + format_number((*l)(p.visibility, p.n_dot_l, p.n_dot_v, p.roughness));
            out += line + "\n";
        }
        return out;
    }

private:
    const Spec& spec_;
    PointGrid grid_;
    std::vector<std::unique_ptr<LutLookup>> luts_;
};

// Writes sweep.csv from the chunk files (in chunk order), then the summary and provenance.
void assemble(const std::string& out_dir, const std::string& header, std::uint64_t chunks,
              const std::function<std::string(std::uint64_t)>& chunk_file, json provenance) {
    const std::string csv_path = (fs::path(out_dir) / "sweep.csv").string();
    {
        AtomicFile csv(csv_path, true);
        csv.stream() << header << "\n";
        for (std::uint64_t c = 0; c < chunks; ++c) {
            std::ifstream in(chunk_file(c), std::ios::binary);
            if (!in) throw std::runtime_error(chunk_file(c) + ": missing chunk file");
            csv.stream() << in.rdbuf();
        }
        csv.commit();
    }
    std::ifstream in(csv_path, std::ios::binary);
    const Summary s = summarise(in, csv_path);
    AtomicFile md((fs::path(out_dir) / "summary.md").string());
    md.stream() << summary_markdown(s);
    md.commit();
    AtomicFile sc((fs::path(out_dir) / "summary.csv").string());
    sc.stream() << summary_csv(s);
    sc.commit();
    provenance["max_std_error"] = s.max_std_error;
    write_json((fs::path(out_dir) / "sweep.json").string(), provenance);
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

Shard parse_shard(const std::string& text) {
    const auto slash = text.find('/');
    auto bad = [&] { return std::invalid_argument("--shard: expected I/N with 0 <= I < N, got '" + text + "'"); };
    if (slash == std::string::npos) throw bad();
    try {
        std::size_t used = 0;
        const unsigned long i = std::stoul(text.substr(0, slash), &used);
        if (used != slash) throw bad();
        const std::string rest = text.substr(slash + 1);
        const unsigned long n = std::stoul(rest, &used);
        if (used != rest.size() || n == 0 || i >= n || n > 1000000) throw bad();
        return {std::uint32_t(i), std::uint32_t(n)};
    } catch (const std::logic_error&) {
        throw bad();
    }
}

std::string csv_header(const Spec& spec) {
    std::string h = "point,form,ao_weighting,roughness,alpha_x,alpha_y,n_dot_v,phi_i,phi_o,delta_phi,n_dot_l,visibility,term,std_error";
    for (const auto& n : comparator_names(spec)) h += "," + n;
    return h;
}

RunResult run_sweep(const Spec& spec, const RunConfig& config) {
    if (!config.backend) throw std::invalid_argument("run_sweep: no backend");
    if (config.shard.count == 0 || config.shard.index >= config.shard.count) throw std::invalid_argument("bad shard");
    ChunkComputer computer(spec, config);
    RunResult result;
    result.points = computer.grid().size();
    result.chunks = (result.points + spec.chunk_size - 1) / spec.chunk_size;
    result.shard_chunks = result.chunks > config.shard.index
                              ? (result.chunks - config.shard.index + config.shard.count - 1) / config.shard.count
                              : 0;
    result.spec_hash = compute_spec_hash(spec, config);

    const fs::path dir(config.out_dir);
    fs::create_directories(dir / "chunks");
    const std::string manifest_path = (dir / manifest_name(config.shard)).string();

    // Every manifest in the directory must describe this sweep: chunk files are shared by name.
    std::set<std::uint64_t> finished;
    bool complete_before = false;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("manifest", 0) != 0 || entry.path().extension() != ".json") continue;
        const json m = read_json(entry.path().string());
        if (m.value("spec_hash", "") != result.spec_hash) {
            if (!config.restart)
                throw std::invalid_argument(entry.path().string() +
                                            ": this directory holds a different sweep (spec, sampling, backend or LUT "
                                            "files changed); use another --out, or --restart to discard it");
            continue;
        }
        if (entry.path().string() == manifest_path) {
            complete_before = m.value("complete", false);
            for (std::uint64_t c : m.at("finished")) finished.insert(c);
        }
    }
    if (config.restart) {
        for (const auto& entry : fs::directory_iterator(dir / "chunks")) fs::remove(entry.path());
        for (const auto& entry : fs::directory_iterator(dir))
            if (entry.path().filename().string().rfind("manifest", 0) == 0) fs::remove(entry.path());
        finished.clear();
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
                     {"sampling",
                      {{"samples", config.plan.samples},
                       {"replicates", config.plan.replicates},
                       {"seed", config.plan.seed},
                       {"sequence", to_string(config.plan.sequence)}}},
                     {"backend", config.backend_label},
                     {"fast_math", config.fast_math},
                     {"command_line", config.command_line},
                     {"complete", false},
                     {"finished", json::array()}};
    auto save_manifest = [&](bool complete) {
        manifest["finished"] = json(std::vector<std::uint64_t>(finished.begin(), finished.end()));
        manifest["complete"] = complete;
        write_json(manifest_path, manifest);
    };

    const bool unsharded = config.shard.count == 1;
    const std::string csv_path = (dir / "sweep.csv").string();
    if (unsharded && complete_before && fs::exists(csv_path)) {
        result.skipped = result.chunks;
        result.complete = result.assembled = true;
        return result;
    }

    // Chunks are the term integrand's work items: the scheduler deals the unfinished ones of this shard
    // to the places; each worker writes its chunk file (atomically) as soon as the chunk is computed, and
    // the manifest names it only after that, one update at a time, so a kill between the two only costs
    // recomputing that chunk.
    std::uint64_t found = 0;
    for (std::uint64_t c = config.shard.index; c < result.chunks; c += config.shard.count)
        if (finished.count(c) && fs::exists(chunk_path(config.out_dir, c))) ++found;
    result.skipped = found;
    auto chunk_done = [&](std::uint64_t c) { return finished.count(c) && fs::exists(chunk_path(config.out_dir, c)); };
    for (auto it = finished.begin(); it != finished.end();)  // listed but its file is gone: recompute
        it = fs::exists(chunk_path(config.out_dir, *it)) ? std::next(it) : finished.erase(it);
    const std::uint64_t chunk_size = spec.chunk_size;
    term::TermIntegrand integrand(
        result.chunks,
        [&](std::uint64_t c) { return computer.queries(c * chunk_size, std::min(result.points, (c + 1) * chunk_size)); },
        [&](std::uint64_t c, std::vector<Estimate>&& est) {
            const std::string rows = computer.rows(c * chunk_size, std::min(result.points, (c + 1) * chunk_size), est);
            AtomicFile f(chunk_path(config.out_dir, c), true);
            f.stream() << rows;
            f.commit();
        },
        config.plan, config.backend->config());
    schedule::WorkSelection selection;
    selection.shard_index = config.shard.index;
    selection.shard_count = config.shard.count;
    selection.already_done = chunk_done;
    selection.max_items = config.max_chunks;
    schedule::RunCallbacks callbacks;
    callbacks.on_done = [&](std::uint64_t c) {
        finished.insert(c);
        save_manifest(false);
        ++result.computed;
    };
    if (config.progress)
        callbacks.progress = [&](std::uint64_t done, std::uint64_t) { config.progress(found + done, result.shard_chunks); };
    config.backend->scheduler().run(integrand, selection, callbacks);
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
        prov["complete"] = true;
        assemble(config.out_dir, csv_header(spec), result.chunks,
                 [&](std::uint64_t c) { return chunk_path(config.out_dir, c); }, prov);
        save_manifest(true);
        // sweep.csv holds every row now; the chunk files would only double the disk use.
        for (std::uint64_t c = 0; c < result.chunks; ++c) fs::remove(chunk_path(config.out_dir, c));
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
            if (m.value("format", "") != kManifestFormat) throw std::invalid_argument(entry.path().string() + ": not a sweep manifest");
            const std::uint32_t i = m.at("shard").at("index"), n = m.at("shard").at("count");
            if (hash.empty()) {
                hash = m.at("spec_hash");
                count = n;
            }
            if (m.at("spec_hash") != hash || n != count)
                throw std::invalid_argument(entry.path().string() + ": shard of a different sweep (spec hash " +
                                            m.at("spec_hash").get<std::string>() + " vs " + hash + ")");
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
    fs::create_directories(out_dir);
    assemble(out_dir, first.at("header"), chunks,
             [&](std::uint64_t c) { return chunk_path(shards.at(std::uint32_t(c % count)).dir, c); }, prov);
}

void ErrorStats::add(double e) {
    ++count;
    max_abs = std::max(max_abs, std::abs(e));
    sum_abs += std::abs(e);
    sum_sq += e * e;
    sum += e;
}

double ErrorStats::rms() const { return count ? std::sqrt(sum_sq / count) : 0; }

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
    s.overall.resize(s.comparators.size());
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
        auto& group = s.per_roughness[std::stod(f[rough])];
        group.resize(s.comparators.size());
        for (std::size_t k = 0; k < s.comparators.size(); ++k) {
            const double e = std::stod(f[se + 1 + k]) - t;
            s.overall[k].add(e);
            group[k].add(e);
        }
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
            o << "| " << s.comparators[k] << " | " << r << " | " << e.count << " | " << fmt(e.max_abs) << " | "
              << fmt(e.mean_abs()) << " | " << fmt(e.rms()) << " | " << fmt(e.bias()) << " |\n";
        };
        row("all", s.overall[k]);
        for (const auto& [r, g] : s.per_roughness) row(fmt(r), g[k]);
    }
    return o.str();
}

std::string summary_csv(const Summary& s) {
    std::ostringstream o;
    o << "comparator,roughness,points,max_abs_error,mean_abs_error,rms_error,bias\n";
    for (std::size_t k = 0; k < s.comparators.size(); ++k) {
        auto row = [&](const std::string& r, const ErrorStats& e) {
            o << s.comparators[k] << "," << r << "," << e.count << "," << format_number(e.max_abs) << ","
              << format_number(e.mean_abs()) << "," << format_number(e.rms()) << "," << format_number(e.bias()) << "\n";
        };
        row("all", s.overall[k]);
        for (const auto& [r, g] : s.per_roughness) row(format_number(r), g[k]);
    }
    return o.str();
}

}  // namespace ms::sweep
