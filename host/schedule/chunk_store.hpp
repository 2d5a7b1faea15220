// The chunk store: how every resumable job keeps its finished work items on disk. One item is one file,
// written atomically (a temporary renamed over it, so a killed process leaves the whole item or none),
// checked by its digest before it is trusted again, and set aside (never read again) when damaged.
// Sweeps, design reference sets and the item store of bakes, scene bakes, representation bakes and
// designs all keep their items here; they differ only in where the files lie and how a file carries
// its digest (ItemSeal).
//
// Syncing is grouped: an item is renamed into place at once (a kill cannot lose or tear it), and the
// items written since the last sync reach the disk together, every CommitPolicy::items items or
// CommitPolicy::interval, and on commit(). A power loss can then lose at most the items of one group;
// each is found missing or damaged on resume and computed again. (One synced write per item cost
// ~20 ms on this project's machines: the limit of an MPI job's rank 0.)
//
// The item store (ItemStore) is a directory:
//   items/item-XXXXXXXXXX.bin        one finished item: a text header (format, spec hash, id, payload
//                                    size and FNV-1a digest) then the payload
//   items/rejected/                  items found damaged, set aside with the reason as a suffix
//   manifest.shard-I-of-N.json       what shard I of N is (job, version, spec hash, item count), whether
//                                    it finished, its devices and its reruns after device failures
// Every shard of a job writes into the same directory (its items are disjoint): a merge reads one folder.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace ms::schedule {

// What a file holds, recorded when it is written: its line count and FNV-1a 64 digest.
struct ItemDigest {
    std::uint64_t rows = 0, fnv1a = 0;
    bool operator==(const ItemDigest& o) const { return rows == o.rows && fnv1a == o.fnv1a; }
    bool operator!=(const ItemDigest& o) const { return !(*this == o); }
};
ItemDigest digest_of(const std::string& bytes);
// "rows N fnv1a64 HHHHHHHHHHHHHHHH": the trailer seal's line (after "# ").
std::string digest_text(const ItemDigest& d);

// How an item's file proves it came back as written.
enum class ItemSeal {
    header,    // a text header first (format, spec hash, id, payload size, digest): self-describing bytes
    trailer,   // a last line "# rows N fnv1a64 H" over the text before it (the file stays a readable CSV)
    recorded,  // the bare payload; the job records its digest elsewhere (a sweep's manifest)
};

struct ChunkLayout {
    std::string folder;                    // the items' folder (created when the first item is written)
    std::string prefix = "item-", suffix = ".bin";
    int digits = 10;                       // of the zero-padded id
    ItemSeal seal = ItemSeal::header;
    std::string spec_hash;                 // header seal: written in every item and checked on reading
    std::string rejected;                  // where damaged items go (default: folder/rejected)
};

// When the items written are synced to disk together.
struct CommitPolicy {
    std::uint32_t items = 64;                        // at the latest after this many items
    std::chrono::milliseconds interval{1000};        // or this long after the first unsynced one
    // false: write() never syncs; the job calls commit_if_due() where it records what is finished.
    bool automatic = true;
    static CommitPolicy every_item() { return {1, std::chrono::milliseconds(0)}; }
};

class ChunkFiles {
public:
    explicit ChunkFiles(ChunkLayout layout, CommitPolicy policy = {});
    ~ChunkFiles();  // syncs what is pending (errors are not reported here: call commit())
    ChunkFiles(const ChunkFiles&) = delete;
    ChunkFiles& operator=(const ChunkFiles&) = delete;

    const ChunkLayout& layout() const { return layout_; }
    std::string path(std::uint64_t id) const;
    // Writes item `id` atomically, sealed as the layout says, and returns the payload's digest. Safe to
    // call from several threads. Returns with committed = true when this write completed a group (then
    // every item written so far is on disk).
    ItemDigest write(std::uint64_t id, const std::string& payload, bool* committed = nullptr);
    // Syncs every item written since the last commit (and their folder). Throws std::runtime_error.
    void commit();
    // commit() when the policy says a group is due; true when it synced (or nothing was pending).
    bool commit_if_due();
    std::uint64_t pending() const;

    // Item `id`'s payload when a sound file holds it: nullopt when there is none, or when it is damaged
    // (then it is set aside and *warning names it, the reason and where it went). `check`: the job's own
    // check of the payload ("" or "tag: reason"; with the recorded seal, the digest it kept is checked there).
    std::optional<std::string> read(std::uint64_t id, std::string* warning = nullptr,
                                    const std::function<std::string(const std::string&)>& check = {}) const;
    // Moves a damaged file into the rejected folder under NAME.TAG (TAG: the reason up to its ':'), and
    // returns "; moved to PATH" (or why it could not be moved).
    std::string set_aside(const std::string& path, const std::string& reason) const;

private:
    void sync_pending_locked();
    bool due_locked() const;
    ChunkLayout layout_;
    CommitPolicy policy_;
    mutable std::mutex mutex_;
    std::vector<std::string> pending_;  // renamed into place, not yet synced
    std::chrono::steady_clock::time_point first_pending_{};
    bool folder_made_ = false;
};

// Removes temporaries a killed writer of this host left in `folder` (their process is gone).
void remove_stale_temporaries(const std::string& folder);

struct Shard {
    std::uint32_t index = 0, count = 1;  // this process runs the items id with id % count == index
};

// What identifies a job's items: results from stores of another job, spec, version or item count are
// never mixed.
struct StoreKey {
    std::string job;        // "bake", "sweep", ...
    std::string spec_hash;  // hash of everything that decides the items' bits (spec, backend kind, version)
    std::uint64_t items = 0;
};

class ItemStore {
public:
    // Opens (creating it if needed) the store in `dir` for `shard` of the job `key`. Throws
    // std::invalid_argument (bad input: nothing is written) when a manifest there belongs to another
    // job, spec, version or item count, or splits the job into another number of shards.
    // `layout`: where the items lie and how they are sealed (default, folder empty: items/item-*.bin with
    // the header seal; its spec hash is always the key's). A manifest of this job, version and spec whose
    // item count is not the key's is damaged: it is set aside (rejected/, as a damaged item is) and `warn`
    // told, and its shard counts as not run.
    ItemStore(std::string dir, StoreKey key, Shard shard, CommitPolicy policy = {}, ChunkLayout layout = {},
              const std::function<void(const std::string&)>& warn = {});
    // Opens an existing store to merge it: every manifest must be of this key and one shard count.
    // Throws std::invalid_argument when `dir` holds no manifest or mixes jobs or shard counts. Damaged
    // manifests are set aside as above.
    static ItemStore open_for_merge(std::string dir, StoreKey key, ChunkLayout layout = {},
                                    const std::function<void(const std::string&)>& warn = {});
    ItemStore(ItemStore&&) = default;

    const std::string& dir() const { return dir_; }
    const Shard& shard() const { return shard_; }
    const StoreKey& key() const { return key_; }
    // Item `id`'s payload when a sound file holds it; a damaged file is set aside, `warning` says so, and
    // nullopt is returned (the caller recomputes the item).
    std::optional<std::string> load(std::uint64_t id, std::string* warning = nullptr) const;
    // The same with the job's own check of the payload ("" or "tag: reason"; damaged: set aside).
    std::optional<std::string> load(std::uint64_t id, std::string* warning,
                                    const std::function<std::string(const std::string&)>& check) const;
    const ChunkFiles& files() const { return *files_; }
    // Writes item `id` atomically (synced with its group: commit()).
    void save(std::uint64_t id, const std::string& payload) const;
    // Syncs the items saved so far.
    void commit() const;
    // Writes this shard's manifest (atomically, after syncing every item saved). devices: the labels of
    // the places that ran it.
    void write_manifest(bool complete, const std::vector<std::string>& devices, std::uint64_t rerun) const;
    // Merge: the shard count the manifests agree on, and the shards that have no manifest or are not
    // complete (a shard that never ran or died).
    std::uint32_t merge_shard_count() const { return shard_.count; }
    std::vector<std::uint32_t> unfinished_shards() const;
    // Merge: summed reruns and the devices of every manifest, first seen first.
    std::uint64_t recorded_reruns() const;
    std::vector<std::string> recorded_devices() const;

private:
    ItemStore() = default;
    std::string dir_;
    StoreKey key_;
    Shard shard_;
    std::unique_ptr<ChunkFiles> files_;
};

}  // namespace ms::schedule
