#include "jobs/sweep/store.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "core/digest.hpp"
#include "io/atomic_file.hpp"
#include "io/input_file.hpp"
#include "io/text.hpp"

namespace ms::sweep {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A stored row's numbers, checked like any input (anyone can recompute an item's digest): the query's
// parameters finite, the term a fraction in [0, 1], its error finite and in [0, 1]. The columns are
// csv_header's: point, form, ao_weighting, then the numbers from roughness to visibility, term, std_error.
std::string check_sweep_row_values(const std::string& line) {
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

constexpr const char* kOldManifestFormats[] = {"microshadow-sweep-manifest/1", "microshadow-sweep-manifest/2"};

bool is_old_manifest(const json& m) {
    if (!m.is_object() || !m.contains("format") || !m["format"].is_string()) return false;
    const std::string format = m["format"];
    return std::find(std::begin(kOldManifestFormats), std::end(kOldManifestFormats), format) != std::end(kOldManifestFormats);
}

// An old manifest's shape (what the upgrade relies on), so a damaged or crafted one is refused naming
// the file, never with a bare JSON type error.
void check_old_manifest(const std::string& path, const json& m) {
    auto bad = [&](const std::string& what) {
        return std::invalid_argument(path + ": not a valid sweep manifest (" + what + "); remove it or use --restart");
    };
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
    if (!m.contains("header") || !m["header"].is_string()) throw bad("no header string");
    for (const char* key : {"chunks", "points", "chunk_size"})
        if (!m.contains(key) || !m[key].is_number_unsigned()) throw bad(std::string("no ") + key + " count");
}

// The old manifests in `folder`: (path, manifest). Files of other formats (the item store's own
// manifests, which share the name manifest.shard-I-of-N.json) are left to their readers.
std::vector<std::pair<std::string, json>> old_manifests_in(const fs::path& folder) {
    std::vector<std::pair<std::string, json>> out;
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) return out;
    for (const auto& entry : fs::directory_iterator(folder)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("manifest", 0) != 0 || entry.path().extension() != ".json") continue;
        json m;
        try {
            m = json::parse(read_input_file(entry.path().string(), 1 << 26, "manifest"));
        } catch (const json::exception&) {
            continue;  // not an old manifest we can tell; the item store refuses it by name if it is its own
        }
        if (!is_old_manifest(m)) continue;
        check_old_manifest(entry.path().string(), m);
        out.emplace_back(entry.path().string(), std::move(m));
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    return out;
}

// Where old manifests wait while their chunks become items: out of the folder's top, where the item
// store's manifests of the same names go.
fs::path upgrade_folder(const std::string& dir) { return fs::path(dir) / "chunks" / "upgrading"; }

}  // namespace

std::string check_chunk_rows(const std::string& text, std::uint64_t first, std::uint64_t last, std::size_t fields) {
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
        if (const std::string problem = check_sweep_row_values(line); !problem.empty())
            return "values: row of point " + std::to_string(expect) + ": " + problem;
        ++expect;
    }
    if (expect != last) return "rows: " + std::to_string(expect - first) + " rows, not " + std::to_string(last - first);
    return "";
}

json read_sweep_description(const std::string& dir) {
    const std::string path = (fs::path(dir) / kSweepDescriptionFile).string();
    std::error_code ec;
    if (!fs::exists(path, ec))
        throw std::invalid_argument(dir + ": not a sweep folder (no " + std::string(kSweepDescriptionFile) +
                                    "); run the sweep or its shards there first");
    json d;
    try {
        d = json::parse(read_input_file(path, 1 << 26, "sweep description"));
    } catch (const json::exception& e) {
        throw std::invalid_argument(path + ": not a valid sweep description (" + e.what() + ")");
    }
    auto bad = [&](const std::string& what) { return std::invalid_argument(path + ": not a valid sweep description (" + what + ")"); };
    if (!d.is_object() || d.value("format", "") != kSweepDescriptionFormat) throw bad(std::string("format is not ") + kSweepDescriptionFormat);
    for (const char* key : {"spec_hash", "header"})
        if (!d.contains(key) || !d[key].is_string()) throw bad(std::string("no ") + key + " string");
    for (const char* key : {"points", "chunk_size", "chunks"})
        if (!d.contains(key) || !d[key].is_number_unsigned()) throw bad(std::string("no ") + key + " count");
    const std::uint64_t points = d["points"], chunk_size = d["chunk_size"], chunks = d["chunks"];
    if (chunk_size == 0 || chunks != (points + chunk_size - 1) / chunk_size)
        throw bad(std::to_string(chunks) + " chunks of " + std::to_string(chunk_size) + " do not hold " + std::to_string(points) + " points");
    if (!d.contains("tolerance") || !d["tolerance"].is_number() || !(d["tolerance"].get<double>() >= 0) ||
        !std::isfinite(d["tolerance"].get<double>()))
        throw bad("no tolerance >= 0");
    return d;
}

void write_sweep_description(const std::string& dir, const json& description) {
    AtomicFile f((fs::path(dir) / kSweepDescriptionFile).string());
    f.stream() << dump_json(description, 1) << "\n";  // paths may hold bytes that are not UTF-8
    f.commit();
}

schedule::StoreKey sweep_store_key(const json& description) {
    return {"sweep", description.at("spec_hash").get<std::string>(), description.at("chunks").get<std::uint64_t>()};
}

std::vector<std::string> old_sweep_manifest_hashes(const std::string& dir) {
    std::vector<std::string> hashes;
    for (const fs::path& folder : {fs::path(dir), upgrade_folder(dir)})
        for (const auto& [path, m] : old_manifests_in(folder)) hashes.push_back(m["spec_hash"]);
    return hashes;
}

std::uint64_t upgrade_old_sweep_folder(const std::string& dir, const std::string& expected_spec_hash,
                                       const std::function<void(const std::string&)>& warn) {
    auto top = old_manifests_in(dir);
    auto waiting = old_manifests_in(upgrade_folder(dir));
    if (top.empty() && waiting.empty()) return 0;
    std::string hash = expected_spec_hash;
    for (const auto* list : {&top, &waiting})
        for (const auto& [path, m] : *list) {
            if (hash.empty()) hash = m["spec_hash"];
            if (m["spec_hash"] != hash)
                throw std::invalid_argument(path + ": this directory holds a different sweep (spec, method, sampling, backend or "
                                                   "comparator files changed); use another --out, or --restart to discard it");
        }
    // Old manifests leave the top first: the item store's manifests take the same names. A run killed
    // during the upgrade finds them waiting and carries on.
    fs::create_directories(upgrade_folder(dir));
    for (const auto& [path, m] : top) fs::rename(path, upgrade_folder(dir) / fs::path(path).filename());
    waiting = old_manifests_in(upgrade_folder(dir));

    schedule::ChunkLayout old_layout;  // the old chunk files: bare rows, their digests in the manifest
    old_layout.folder = (fs::path(dir) / "chunks").string();
    old_layout.prefix = "chunk-";
    old_layout.suffix = ".csv";
    old_layout.seal = schedule::ItemSeal::recorded;
    const schedule::ChunkFiles old_chunks(old_layout);
    std::uint64_t imported = 0;
    for (const auto& [path, m] : waiting) {
        const std::uint64_t points = m["points"], chunk_size = m["chunk_size"], chunks = m["chunks"];
        if (chunk_size == 0 || chunks != (points + chunk_size - 1) / chunk_size)
            throw std::invalid_argument(path + ": not a valid sweep manifest (its chunk counts disagree); remove it or use --restart");
        const std::string header = m["header"];
        const std::size_t fields = std::size_t(std::count(header.begin(), header.end(), ',')) + 1;
        schedule::Shard shard;
        if (m.contains("shard")) shard = {m["shard"]["index"].get<std::uint32_t>(), m["shard"]["count"].get<std::uint32_t>()};
        // What the items are, for the runs and merges that follow (the first old manifest's words).
        json description = m;
        for (const char* key : {"finished", "digests", "shard", "complete", "format"}) description.erase(key);
        description["format"] = kSweepDescriptionFormat;
        const json sampling = m.value("sampling", json::object());
        description["tolerance"] =
            sampling.is_object() && sampling.value("method", "") == "exact" && sampling.contains("tolerance") && sampling["tolerance"].is_number()
                ? sampling["tolerance"].get<double>()
                : 0.0;
        std::error_code ec;
        if (!fs::exists(fs::path(dir) / kSweepDescriptionFile, ec)) write_sweep_description(dir, description);

        const schedule::ItemStore store(dir, sweep_store_key(description), shard, schedule::CommitPolicy{}, {}, warn);
        std::uint64_t shard_done = 0, shard_chunks = 0;
        for (std::uint64_t c = shard.index; c < chunks; c += shard.count) ++shard_chunks;
        std::vector<std::string> moved;
        for (const auto& finished : m["finished"]) {
            const std::uint64_t c = finished;
            if (c >= chunks) continue;
            const std::string key = std::to_string(c);
            std::error_code missing;
            if (!fs::exists(old_chunks.path(c), missing)) continue;  // listed, but gone: computed again
            std::string warning;
            const json& manifest = m;  // (a structured binding cannot be captured by a lambda in C++17)
            const auto rows = old_chunks.read(c, &warning, [&](const std::string& text) -> std::string {
                // Format 2 recorded each chunk's row count and digest; format 1 chunks are checked by their rows alone.
                if (manifest.contains("digests") && manifest["digests"].contains(key)) {
                    const json& recorded = manifest["digests"][key];
                    const schedule::ItemDigest d = schedule::digest_of(text);
                    if (d.rows != recorded["rows"].get<std::uint64_t>() || hex16(d.fnv1a) != recorded["fnv1a64"].get<std::string>())
                        return "digest: its " + std::to_string(d.rows) + " rows and digest " + hex16(d.fnv1a) + " are not the " +
                               std::to_string(recorded["rows"].get<std::uint64_t>()) + " rows and digest " +
                               recorded["fnv1a64"].get<std::string>() + " recorded when it was written";
                }
                return check_chunk_rows(text, c * chunk_size, std::min(points, (c + 1) * chunk_size), fields);
            });
            if (!rows) {
                if (warn) warn(warning + "; computed again");
                continue;
            }
            store.save(c, *rows);
            moved.push_back(old_chunks.path(c));
            ++imported;
            shard_done += c % shard.count == shard.index;
        }
        const std::vector<std::string> devices = {m.value("backend", std::string("unknown"))};
        store.write_manifest(m.value("complete", false) && shard_done == shard_chunks, devices, 0);
        // The items are on disk (write_manifest syncs them): the old copies and the manifest can go.
        for (const auto& p : moved) fs::remove(p, ec);
        fs::remove(path);
    }
    std::error_code ec;
    fs::remove(upgrade_folder(dir), ec);  // only when empty
    return imported;
}

}  // namespace ms::sweep
