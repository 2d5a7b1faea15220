#include "jobs/reference_set.hpp"

#include "core/error_stats.hpp"

#include "core/digest.hpp"
#include "jobs/cache_keys.hpp"

#include <toml++/toml.h>


#include <chrono>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/cancel.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "io/input_file.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"
#include "io/text.hpp"
#include "platform/files.hpp"
#include "sampling/point_set.hpp"
#include "schedule/chunk_store.hpp"

#include <optional>

namespace ms::design {

namespace fs = std::filesystem;

namespace {

// Bumped when the cache format or the point generator changes: old caches are then simply not found.
constexpr int kCacheFormat = 2;
const std::vector<std::string> kPointColumns = {"visibility", "n_dot_l", "n_dot_v", "roughness",
                                                "relative_azimuth_deg", "weight"};
const std::string kCacheHeader = "visibility,n_dot_l,n_dot_v,roughness,relative_azimuth,weight,term,std_error";

// The radical inverse of i in `base`: the Halton sequence's coordinate.
double radical_inverse(std::uint64_t i, unsigned base) {
    double inv = 1.0 / base, f = inv, r = 0;
    while (i > 0) {
        r += f * double(i % base);
        i /= base;
        f *= inv;
    }
    return r;
}

// A reproducible shift in [0, 1) per dimension from the seed (splitmix64): the Cranley-Patterson
// rotation that makes two seeds two independent low-discrepancy sets.
double seed_shift(std::uint64_t seed, unsigned dim) {
    std::uint64_t z = seed * 0x9E3779B97F4A7C15ULL + (dim + 1) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return double(z >> 11) * 0x1.0p-53;
}

[[noreturn]] void fail(const std::string& source, const std::string& key, const std::string& what) {
    throw std::invalid_argument(source + ": " + key + ": " + what);
}

double number(const std::string& source, const toml::node& n, const std::string& key) {
    if (n.is_integer()) return double(n.as_integer()->get());
    if (n.is_floating_point() && std::isfinite(n.as_floating_point()->get())) return n.as_floating_point()->get();
    fail(source, key, "must be a finite number");
}

std::uint64_t positive_integer(const std::string& source, const toml::node& n, const std::string& key,
                               std::uint64_t max) {
    if (!n.is_integer() || n.as_integer()->get() <= 0 || std::uint64_t(n.as_integer()->get()) > max)
        fail(source, key, "must be an integer in [1, " + std::to_string(max) + "]");
    return std::uint64_t(n.as_integer()->get());
}

void reject_unknown(const std::string& source, const toml::table& t, const std::string& prefix,
                    const std::set<std::string>& known) {
    for (const auto& [k, v] : t) {
        if (known.count(std::string(k.str()))) continue;
        std::string list;
        for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
        fail(source, prefix + std::string(k.str()), "unknown key (known here: " + list + ")");
    }
}

// [lo, hi] within [min, max], lo < hi.
Interval interval(const std::string& source, const toml::node& n, const std::string& key, double min, double max) {
    const toml::array* a = n.as_array();
    if (!a || a->size() != 2) fail(source, key, "must be [lo, hi]");
    Interval r{number(source, *a->get(0), key + "[0]"), number(source, *a->get(1), key + "[1]")};
    if (!(r.lo < r.hi) || r.lo < min || r.hi > max)
        fail(source, key, "needs " + format_number(min) + " <= lo < hi <= " + format_number(max) + " (got [" +
                              format_number(r.lo) + ", " + format_number(r.hi) + "])");
    return r;
}

std::string row_text(const ReferencePoint& p, const Estimate& e) {
    return format_number(p.visibility) + "," + format_number(p.n_dot_l) + "," + format_number(p.n_dot_v) + "," +
           format_number(p.roughness) + "," + format_number(p.relative_azimuth) + "," + format_number(p.weight) +
           "," + format_number(e.term) + "," + format_number(e.std_error) + "\n";
}

// What a cache file must hold, recorded when it is written: its row count and FNV-1a 64 digest
// ("rows N fnv1a64 H", the chunk store's digest line). Rows changed afterwards (a term out of range, or
// merely a different number) no longer match it.
std::string digest_text(const std::string& rows) { return schedule::digest_text(schedule::digest_of(rows)); }

std::string read_whole(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open for reading");
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// A problem with a cache file, with a short tag first (the name it is set aside under): "digest",
// "rows", "range", "header", "sidecar".
struct Damage {
    std::string tag, what;
};

// Parses rows written by row_text, checks that they are the expected points and that each estimate is
// a term in [0, 1] with a std error in [0, 1]. Returns the estimates, or the damage in *damage.
std::vector<Estimate> parse_rows(const std::string& text, const std::vector<ReferencePoint>& points,
                                 std::size_t first, std::size_t count, Damage* damage) {
    std::vector<Estimate> out;
    std::istringstream in(text);
    std::string line;
    auto bad = [&](const std::string& tag, const std::string& what) {
        *damage = {tag, "row " + std::to_string(out.size() + 1) + " " + what};
        return std::vector<Estimate>{};
    };
    while (std::getline(in, line)) {
        if (line.empty()) continue;
        std::vector<double> f;
        std::stringstream ss(line);
        std::string field;
        while (std::getline(ss, field, ',')) {
            char* end = nullptr;
            f.push_back(std::strtod(field.c_str(), &end));
            if (end == field.c_str() || *end != '\0') f.back() = std::nan("");
        }
        if (out.size() >= count) return bad("rows", "is one more than the " + std::to_string(count) + " expected");
        const std::size_t i = first + out.size();
        if (f.size() != 8 || format_number(f[0]) != format_number(points[i].visibility) ||
            format_number(f[1]) != format_number(points[i].n_dot_l) ||
            format_number(f[2]) != format_number(points[i].n_dot_v) ||
            format_number(f[3]) != format_number(points[i].roughness) ||
            format_number(f[4]) != format_number(points[i].relative_azimuth) ||
            format_number(f[5]) != format_number(points[i].weight))
            return bad("rows", "is not the definition's point");
        // The term is a ratio of a part of an integral to the whole: in [0, 1]; so is any useful error.
        if (!(f[6] >= 0 && f[6] <= 1) || !(f[7] >= 0 && f[7] <= 1))
            return bad("range", "has term " + format_number(f[6]) + " and std_error " + format_number(f[7]) +
                                    " (both must be in [0, 1])");
        out.push_back({f[6], f[7]});
    }
    if (out.size() != count) {
        *damage = {"rows", std::to_string(out.size()) + " rows, expected " + std::to_string(count)};
        return {};
    }
    return out;
}

// The finished file: the header, the rows, and the digest its sidecar recorded.
std::vector<Estimate> read_finished(const std::string& csv_path, const std::string& json_path,
                                    const ReferenceDefinition& def, const std::vector<ReferencePoint>& points,
                                    Damage* damage) {
    const std::string text = read_whole(csv_path);
    nlohmann::json meta;
    {
        std::ifstream in(json_path, std::ios::binary);
        if (in) meta = nlohmann::json::parse(in, nullptr, false);
    }
    if (!meta.is_object() || !meta.contains("csv_digest") || !meta["csv_digest"].is_string() ||
        meta.value("hash", std::string()) != def.hash()) {
        *damage = {"sidecar", json_path + " is missing, unreadable or not this definition's"};
        return {};
    }
    if (meta["csv_digest"].get<std::string>() != digest_text(text)) {
        *damage = {"digest", "its rows do not match the digest recorded in " + json_path + " when it was written"};
        return {};
    }
    const std::size_t header_end = text.find('\n');
    if (header_end == std::string::npos || text.compare(0, header_end, kCacheHeader) != 0) {
        *damage = {"header", "not a reference set (header)"};
        return {};
    }
    return parse_rows(text.substr(header_end + 1), points, 0, points.size(), damage);
}

// Moves a damaged cache file to DIR/rejected/ (kept as evidence, never read again) and says so.
std::string set_aside(const std::string& path, const std::string& tag) {
    const fs::path from(path);
    const fs::path dir = from.parent_path() / "rejected";
    std::error_code ec;
    fs::create_directories(dir, ec);
    fs::path to = dir / (from.filename().string() + "." + tag);
    for (int n = 1; fs::exists(to); ++n) to = dir / (from.filename().string() + "." + tag + "." + std::to_string(n));
    if (!ec) fs::rename(from, to, ec);
    return ec ? " (could not be moved aside: " + ec.message() + ")" : "; moved to " + to.string();
}

// An exclusive lock on DIR/reference-H.lock while a set is computed, so that two runs on one cache
// never compute (and then remove) the same chunks: the second waits, then finds the finished file.
// The advisory lock dies with its process, so a killed run leaves no stale lock; the empty file stays
// (removing it would let a third run lock a new file while a second still waits on the old one).
class CacheLock {
public:
    CacheLock(const std::string& path, const std::function<void(const std::string&)>& notice) {
        fd_ = platform::open_file(path, platform::read_write | platform::create, 0644);
        if (fd_ < 0) throw std::invalid_argument(path + ": cannot create the cache lock (" + std::strerror(errno) + ")");
        bool told = false;
        for (int held; (held = platform::try_lock_exclusive(fd_)) != 0;) {
            if (held < 0) {
                const int e = errno;
                platform::close_file(fd_);
                throw std::runtime_error(path + ": cannot lock (" + std::strerror(e) + ")");
            }
            if (!told && notice) notice("another run is computing this reference set (" + path + " is locked); waiting for it");
            told = true;
            try {
                throw_if_cancelled();
            } catch (...) {
                platform::close_file(fd_);
                throw;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
    }
    ~CacheLock() { platform::close_file(fd_); }
    CacheLock(const CacheLock&) = delete;
    CacheLock& operator=(const CacheLock&) = delete;

private:
    int fd_ = -1;
};

}  // namespace

schedule::CacheKey ReferenceDefinition::cache_key() const {
    schedule::CacheKey key("design-reference");
    key.constant("cache_format", kCacheFormat);
    for (const auto& [name, range] : {std::pair<const char*, const Interval*>{"visibility", &visibility},
                                      {"roughness", &roughness}, {"n_dot_v", &n_dot_v}, {"n_dot_l", &n_dot_l},
                                      {"azimuth_deg", &azimuth_deg}})
        key.add(name, {range->lo, range->hi});
    key.add("count", count).add("point_seed", point_seed);
    // The points themselves, not the file's name: renaming a file keeps its cache, editing it does not.
    std::string all;
    for (const auto& p : csv_points) all += row_text(p, Estimate{});
    key.add("csv_points", {csv_points.size(), hex16(fnv1a(all))});
    add_sampling_plan(key, plan);
    add_term_options(key, options);
    add_build(key, build);
    key.add("results", backend_label);
    return key;
}

const std::vector<std::string>& ReferenceDefinition::cache_key_exclusions() {
    static const std::vector<std::string> excluded = {
        "name: the set's label in reports",
        "points_csv: the file's path; its points are keyed (csv_points)",
    };
    return excluded;
}

std::string ReferenceDefinition::canonical_text() const { return cache_key().canonical_text(); }

std::string ReferenceDefinition::hash() const { return cache_key().hash(); }

std::vector<ReferencePoint> read_reference_points_csv(const std::string& path) {
    const NumericCsv csv = read_numeric_csv(path, kPointColumns);
    std::vector<ReferencePoint> points;
    double total_weight = 0;
    for (std::size_t i = 0; i < csv.rows.size(); ++i) {
        const auto& r = csv.rows[i];
        auto check = [&](std::size_t column, bool ok, const std::string& range) {
            if (!ok)
                throw CsvError(path + ":" + std::to_string(csv.lines[i]) + ": column " + kPointColumns[column] +
                               ": " + format_number(r[column]) + " outside " + range);
        };
        check(0, r[0] >= 0 && r[0] <= 1, "[0, 1]");
        check(1, r[1] >= -1 && r[1] <= 1, "[-1, 1]");
        check(2, r[2] > 0 && r[2] <= 1, "(0, 1]");
        check(3, r[3] > 0 && r[3] <= 1, "(0, 1]");
        check(4, r[4] >= 0 && r[4] <= 180, "[0, 180] degrees");
        check(5, r[5] >= 0, "[0, inf)");
        points.push_back({r[0], r[1], r[2], r[3], r[4] * kPi / 180.0, r[5]});
        total_weight += r[5] * std::max(r[1], 0.0);
    }
    if (points.empty()) throw CsvError(path + ": no points");
    if (!(total_weight > 0)) throw CsvError(path + ": every point has weight x NdotL = 0");
    return points;
}

ReferenceDefinition parse_reference_spec(const std::string& text, const std::string& source, const std::string& base_dir) {
    toml::table root;
    try {
        root = toml::parse(text, source);
    } catch (const toml::parse_error& e) {
        throw std::invalid_argument(source + ":" + std::to_string(e.source().begin.line) + ": " +
                                    std::string(e.description()));
    }
    reject_unknown(source, root, "", {"name", "points", "sampling"});
    // References need accuracy: the exact method (1e-10 at ~10 us a point per core) is the default; the
    // sampled one needs 65536 samples (~45 us a point per core) for ~5e-4.
    ReferenceDefinition def;
    def.plan.method = Method::exact;
    if (const toml::node* n = root.get("name")) {
        if (!n->is_string() || n->as_string()->get().empty()) fail(source, "name", "must be a non-empty string");
        def.name = n->as_string()->get();
    } else {
        def.name = fs::path(source).stem().string();
    }
    const toml::node* points = root.get("points");
    if (!points || !points->is_table()) fail(source, "points", "missing table [points]");
    const toml::table& pt = *points->as_table();
    reject_unknown(source, pt, "points.",
                   {"count", "seed", "visibility", "roughness", "n_dot_v", "n_dot_l", "relative_azimuth_deg", "csv"});
    if (const toml::node* csv = pt.get("csv")) {
        for (const char* k : {"count", "seed", "visibility", "roughness", "n_dot_v", "n_dot_l", "relative_azimuth_deg"})
            if (pt.get(k)) fail(source, std::string("points.") + k, "not allowed with points.csv (the file gives the points)");
        if (!csv->is_string()) fail(source, "points.csv", "must be a file name");
        const fs::path p(csv->as_string()->get());
        def.points_csv = (p.is_absolute() ? p : fs::path(base_dir) / p).string();
        def.csv_points = read_reference_points_csv(def.points_csv);
    } else {
        if (const toml::node* n = pt.get("count")) def.count = positive_integer(source, *n, "points.count", 1u << 24);
        if (const toml::node* n = pt.get("seed")) {
            if (!n->is_integer() || n->as_integer()->get() < 0) fail(source, "points.seed", "must be an integer >= 0");
            def.point_seed = std::uint64_t(n->as_integer()->get());
        }
        if (const toml::node* n = pt.get("visibility")) def.visibility = interval(source, *n, "points.visibility", 0, 1);
        if (const toml::node* n = pt.get("roughness")) def.roughness = interval(source, *n, "points.roughness", 0.01, 1);
        if (const toml::node* n = pt.get("n_dot_v")) def.n_dot_v = interval(source, *n, "points.n_dot_v", 0.001, 1);
        if (const toml::node* n = pt.get("n_dot_l")) def.n_dot_l = interval(source, *n, "points.n_dot_l", 0, 1);
        if (const toml::node* n = pt.get("relative_azimuth_deg"))
            def.azimuth_deg = interval(source, *n, "points.relative_azimuth_deg", 0, 180);
    }
    if (const toml::node* s = root.get("sampling")) {
        if (!s->is_table()) fail(source, "sampling", "must be a table [sampling]");
        const toml::table& st = *s->as_table();
        reject_unknown(source, st, "sampling.", {"samples", "replicates", "seed", "ao_weighting", "form", "method", "tolerance"});
        if (const toml::node* n = st.get("samples")) def.plan.samples = positive_integer(source, *n, "sampling.samples", 1ull << 32);
        if (const toml::node* n = st.get("replicates"))
            def.plan.replicates = std::uint32_t(positive_integer(source, *n, "sampling.replicates", 1024));
        if (def.plan.replicates < 2) fail(source, "sampling.replicates", "must be at least 2 (the standard error needs two)");
        if (const toml::node* n = st.get("seed")) {
            if (!n->is_integer() || n->as_integer()->get() < 0) fail(source, "sampling.seed", "must be an integer >= 0");
            def.plan.seed = std::uint64_t(n->as_integer()->get());
        }
        if (const toml::node* n = st.get("method")) {
            const auto text = n->value<std::string>();
            if (!text || (*text != "exact" && *text != "sampled"))
                fail(source, "sampling.method", "must be \"exact\" or \"sampled\"");
            def.plan.method = parse_method(*text);
        }
        if (const toml::node* n = st.get("tolerance")) {
            const auto value = n->value<double>();
            if (!value || !(*value >= exact_term::kMinTolerance && *value <= 0.1))
                fail(source, "sampling.tolerance", "must be a number in [1e-13, 0.1] (the exact method's estimated error)");
            if (def.plan.method != Method::exact)
                fail(source, "sampling.tolerance", "applies to the exact method; a sampled reference takes samples");
            def.plan.tolerance = *value;
        }
        try {
            if (const toml::node* n = st.get("ao_weighting"); n && n->is_string())
                def.options.ao_weighting = parse_ao_weighting(n->as_string()->get());
            else if (n) fail(source, "sampling.ao_weighting", "must be \"cosine\" or \"uniform\"");
            if (const toml::node* n = st.get("form"); n && n->is_string()) def.options.form = parse_form(n->as_string()->get());
            else if (n) fail(source, "sampling.form", "must be \"height-correlated\" or \"uncorrelated\"");
        } catch (const std::invalid_argument& e) {
            if (std::string(e.what()).rfind(source, 0) == 0) throw;
            throw std::invalid_argument(source + ": sampling: " + e.what());
        }
    }
    // Samples a power-of-two multiple (at least 16) of the replicates (the Sobol nets), as the CLI's
    // plan() rounds.
    def.plan.samples = round_up_samples(def.plan.samples, def.plan.replicates);
    return def;
}

ReferenceDefinition parse_reference_spec_file(const std::string& path) {
    const std::string text = read_input_file(path, kMaxSpecBytes, "reference spec");
    return parse_reference_spec(text, path, fs::path(path).parent_path().string().empty()
                                                ? std::string(".")
                                                : fs::path(path).parent_path().string());
}

std::vector<ReferencePoint> reference_points(const ReferenceDefinition& def) {
    if (!def.points_csv.empty()) return def.csv_points;
    std::vector<ReferencePoint> out(def.count);
    static const unsigned kBases[5] = {2, 3, 5, 7, 11};
    for (std::uint64_t i = 0; i < def.count; ++i) {
        double u[5];
        for (unsigned d = 0; d < 5; ++d) {
            u[d] = radical_inverse(i + 1, kBases[d]) + seed_shift(def.point_seed, d);
            u[d] -= std::floor(u[d]);
        }
        auto at = [](const Interval& r, double t) { return r.lo + (r.hi - r.lo) * t; };
        ReferencePoint& p = out[i];
        p.visibility = at(def.visibility, u[0]);
        p.roughness = at(def.roughness, u[1]);
        p.n_dot_v = std::max(at(def.n_dot_v, u[2]), 1e-3);
        // NdotL in (lo, hi]: 1 - u is in (0, 1].
        p.n_dot_l = at(def.n_dot_l, 1.0 - u[3]);
        p.relative_azimuth = at(def.azimuth_deg, u[4]) * kPi / 180.0;
        p.weight = 1;
    }
    return out;
}

Query query_of(const ReferencePoint& p) {
    Query q;
    q.visibility = p.visibility;
    q.alpha_x = q.alpha_y = std::max(p.roughness * p.roughness, 1e-6);
    const double sin_v = std::sqrt(std::max(0.0, 1.0 - p.n_dot_v * p.n_dot_v));
    const double sin_l = std::sqrt(std::max(0.0, 1.0 - p.n_dot_l * p.n_dot_l));
    q.wi = {sin_v, 0, p.n_dot_v};
    q.wo = {sin_l * std::cos(p.relative_azimuth), sin_l * std::sin(p.relative_azimuth), p.n_dot_l};
    return q;
}

std::string cache_file(const ReferenceDefinition& def, const std::string& dir) {
    return (fs::path(dir) / ("reference-" + def.hash() + ".csv")).string();
}

void check_plan(const ReferenceDefinition& def) {
    const SamplingPlan& p = def.plan;
    if (p.method == Method::exact) {
        try {
            exact_term::validate_tolerance(p.tolerance > 0 ? p.tolerance : exact::kDefaultTolerance);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("reference set '" + def.name + "': " + e.what());
        }
        return;  // no point set: the sampling fields are unused
    }
    const std::uint64_t per = p.replicates ? p.samples / p.replicates : 0;
    // What the point set accepts (sampling/point_set.hpp), and two replicates for a standard error.
    if (p.replicates < 2 || p.replicates > 1024 || p.samples % p.replicates != 0 || per < 16 || per > (1ull << 28) ||
        (per & (per - 1)) != 0)
        throw std::invalid_argument("reference set '" + def.name + "': " + std::to_string(p.samples) + " samples in " +
                                    std::to_string(p.replicates) +
                                    " replicates; needs 2 to 1024 replicates of a power of two in [16, 2^28] points each");
}

ReferenceSet load_or_compute(const ReferenceDefinition& def, const CacheConfig& config, CacheReport* report) {
    const auto start = std::chrono::steady_clock::now();
    // Everything about the definition is checked before any file or folder is made.
    check_plan(def);
    CacheReport local;
    CacheReport& rep = report ? *report : local;
    ReferenceSet set;
    set.definition = def;
    set.points = reference_points(def);
    set.file = cache_file(def, config.dir);
    const std::string json_file = fs::path(set.file).replace_extension(".json").string();
    const std::size_t n = set.points.size();
    auto finish = [&]() {
        ErrorStats std_errors;  // the values' estimated errors, summarised as every error is
        for (const auto& e : set.values) std_errors.add(e.std_error);
        set.max_std_error = std_errors.max_abs();
        set.rms_std_error = std_errors.rms();
        rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return set;
    };
    auto warn = [&](const std::string& w) {
        rep.warnings.push_back(w);
        if (config.warn) config.warn(w);
    };
    // The finished file, trusted only when its digest and every row hold; else it is set aside (with
    // its sidecar) and the set computed again.
    auto try_finished = [&]() {
        if (!fs::exists(set.file)) return false;
        Damage damage;
        set.values = read_finished(set.file, json_file, def, set.points, &damage);
        if (damage.tag.empty()) return true;
        std::string moved = set_aside(set.file, damage.tag);
        if (fs::exists(json_file)) set_aside(json_file, damage.tag);
        warn(set.file + ": " + damage.what + moved + "; computed again");
        set.values.clear();
        return false;
    };
    const bool rank0 = !config.transport || config.transport->coordinator();
    const bool sharded = config.shard.count > 1;
    if (config.merge && (sharded || config.transport))
        throw std::invalid_argument("a merge of the reference set's shards takes neither a shard nor an MPI world");
    // Rank 0 of an MPI world that has nothing to hand out still runs the exchange, so the ranks stop.
    auto release_ranks = [&] {
        if (config.transport) config.transport->coordinate({}, [](std::uint64_t, const std::string&) {}, nullptr);
    };
    if (rank0 && try_finished()) {
        rep.from_cache = true;
        release_ranks();
        return finish();
    }
    std::error_code ec;
    // The finished set's two outputs, checked before the long computation (a shard writes neither).
    std::optional<OutputSet> outputs;
    std::size_t csv_out = 0, json_out = 0;
    std::optional<CacheLock> lock;
    if (rank0) {
        fs::create_directories(config.dir, ec);
        if (ec) throw std::invalid_argument(config.dir + ": cannot create the cache directory (" + ec.message() + ")");
        // Shards share the chunk folder (their items are disjoint) and write no finished file: no lock.
        if (!sharded) {
            outputs.emplace();
            csv_out = outputs->add(set.file);
            json_out = outputs->add(json_file);
            lock.emplace(fs::path(set.file).replace_extension(".lock").string(), config.warn);
            // Another run may have finished the set while this one waited for the lock.
            if (try_finished()) {
                rep.from_cache = true;
                release_ranks();
                return finish();
            }
        }
    }
    TermBackend* backend = config.backend;
    auto need_backend = [&]() -> TermBackend& {
        if (!backend && config.open_backend) backend = config.open_backend();
        if (!backend) throw std::runtime_error(set.file + ": the reference set has to be computed and no backend was given");
        return *backend;
    };
    const std::string chunk_dir = fs::path(set.file).replace_extension(".chunks").string();
    rep.chunk_folder = chunk_dir;
    if (rank0) {
        fs::create_directories(chunk_dir, ec);
        if (ec) throw std::invalid_argument(chunk_dir + ": cannot create (" + ec.message() + ")");
        // The definition beside the chunks: a chunk folder is only ever of this hash, but say what it is.
        AtomicFile f((fs::path(chunk_dir) / "definition.txt").string());
        f.stream() << def.canonical_text();
        f.commit();
    }
    const std::size_t chunk = std::max<std::size_t>(1, config.chunk_points);
    const std::size_t chunks = (n + chunk - 1) / chunk;
    set.values.assign(n, Estimate{});
    // The chunks are the items of the chunk store (schedule/chunk_store.hpp) in the chunk folder: each
    // chunk-NNNNNN.csv the rows of its points, sealed by a last line with their digest.
    schedule::ChunkLayout layout;
    layout.folder = chunk_dir;
    layout.prefix = "chunk-";
    layout.suffix = ".csv";
    layout.digits = 6;
    layout.seal = schedule::ItemSeal::trailer;
    const schedule::StoreKey key{"design-reference", def.hash(), chunks};
    std::optional<schedule::ItemStore> store;
    schedule::ItemPlan plan;
    if (config.merge) {
        store.emplace(schedule::ItemStore::open_for_merge(chunk_dir, key, layout));
        plan.merge_only = true;
    } else if (rank0) {
        store.emplace(chunk_dir, key, config.shard, schedule::CommitPolicy{}, layout);
    }
    plan.store = store ? &*store : nullptr;
    plan.shard = config.shard;
    plan.transport = config.transport;
    plan.warn = warn;  // each message says what follows (schedule/distributed.cpp)
    auto first_of = [&](std::uint64_t c) { return std::size_t(c) * chunk; };
    auto count_of = [&](std::uint64_t c) { return std::min(chunk, n - first_of(c)); };
    std::size_t points_done = 0;
    schedule::ItemJob job;
    job.name = "reference set " + def.hash();
    job.items = chunks;
    job.check = [&](std::uint64_t c, const std::string& rows) -> std::string {
        Damage damage;
        parse_rows(rows, set.points, first_of(c), count_of(c), &damage);
        return damage.tag.empty() ? "" : damage.tag + ": " + damage.what;
    };
    job.accept = [&](std::uint64_t c, const std::string& rows) {
        Damage damage;
        const auto values = parse_rows(rows, set.points, first_of(c), count_of(c), &damage);
        if (!damage.tag.empty()) throw std::runtime_error("chunk " + std::to_string(c) + " of " + job.name + ": " + damage.what);
        std::copy(values.begin(), values.end(), set.values.begin() + std::ptrdiff_t(first_of(c)));
        points_done += count_of(c);
        if (config.progress) config.progress(points_done, n);
    };
    std::size_t computed = 0;
    job.compute = [&](std::uint64_t c) {
        if (config.max_chunks && computed >= config.max_chunks)
            throw IncompleteReference("reference set " + def.hash() + ": stopped after " + std::to_string(computed) +
                                      " chunks (resumable)");
        throw_if_cancelled();
        TermBackend& b = need_backend();
        const std::size_t first = first_of(c), count = count_of(c);
        std::vector<Query> queries;
        for (std::size_t i = first; i < first + count; ++i) queries.push_back(query_of(set.points[i]));
        const auto values = evaluate(b, queries, def.options, def.plan, nullptr, [&](std::size_t d, std::size_t) {
            if (config.progress) config.progress(points_done + d, n);
        });
        std::string rows;
        for (std::size_t i = 0; i < count; ++i) rows += row_text(set.points[first + i], values[i]);
        ++computed;
        return rows;
    };
    const schedule::ItemRunReport run = schedule::run_item_job(job, plan, {def.backend_label});
    rep.chunks_found = run.loaded;
    rep.chunks_computed = run.run.done;
    if (!run.complete) {
        rep.complete = false;
        rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return set;
    }
    // Both outputs appear together or not at all.
    std::string text = kCacheHeader + "\n";
    for (std::size_t i = 0; i < n; ++i) text += row_text(set.points[i], set.values[i]);
    outputs->stream(csv_out) << text;
    ReferenceSet result = finish();
    nlohmann::json meta = {{"program", "microshadow " MICROSHADOW_VERSION},
                           {"command_line", config.command_line},
                           {"name", def.name},
                           {"hash", def.hash()},
                           {"definition", def.canonical_text()},
                           {"points", n},
                           {"csv_digest", digest_text(text)},
                           {"max_std_error", result.max_std_error},
                           {"rms_std_error", result.rms_std_error},
                           {"seconds", rep.seconds}};
    if (!def.points_csv.empty()) meta["points_csv"] = json_safe(def.points_csv);
    // What decided the values (and what the std_error column means): the method with its parameters.
    meta["method"] = to_string(def.plan.method);
    if (def.plan.method == Method::exact) meta["exact"] = exact_provenance(def.plan);
    else
        meta["sampling"] = {{"samples", def.plan.samples},
                            {"replicates", def.plan.replicates},
                            {"seed", def.plan.seed},
                            {"sequence", to_string(def.plan.sequence)}};
    outputs->stream(json_out) << dump_json(meta, 2) << "\n";
    outputs->commit();
    // The finished file holds everything the chunks did. Only this run (holding the lock, or merging
    // shards that have all finished) writes into this folder now, so removing it takes no other run's chunks.
    store.reset();
    fs::remove_all(chunk_dir, ec);
    return result;
}

}  // namespace ms::design
