#include "schedule/distributed.hpp"

#include "core/digest.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/cancel.hpp"
#include "io/atomic_file.hpp"
#include "io/input_file.hpp"
#include "io/text.hpp"

namespace ms::schedule {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kManifestFormat = "microshadow-item-store/1";
constexpr const char* kItemMagic = "microshadow-item/1";
// An item's payload is at most a LUT slice or a sweep chunk; anything far larger is a damaged header.
constexpr std::uint64_t kMaxItemBytes = std::uint64_t(1) << 32;

std::string item_path(const std::string& dir, std::uint64_t id) {
    char name[48];
    std::snprintf(name, sizeof name, "item-%010" PRIu64 ".bin", id);
    return (fs::path(dir) / "items" / name).string();
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
                  " (the options, the spec or the kind of device differ)";
    else if (m["items"] != key.items)
        differs = "it has " + std::to_string(m["items"].get<std::uint64_t>()) + " items, this job " + std::to_string(key.items);
    if (!differs.empty())
        throw std::invalid_argument(path + ": the chunk store holds another job (" + differs +
                                    "); use another store folder or remove this one");
}

// What ran the items, as the jobs' provenance names it: the devices, or the oracle.
std::vector<std::string> place_labels(const Scheduler& scheduler) {
    return scheduler.is_oracle() ? std::vector<std::string>{scheduler.name()} : scheduler.device_labels();
}

}  // namespace

Shard parse_shard(const std::string& text, const std::string& option) {
    auto bad = [&] { return std::invalid_argument(option + ": expected I/N with 0 <= I < N, got '" + text + "'"); };
    const auto slash = text.find('/');
    if (slash == std::string::npos || slash == 0 || slash + 1 == text.size()) throw bad();
    for (std::size_t i = 0; i < text.size(); ++i)
        if (i != slash && (text[i] < '0' || text[i] > '9')) throw bad();
    if (slash > 7 || text.size() - slash - 1 > 7) throw bad();
    const unsigned long i = std::stoul(text.substr(0, slash)), n = std::stoul(text.substr(slash + 1));
    if (n == 0 || i >= n || n > 1000000) throw bad();
    return {std::uint32_t(i), std::uint32_t(n)};
}

std::optional<Shard> slurm_array_shard(const std::function<const char*(const char*)>& lookup) {
    const char* id = lookup("SLURM_ARRAY_TASK_ID");
    if (!id || !*id) return std::nullopt;
    auto number = [&](const char* name, unsigned long fallback) -> unsigned long {
        const char* v = lookup(name);
        if (!v || !*v) return fallback;
        const std::string s(v);
        if (s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
            throw std::invalid_argument(std::string(name) + "='" + s + "' is not a task number");
        return std::stoul(s);
    };
    const unsigned long task = number("SLURM_ARRAY_TASK_ID", 0);
    const char* count_text = lookup("SLURM_ARRAY_TASK_COUNT");
    if (!count_text || !*count_text)
        throw std::invalid_argument("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not; give --shard I/N");
    const unsigned long count = number("SLURM_ARRAY_TASK_COUNT", 0), min = number("SLURM_ARRAY_TASK_MIN", 0),
                        step = number("SLURM_ARRAY_TASK_STEP", 1);
    // Slurm sets _MAX too; where it is absent (a hand-made environment) only the count is checked.
    const bool has_max = lookup("SLURM_ARRAY_TASK_MAX") && *lookup("SLURM_ARRAY_TASK_MAX");
    const unsigned long max = number("SLURM_ARRAY_TASK_MAX", 0);
    // Only an array of evenly spaced ids maps to I/N: (max - min) / step + 1 tasks, this one the
    // (task - min) / step-th.
    if (step == 0 || task < min || (task - min) % step != 0 || (has_max && (max < min || (max - min) / step + 1 != count)) ||
        (task - min) / step >= count || count == 0 || count > 1000000)
        throw std::invalid_argument("SLURM_ARRAY_TASK_ID " + std::to_string(task) + " of an array of " + std::to_string(count) +
                                    " tasks (min " + std::to_string(min) + ", max " + std::to_string(max) + ", step " +
                                    std::to_string(step) + ") is not one of evenly spaced task ids; submit --array=0-" +
                                    std::to_string(count ? count - 1 : 0) + " or give --shard I/N");
    return Shard{std::uint32_t((task - min) / step), std::uint32_t(count)};
}

ItemStore::ItemStore(std::string dir, StoreKey key, Shard shard) : dir_(std::move(dir)), key_(std::move(key)), shard_(shard) {
    if (shard_.count == 0 || shard_.index >= shard_.count) throw std::invalid_argument("chunk store: bad shard " + shard_text(shard_));
    std::error_code ec;
    if (fs::exists(dir_, ec) && !fs::is_directory(dir_, ec))
        throw std::invalid_argument(dir_ + ": the chunk store must be a folder, and this is not one");
    for (const auto& [path, m] : read_manifests(dir_)) {
        check_same_job(path, m, key_);
        if (m["shard_count"] != shard_.count)
            throw std::invalid_argument(path + ": the chunk store splits this job into " +
                                        std::to_string(m["shard_count"].get<std::uint64_t>()) + " shards, not " +
                                        std::to_string(shard_.count) + " (--shard " + shard_text(shard_) +
                                        "); use the same N, or another store folder");
    }
    fs::create_directories(fs::path(dir_) / "items");
}

ItemStore ItemStore::open_for_merge(std::string dir, StoreKey key) {
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

std::optional<std::string> ItemStore::load(std::uint64_t id, std::string* warning) const {
    const std::string path = item_path(dir_, id);
    std::error_code ec;
    if (!fs::exists(path, ec)) return std::nullopt;
    std::string problem, payload;
    try {
        const std::string text = read_input_file(path, kMaxItemBytes + 4096, "chunk store item");
        // Header: five lines (magic, spec hash, id, payload bytes, payload digest), then the payload.
        std::istringstream in(text);
        std::string magic, hash, id_text, size_text, digest;
        std::getline(in, magic) && std::getline(in, hash) && std::getline(in, id_text) && std::getline(in, size_text) &&
            std::getline(in, digest);
        const std::size_t header = magic.size() + hash.size() + id_text.size() + size_text.size() + digest.size() + 5;
        if (magic != kItemMagic) problem = "header: not a chunk store item";
        else if (hash != key_.spec_hash) problem = "spec: written for spec hash " + hash + ", not " + key_.spec_hash;
        else if (id_text != std::to_string(id)) problem = "index: holds item '" + id_text + "'";
        else if (header > text.size() || size_text != std::to_string(text.size() - header))
            problem = "size: " + std::to_string(text.size() < header ? 0 : text.size() - header) + " payload bytes, the header says " + size_text;
        else {
            payload = text.substr(header);
            if (digest != hex16(fnv1a(payload))) problem = "digest: its payload's digest is " + hex16(fnv1a(payload)) + ", not " + digest;
        }
    } catch (const std::exception& e) {
        problem = std::string("read: ") + e.what();
    }
    if (problem.empty()) return payload;
    // Set it aside as evidence (never read again), and say so; the caller computes the item again.
    const fs::path aside = fs::path(dir_) / "items" / "rejected";
    fs::create_directories(aside, ec);
    const std::string tag = problem.substr(0, problem.find(':'));
    fs::path to = aside / (fs::path(path).filename().string() + "." + tag);
    for (int n = 1; fs::exists(to, ec); ++n) to = aside / (fs::path(path).filename().string() + "." + tag + "." + std::to_string(n));
    fs::rename(path, to, ec);
    if (warning) *warning = path + ": " + problem + (ec ? " (could not be moved aside: " + ec.message() + ")" : "; moved to " + to.string());
    return std::nullopt;
}

void ItemStore::save(std::uint64_t id, const std::string& payload) const {
    AtomicFile f(item_path(dir_, id), true);
    f.stream() << kItemMagic << "\n" << key_.spec_hash << "\n" << id << "\n" << payload.size() << "\n" << hex16(fnv1a(payload)) << "\n" << payload;
    f.commit();
}

void ItemStore::write_manifest(bool complete, const std::vector<std::string>& devices, std::uint64_t rerun) const {
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

ItemRunReport run_items(Scheduler& scheduler, Integrand& integrand, const ItemPlan& plan, const RunCallbacks& callbacks) {
    ItemRunReport report;
    const std::uint64_t total = integrand.work_items();
    if ((plan.store || plan.transport) && !integrand.distributable())
        throw std::invalid_argument(integrand.name() + " cannot be split into shards or MPI ranks");
    auto warn = [&](const std::string& w) {
        if (plan.warn && !w.empty()) plan.warn(w);
    };

    if (plan.merge_only) {
        if (!plan.store) throw std::logic_error("run_items: a merge needs a chunk store");
        const ItemStore& store = *plan.store;
        const std::uint32_t count = store.merge_shard_count();
        // Every item must be there; a missing one names its shard, to rerun before merging again.
        std::map<std::uint32_t, std::pair<std::uint64_t, std::uint64_t>> missing;  // shard -> (first id, how many)
        for (std::uint64_t id = 0; id < total; ++id) {
            throw_if_cancelled();
            std::string warning;
            std::optional<std::string> payload = store.load(id, &warning);
            warn(warning);
            if (!payload) {
                auto& m = missing.try_emplace(std::uint32_t(id % count), id, 0).first->second;
                ++m.second;
                continue;
            }
            if (missing.empty()) integrand.load_item(id, *payload);
            ++report.loaded;
        }
        if (!missing.empty()) {
            std::string msg = store.dir() + ": cannot merge, items are missing:";
            for (const auto& [s, m] : missing)
                msg += " shard " + std::to_string(s) + "/" + std::to_string(count) + " lacks " + std::to_string(m.second) +
                       " item(s) (the first is " + std::to_string(m.first) + ");";
            throw std::invalid_argument(msg + " rerun those shards (they resume), then merge; nothing was written");
        }
        report.complete = true;
        report.rerun = store.recorded_reruns();
        report.devices = store.recorded_devices();
        return report;
    }

    // Items already finished (a rerun after a kill, or an MPI job resumed): load them instead of computing.
    const Shard shard = plan.transport ? Shard{} : plan.shard;
    std::vector<char> done(total, 0);
    const bool coordinating = !plan.transport || plan.transport->coordinator();
    if (plan.store && coordinating) {
        for (std::uint64_t id = shard.index; id < total; id += shard.count) {
            throw_if_cancelled();
            std::string warning;
            if (std::optional<std::string> payload = plan.store->load(id, &warning)) {
                integrand.load_item(id, *payload);
                done[id] = 1;
                ++report.loaded;
            }
            warn(warning);
        }
    }

    if (plan.transport && plan.transport->coordinator()) {
        std::deque<std::uint64_t> pending;
        for (std::uint64_t id = 0; id < total; ++id)
            if (!done[id]) pending.push_back(id);
        const std::uint64_t loaded = report.loaded;
        plan.transport->coordinate(
            std::move(pending),
            [&](std::uint64_t id, const std::string& payload) {
                if (id >= total || done[id]) throw std::runtime_error("MPI: a rank sent item " + std::to_string(id) + " twice or out of range");
                integrand.load_item(id, payload);
                done[id] = 1;
                if (plan.store) plan.store->save(id, payload);
                ++report.run.done;
            },
            [&](std::uint64_t d, std::uint64_t t) {
                if (callbacks.progress) callbacks.progress(loaded + d, loaded + t);
            });
        report.complete = true;
        return report;
    }
    if (plan.transport) {
        // A computing rank: items come from rank 0 one at a time, results go back as they finish.
        WorkSelection selection;
        selection.next_item = [&](std::uint64_t& id) { return plan.transport->next_item(id); };
        RunCallbacks cb;
        cb.on_done = [&](std::uint64_t id) { plan.transport->send_result(id, integrand.save_item(id)); };
        try {
            report.run = scheduler.run(integrand, selection, cb);
        } catch (const Cancelled&) {
            plan.transport->finish("cancelled");
            throw;
        } catch (const std::exception& e) {
            plan.transport->finish(e.what());
            throw;
        }
        plan.transport->finish("");
        report.rerun = report.run.rerun;
        return report;
    }

    WorkSelection selection;
    selection.shard_index = shard.index;
    selection.shard_count = shard.count;
    selection.already_done = [&](std::uint64_t id) { return done[id] != 0; };
    RunCallbacks cb = callbacks;
    if (plan.store) {
        // on_done runs one call at a time: each finished item reaches the store before the next is recorded.
        cb.on_done = [&](std::uint64_t id) {
            plan.store->save(id, integrand.save_item(id));
            if (callbacks.on_done) callbacks.on_done(id);
        };
        plan.store->write_manifest(false, place_labels(scheduler), 0);
    }
    const std::uint64_t loaded = report.loaded;
    if (callbacks.progress)
        cb.progress = [&](std::uint64_t d, std::uint64_t t) { callbacks.progress(loaded + d, loaded + t); };
    report.run = scheduler.run(integrand, selection, cb);
    report.rerun = report.run.rerun;
    if (plan.store) plan.store->write_manifest(true, place_labels(scheduler), report.rerun);
    report.complete = shard.count == 1;
    return report;
}

}  // namespace ms::schedule
