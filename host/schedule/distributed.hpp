// Running one job's work items on many processes: shards (tasks of a Slurm array, or any N processes
// given --shard I/N), resumable through a chunk store of finished items, merged into the outputs of one
// process; or the ranks of an MPI world, where rank 0 hands items out and gathers them.
//
// Everything rests on the integrand's contract (integrand.hpp): an item's result depends on the job's
// spec and the item's id alone, and save_item/load_item carry it between processes bit for bit. So the
// same items, however they were split, run or rerun, assemble into the same bytes.
//
// The chunk store (ItemStore) is a directory:
//   items/item-XXXXXXXXXX.bin        one finished item: a text header (format, spec hash, id, payload
//                                    size and FNV-1a digest) then the payload; written atomically, so a
//                                    killed process leaves either the whole item or nothing
//   items/rejected/                  items found damaged, set aside (never read again) and recomputed
//   manifest.shard-I-of-N.json       what shard I of N is (job, version, spec hash, item count), whether
//                                    it finished, its devices and its reruns after device failures
// Every shard of a job writes into the same directory (its items are disjoint): a merge reads one folder.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "schedule/scheduler.hpp"

namespace ms::schedule {

struct Shard {
    std::uint32_t index = 0, count = 1;  // this process runs the items id with id % count == index
};
// "I/N" with 0 <= I < N <= 1000000; throws std::invalid_argument naming `option` and the text.
Shard parse_shard(const std::string& text, const std::string& option = "--shard");
// The shard of a Slurm array task (SLURM_ARRAY_TASK_ID, _MIN, _STEP, _COUNT from `lookup`, normally
// getenv): nullopt outside an array; std::invalid_argument when the variables do not describe a task
// of an array of consecutive ids (e.g. --array=0,3,7 or a %-throttle gives no I/N).
std::optional<Shard> slurm_array_shard(const std::function<const char*(const char*)>& lookup);

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
    ItemStore(std::string dir, StoreKey key, Shard shard);
    // Opens an existing store to merge it: every manifest must be of this key and one shard count.
    // Throws std::invalid_argument when `dir` holds no manifest or mixes jobs or shard counts.
    static ItemStore open_for_merge(std::string dir, StoreKey key);

    const std::string& dir() const { return dir_; }
    const Shard& shard() const { return shard_; }
    // Item `id`'s payload when a sound file holds it; a damaged file is set aside, `warning` says so, and
    // nullopt is returned (the caller recomputes the item).
    std::optional<std::string> load(std::uint64_t id, std::string* warning = nullptr) const;
    // Writes item `id` atomically.
    void save(std::uint64_t id, const std::string& payload) const;
    // Writes this shard's manifest (atomically). devices: the labels of the places that ran it.
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
};

// How rank 0 of an MPI world and the other ranks talk (implemented over MPI by the CLI; an interface
// here so the jobs do not depend on MPI being built in).
class ItemTransport {
public:
    virtual ~ItemTransport() = default;
    virtual int rank() const = 0;
    virtual int ranks() const = 0;
    bool coordinator() const { return rank() == 0; }
    // Rank 0: hands `pending` out to the other ranks as they ask (a rank twice as fast takes twice the
    // items), calls on_result(id, payload) for every finished item and progress(done, total), and returns
    // when every rank has stopped. Throws std::runtime_error naming the rank and item when a rank failed
    // (the other ranks are stopped cleanly first), ms::Cancelled on cancellation.
    virtual void coordinate(std::deque<std::uint64_t> pending,
                            const std::function<void(std::uint64_t, const std::string&)>& on_result,
                            const std::function<void(std::uint64_t, std::uint64_t)>& progress) = 0;
    // Other ranks: the next item to compute (false: none left), a finished item's payload, and the end
    // of this rank's work (failure: "" when it finished, else the error, which rank 0 reports).
    virtual bool next_item(std::uint64_t& id) = 0;
    virtual void send_result(std::uint64_t id, const std::string& payload) = 0;
    virtual void finish(const std::string& failure) = 0;
};

// How a job's items are split and kept.
struct ItemPlan {
    const ItemStore* store = nullptr;   // finished items are kept here and resumed from (null: none)
    Shard shard;                        // with a store: this process's items
    bool merge_only = false;            // compute nothing: every item must be in the store already
    ItemTransport* transport = nullptr; // an MPI world (rank 0 coordinates and keeps the store)
    std::function<void(const std::string&)> warn;  // damaged items set aside
};

struct ItemRunReport {
    RunReport run;                 // of the items this process computed
    std::uint64_t loaded = 0;      // items taken from the store
    bool complete = false;         // every item of the job is in the integrand (this process writes)
    std::uint64_t rerun = 0;       // reruns after device failures (merge: as the shards recorded them)
    std::vector<std::string> devices;  // merge: the shards' devices (empty: this process's scheduler's)
};

// Runs the integrand's items as the plan says. Throws std::invalid_argument for a merge with missing
// items (naming the shard to rerun), ms::Cancelled, and whatever Scheduler::run throws.
ItemRunReport run_items(Scheduler& scheduler, Integrand& integrand, const ItemPlan& plan,
                        const RunCallbacks& callbacks = {});

}  // namespace ms::schedule
