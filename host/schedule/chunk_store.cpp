#include "schedule/chunk_store.hpp"


#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/digest.hpp"
#include "io/atomic_file.hpp"
#include "io/input_file.hpp"
#include "io/text.hpp"
#include "platform/files.hpp"
#include "platform/process.hpp"

namespace ms::schedule {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kManifestFormat = "microshadow-item-store/1";
constexpr const char* kItemMagic = "microshadow-item/1";
// An item's payload is at most a LUT slice or a sweep chunk; anything far larger is a damaged header.
constexpr std::uint64_t kMaxItemBytes = std::uint64_t(1) << 32;
constexpr const char* kTrailerPrefix = "# ";

std::string host_name() {
    // Only characters safe in a file name.
    std::string s = platform::host_name();
    for (char& c : s)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '.') c = '_';
    return s.empty() ? "host" : s;
}

// A temporary beside the item, named by host and process: the shards of one job may write into one
// shared folder from several nodes at once, so neither the name nor its clean-up may collide.
std::string temporary_of(const std::string& path) {
    const fs::path p(path);
    return (p.parent_path() / ("." + p.filename().string() + ".tmp." + host_name() + "." + std::to_string(platform::process_id()))).string();
}

void write_all(int fd, const std::string& bytes, const std::string& path) {
    std::size_t at = 0;
    while (at < bytes.size()) {
        const long long n = platform::write_some(fd, bytes.data() + at, bytes.size() - at);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
        at += std::size_t(n);
    }
}

void sync_path(const std::string& path, bool directory) {
    if (directory) {
        platform::sync_directory(path);  // best effort: some file systems refuse; its files were synced
        return;
    }
    if (platform::sync_path(path) != 0) throw std::runtime_error(path + ": cannot sync to disk (" + std::strerror(errno) + ")");
}

std::string manifest_name(const Shard& s) {
    return "manifest.shard-" + std::to_string(s.index) + "-of-" + std::to_string(s.count) + ".json";
}

std::string shard_text(const Shard& s) { return std::to_string(s.index) + "/" + std::to_string(s.count); }

// The store's manifests, each checked for shape so a damaged one is refused naming the file.
std::vector<std::pair<std::string, json>> read_manifests(const std::string& dir) {
    std::vector<std::pair<std::string, json>> out;
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) return out;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind("manifest.shard-", 0) != 0 || entry.path().extension() != ".json") continue;
        const std::string path = entry.path().string();
        json m;
        try {
            m = json::parse(read_input_file(path, 1 << 24, "manifest"));
        } catch (const json::exception& e) {
            throw std::invalid_argument(path + ": not a valid chunk store manifest (" + e.what() + ")");
        }
        auto bad = [&](const std::string& what) {
            return std::invalid_argument(path + ": not a valid chunk store manifest (" + what + ")");
        };
        if (!m.is_object() || m.value("format", "") != kManifestFormat) throw bad("format is not " + std::string(kManifestFormat));
        for (const char* key : {"job", "version", "spec_hash"})
            if (!m.contains(key) || !m[key].is_string()) throw bad(std::string("no ") + key + " string");
        for (const char* key : {"items", "shard_index", "shard_count", "rerun"})
            if (!m.contains(key) || !m[key].is_number_unsigned()) throw bad(std::string("no ") + key + " count");
        if (!m.contains("complete") || !m["complete"].is_boolean()) throw bad("complete is not true or false");
        if (!m.contains("devices") || !m["devices"].is_array()) throw bad("no devices list");
        for (const auto& d : m["devices"])
            if (!d.is_string()) throw bad("a device label is not a string");
        const std::uint64_t count = m["shard_count"], index = m["shard_index"];
        if (count == 0 || index >= count || count > 1000000) throw bad("shard_index is not below shard_count");
        out.emplace_back(path, std::move(m));
    }
    return out;
}

// The refusal when a manifest is of another job: which of job, version, spec and item count differ.
void check_same_job(const std::string& path, const json& m, const StoreKey& key) {
    std::string differs;
    if (m["job"] != key.job) differs = "it is a '" + m["job"].get<std::string>() + "' job, not '" + key.job + "'";
    else if (m["version"] != MICROSHADOW_VERSION)
        differs = "it was written by microshadow " + m["version"].get<std::string>() + ", this is " MICROSHADOW_VERSION;
    else if (m["spec_hash"] != key.spec_hash)
        differs = "its spec hash " + m["spec_hash"].get<std::string>() + " is not this job's " + key.spec_hash +
                  " (the options, the spec, the kind of device or the program's sources differ)";
    else if (m["items"] != key.items)
        differs = "it has " + std::to_string(m["items"].get<std::uint64_t>()) + " items, this job " + std::to_string(key.items);
    if (!differs.empty())
        throw std::invalid_argument(path + ": the chunk store holds another job (" + differs +
                                    "); use another store folder or remove this one");
}

// A manifest of this very job (job, version and spec hash agree) whose item count is not the job's is
// damaged, not another job's: the spec hash fixes the count. Refusing it failed every resume; it is set
// aside like a damaged item instead (its shard then counts as not run: the shard's items are read and
// checked again and its next run writes a new manifest), and `warn` says so.
void set_aside_damaged_manifests(const std::string& dir, const StoreKey& key, const ChunkFiles& files,
                                 const std::function<void(const std::string&)>& warn) {
    for (const auto& [path, m] : read_manifests(dir)) {
        if (m["job"] != key.job || m["version"] != MICROSHADOW_VERSION || m["spec_hash"] != key.spec_hash || m["items"] == key.items)
            continue;
        const std::string problem = "items: the manifest says " + std::to_string(m["items"].get<std::uint64_t>()) +
                                    " items where this job's spec has " + std::to_string(key.items);
        const std::string moved = files.set_aside(path, problem);
        // Nothing is computed again for it: the shard's items are read and checked as before.
        if (warn) warn(path + ": " + problem + moved + "; its shard's next run writes its manifest again");
    }
}

ChunkLayout item_store_layout(const std::string& dir, const std::string& spec_hash, ChunkLayout layout) {
    if (layout.folder.empty()) layout.folder = (fs::path(dir) / "items").string();
    layout.spec_hash = spec_hash;
    return layout;
}

}  // namespace

ItemDigest digest_of(const std::string& bytes) {
    ItemDigest d;
    for (char ch : bytes) d.rows += ch == '\n';
    d.fnv1a = fnv1a(bytes);
    return d;
}

std::string digest_text(const ItemDigest& d) { return "rows " + std::to_string(d.rows) + " fnv1a64 " + hex16(d.fnv1a); }

void remove_stale_temporaries(const std::string& folder) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) return;
    const std::string marker = ".tmp." + host_name() + ".";
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
        const std::string name = entry.path().filename().string();
        const std::size_t at = name.rfind(marker);
        if (name.empty() || name[0] != '.' || at == std::string::npos) continue;
        const std::string pid_text = name.substr(at + marker.size());
        if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos || pid_text.size() > 9) continue;
        const long pid = std::stol(pid_text);
        // A process of this host that no longer exists left it; a live one is still writing.
        if (pid != platform::process_id() && !platform::process_exists(pid)) fs::remove(entry.path(), ec);
    }
}

ChunkFiles::ChunkFiles(ChunkLayout layout, CommitPolicy policy) : layout_(std::move(layout)), policy_(policy) {
    if (layout_.rejected.empty()) layout_.rejected = (fs::path(layout_.folder) / "rejected").string();
    if (policy_.items == 0) policy_.items = 1;
}

ChunkFiles::~ChunkFiles() {
    try {
        commit();
    } catch (const std::exception&) {
        // Unsynced items are still in place (renamed): only a power loss could cost them, and a resume
        // checks every item it reads.
    }
}

std::string ChunkFiles::path(std::uint64_t id) const {
    char name[48];
    std::snprintf(name, sizeof name, "%0*" PRIu64, layout_.digits, id);
    return (fs::path(layout_.folder) / (layout_.prefix + name + layout_.suffix)).string();
}

ItemDigest ChunkFiles::write(std::uint64_t id, const std::string& payload, bool* committed) {
    const ItemDigest digest = digest_of(payload);
    std::string bytes;
    switch (layout_.seal) {
        case ItemSeal::header:
            bytes = std::string(kItemMagic) + "\n" + layout_.spec_hash + "\n" + std::to_string(id) + "\n" +
                    std::to_string(payload.size()) + "\n" + hex16(digest.fnv1a) + "\n" + payload;
            break;
        case ItemSeal::trailer: bytes = payload + kTrailerPrefix + digest_text(digest) + "\n"; break;
        case ItemSeal::recorded: bytes = payload; break;
    }
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!folder_made_) {
            fs::create_directories(layout_.folder);
            remove_stale_temporaries(layout_.folder);
            folder_made_ = true;
        }
    }
    // Written and renamed outside the lock: items of several places are written in parallel.
    const std::string target = path(id), temp = temporary_of(target);
    const int fd = platform::open_file(temp, platform::write_only | platform::create | platform::truncate, 0644);
    if (fd < 0) throw std::runtime_error(temp + ": cannot create (" + std::strerror(errno) + ")");
    try {
        write_all(fd, bytes, temp);
    } catch (...) {
        platform::close_file(fd);
        platform::remove_file(temp);
        throw;
    }
    if (platform::close_file(fd) != 0 || platform::replace_file(temp, target) != 0) {
        const int e = errno;
        platform::remove_file(temp);
        throw std::runtime_error(target + ": cannot write (" + std::strerror(e) + ")");
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_.empty()) first_pending_ = std::chrono::steady_clock::now();
    pending_.push_back(target);
    const bool due = policy_.automatic && due_locked();
    if (due) sync_pending_locked();
    if (committed) *committed = due;
    return digest;
}

void ChunkFiles::sync_pending_locked() {
    if (pending_.empty()) return;
    for (const auto& p : pending_) sync_path(p, false);
    // The renames themselves reach the disk with the folder.
    sync_path(layout_.folder, true);
    pending_.clear();
}

bool ChunkFiles::due_locked() const {
    return pending_.size() >= policy_.items || std::chrono::steady_clock::now() - first_pending_ >= policy_.interval;
}

bool ChunkFiles::commit_if_due() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_.empty()) return true;
    if (!due_locked()) return false;
    sync_pending_locked();
    return true;
}

void ChunkFiles::commit() {
    std::lock_guard<std::mutex> lock(mutex_);
    sync_pending_locked();
}

std::uint64_t ChunkFiles::pending() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pending_.size();
}

std::string ChunkFiles::set_aside(const std::string& path, const std::string& reason) const {
    std::error_code ec;
    const fs::path aside(layout_.rejected);
    fs::create_directories(aside, ec);
    const std::string tag = reason.substr(0, reason.find(':'));
    const std::string name = fs::path(path).filename().string();
    fs::path to = aside / (name + "." + tag);
    for (int n = 1; fs::exists(to, ec); ++n) to = aside / (name + "." + tag + "." + std::to_string(n));
    if (!ec) fs::rename(path, to, ec);
    return ec ? " (could not be moved aside: " + ec.message() + ")" : "; moved to " + to.string();
}

std::optional<std::string> ChunkFiles::read(std::uint64_t id, std::string* warning,
                                            const std::function<std::string(const std::string&)>& check) const {
    const std::string file = path(id);
    std::error_code ec;
    if (!fs::exists(file, ec)) return std::nullopt;
    std::string problem, payload;
    try {
        const std::string text = read_input_file(file, kMaxItemBytes + 4096, "chunk store item");
        switch (layout_.seal) {
            case ItemSeal::header: {
                // Five lines (magic, spec hash, id, payload bytes, payload digest), then the payload.
                std::istringstream in(text);
                std::string magic, hash, id_text, size_text, digest;
                std::getline(in, magic) && std::getline(in, hash) && std::getline(in, id_text) &&
                    std::getline(in, size_text) && std::getline(in, digest);
                const std::size_t header = magic.size() + hash.size() + id_text.size() + size_text.size() + digest.size() + 5;
                if (magic != kItemMagic) problem = "header: not a chunk store item";
                else if (hash != layout_.spec_hash) problem = "spec: written for spec hash " + hash + ", not " + layout_.spec_hash;
                else if (id_text != std::to_string(id)) problem = "index: holds item '" + id_text + "'";
                else if (header > text.size() || size_text != std::to_string(text.size() - header))
                    problem = "size: " + std::to_string(text.size() < header ? 0 : text.size() - header) +
                              " payload bytes, the header says " + size_text;
                else {
                    payload = text.substr(header);
                    if (digest != hex16(fnv1a(payload)))
                        problem = "digest: its payload's digest is " + hex16(fnv1a(payload)) + ", not " + digest;
                }
                break;
            }
            case ItemSeal::trailer: {
                const std::size_t last_line = text.size() >= 2 ? text.rfind('\n', text.size() - 2) : std::string::npos;
                const std::size_t rows_end = last_line == std::string::npos ? 0 : last_line + 1;
                payload = text.substr(0, rows_end);
                if (text.substr(rows_end) != kTrailerPrefix + digest_text(digest_of(payload)) + "\n")
                    problem = "digest: its rows do not match the digest line written with them";
                break;
            }
            case ItemSeal::recorded:
                payload = text;
                break;
        }
        if (problem.empty() && check) problem = check(payload);
    } catch (const std::exception& e) {
        problem = std::string("read: ") + e.what();
    }
    if (problem.empty()) return payload;
    // Set it aside as evidence (never read again), and say so; the caller computes the item again.
    const std::string moved = set_aside(file, problem);
    if (warning) *warning = file + ": " + problem + moved;
    return std::nullopt;
}

ItemStore::ItemStore(std::string dir, StoreKey key, Shard shard, CommitPolicy policy, ChunkLayout layout,
                     const std::function<void(const std::string&)>& warn)
    : dir_(std::move(dir)), key_(std::move(key)), shard_(shard) {
    if (shard_.count == 0 || shard_.index >= shard_.count) throw std::invalid_argument("chunk store: bad shard " + shard_text(shard_));
    std::error_code ec;
    if (fs::exists(dir_, ec) && !fs::is_directory(dir_, ec))
        throw std::invalid_argument(dir_ + ": the chunk store must be a folder, and this is not one");
    // The files object writes nothing until an item is saved: a refused store stays as it was.
    files_ = std::make_unique<ChunkFiles>(item_store_layout(dir_, key_.spec_hash, std::move(layout)), policy);
    set_aside_damaged_manifests(dir_, key_, *files_, warn);
    for (const auto& [path, m] : read_manifests(dir_)) {
        check_same_job(path, m, key_);
        if (m["shard_count"] != shard_.count)
            throw std::invalid_argument(path + ": the chunk store splits this job into " +
                                        std::to_string(m["shard_count"].get<std::uint64_t>()) + " shards, not " +
                                        std::to_string(shard_.count) + " (--shard " + shard_text(shard_) +
                                        "); run the other shards with the same N (then --merge), or use another store folder");
    }
    fs::create_directories(files_->layout().folder);
}

ItemStore ItemStore::open_for_merge(std::string dir, StoreKey key, ChunkLayout layout,
                                    const std::function<void(const std::string&)>& warn) {
    {
        const ChunkFiles files(item_store_layout(dir, key.spec_hash, layout));
        set_aside_damaged_manifests(dir, key, files, warn);
    }
    const auto manifests = read_manifests(dir);
    if (manifests.empty())
        throw std::invalid_argument(dir + ": no shard manifests (manifest.shard-I-of-N.json) in the chunk store; run the "
                                    "shards first");
    ItemStore store;
    store.dir_ = std::move(dir);
    store.key_ = std::move(key);
    store.shard_.count = manifests.front().second["shard_count"];
    for (const auto& [path, m] : manifests) {
        check_same_job(path, m, store.key_);
        const std::uint32_t count = m["shard_count"];
        if (count != store.shard_.count)
            throw std::invalid_argument(path + ": shards of " + std::to_string(count) + " and of " +
                                        std::to_string(store.shard_.count) + " in one chunk store; merge one split");
    }
    store.files_ = std::make_unique<ChunkFiles>(item_store_layout(store.dir_, store.key_.spec_hash, std::move(layout)));
    return store;
}

std::vector<std::uint32_t> ItemStore::unfinished_shards() const {
    std::set<std::uint32_t> finished;
    for (const auto& [path, m] : read_manifests(dir_))
        if (m["complete"].get<bool>() && m["shard_count"] == shard_.count) finished.insert(m["shard_index"].get<std::uint32_t>());
    std::vector<std::uint32_t> out;
    for (std::uint32_t i = 0; i < shard_.count; ++i)
        if (!finished.count(i)) out.push_back(i);
    return out;
}

std::uint64_t ItemStore::recorded_reruns() const {
    std::uint64_t sum = 0;
    for (const auto& [path, m] : read_manifests(dir_)) sum += m["rerun"].get<std::uint64_t>();
    return sum;
}

std::vector<std::string> ItemStore::recorded_devices() const {
    // Manifests in shard order, so the list does not depend on the directory's order.
    std::map<std::uint64_t, std::vector<std::string>> by_shard;
    for (const auto& [path, m] : read_manifests(dir_)) by_shard[m["shard_index"]] = m["devices"].get<std::vector<std::string>>();
    std::vector<std::string> out;
    for (const auto& [i, labels] : by_shard)
        for (const auto& l : labels)
            if (std::find(out.begin(), out.end(), l) == out.end()) out.push_back(l);
    return out;
}

std::optional<std::string> ItemStore::load(std::uint64_t id, std::string* warning) const { return files_->read(id, warning); }

std::optional<std::string> ItemStore::load(std::uint64_t id, std::string* warning,
                                           const std::function<std::string(const std::string&)>& check) const {
    return files_->read(id, warning, check);
}

void ItemStore::save(std::uint64_t id, const std::string& payload) const { files_->write(id, payload); }

void ItemStore::commit() const { files_->commit(); }

void ItemStore::write_manifest(bool complete, const std::vector<std::string>& devices, std::uint64_t rerun) const {
    // What the manifest says is finished must be on disk before it says so.
    files_->commit();
    json devices_json = json::array();
    for (const auto& d : devices) devices_json.push_back(json_safe(d));
    const json m = {{"format", kManifestFormat}, {"job", key_.job},           {"version", MICROSHADOW_VERSION},
                    {"spec_hash", key_.spec_hash}, {"items", key_.items},     {"shard_index", shard_.index},
                    {"shard_count", shard_.count}, {"complete", complete},    {"devices", devices_json},
                    {"rerun", rerun}};
    AtomicFile f((fs::path(dir_) / manifest_name(shard_)).string());
    f.stream() << dump_json(m, 1) << "\n";
    f.commit();
}

}  // namespace ms::schedule
