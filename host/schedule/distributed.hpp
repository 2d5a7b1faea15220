// Running one job's work items on many processes: shards (tasks of a Slurm array, or any N processes
// given --shard I/N), resumable through a chunk store of finished items, merged into the outputs of one
// process; or the ranks of an MPI world, where rank 0 hands items out and gathers them.
//
// Everything rests on the integrand's contract (integrand.hpp): an item's result depends on the job's
// spec and the item's id alone, and save_item/load_item carry it between processes bit for bit. So the
// same items, however they were split, run or rerun, assemble into the same bytes.
//
// The chunk store that keeps finished items, resumes and merges is schedule/chunk_store.hpp.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "schedule/chunk_store.hpp"
#include "schedule/scheduler.hpp"

namespace ms::schedule {

// "I/N" with 0 <= I < N <= 1000000; throws std::invalid_argument naming `option` and the text.
Shard parse_shard(const std::string& text, const std::string& option = "--shard");
// The shard of a Slurm array task (SLURM_ARRAY_TASK_ID, _MIN, _STEP, _COUNT from `lookup`, normally
// getenv): nullopt outside an array; std::invalid_argument when the variables do not describe a task
// of an array of consecutive ids (e.g. --array=0,3,7 or a %-throttle gives no I/N).
std::optional<Shard> slurm_array_shard(const std::function<const char*(const char*)>& lookup);

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
    std::function<void(const std::string&)> warn;  // damaged items set aside, each message saying what follows
    std::uint64_t max_items = 0;        // > 0: compute at most this many items in this run (run_items; resumable)
};

struct ItemRunReport {
    RunReport run;                 // of the items this process computed
    std::uint64_t loaded = 0;      // items taken from the store
    bool complete = false;         // every item of the job is in the integrand (this process writes)
    bool shard_complete = false;   // every item of this process's shard is finished (false: stopped at max_items)
    std::uint64_t rerun = 0;       // reruns after device failures (merge: as the shards recorded them)
    std::vector<std::string> devices;  // merge: the shards' devices (empty: this process's scheduler's)
};

// Runs the integrand's items as the plan says. Throws std::invalid_argument for a merge with missing
// items (naming the shard to rerun), ms::Cancelled, and whatever Scheduler::run throws.
ItemRunReport run_items(Scheduler& scheduler, Integrand& integrand, const ItemPlan& plan,
                        const RunCallbacks& callbacks = {});

// A job whose items run one after another in this process, each on the whole scheduler (a batch of
// queries handed to evaluate(), a bake of some channels, ...): split, kept, resumed, merged and spread
// over MPI ranks by the same plan as run_items. The contract is the integrand's: an item's payload
// depends on the job's spec and the item's id alone.
struct ItemJob {
    std::string name;              // in messages ("repr bake", "design reference set")
    std::uint64_t items = 0;
    // Computes item `id` and returns its payload (the bytes the store keeps and ranks send).
    std::function<std::string(std::uint64_t id)> compute;
    // Takes a finished item's payload: computed here, loaded from the store or gathered from a rank.
    // Throws std::runtime_error when the bytes are not an item of this job.
    std::function<void(std::uint64_t id, const std::string& payload)> accept;
    // Optional: checks a stored item's payload before it is accepted ("" or "tag: reason"); a damaged
    // one is set aside and computed again.
    std::function<std::string(std::uint64_t id, const std::string& payload)> check;
};

// Runs the job's items as the plan says; `places` are the labels the manifests record (a shard's; one
// process's store needs none: its items are the whole job). Throws as run_items does.
ItemRunReport run_item_job(const ItemJob& job, const ItemPlan& plan, const std::vector<std::string>& places,
                           const RunCallbacks& callbacks = {});

// How a command asked for its items to be split, as parsed from its options.
struct DistributionRequest {
    Shard shard;                           // --shard I/N, or the Slurm array task's
    bool shard_given = false;              // --shard was given (not only the array's variables)
    std::string store;                     // --store DIR
    bool merge = false;                    // --merge
    ItemTransport* transport = nullptr;    // --mpi: the world
};

// The plan of a request for the job `key`: the store opened (for this shard, or for merging), where
// the items are kept, and whether this process writes the outputs. Throws std::invalid_argument (bad
// input, nothing written) for --merge with --shard or --mpi, --mpi with --shard, and whatever ItemStore
// refuses (a store of another job, another split).
class Distribution {
public:
    // default_store: the store folder when sharding or merging without --store (the job's output beside it).
    Distribution(const DistributionRequest& request, const StoreKey& key, const std::string& default_store,
                 std::function<void(const std::string&)> warn = {});
    Distribution(const Distribution&) = delete;
    Distribution& operator=(const Distribution&) = delete;

    const ItemPlan& plan() const { return plan_; }
    const Shard& shard() const { return shard_; }
    const ItemStore* store() const { return store_ ? &*store_ : nullptr; }
    // This process writes the job's outputs: one process, the merge, or rank 0 of an MPI world.
    bool writer() const { return writer_; }
    // "shard 1/4 finished in DIR (3 of its items found there, 5 computed); ..." for a shard's stderr.
    std::string shard_finished(std::uint64_t loaded, std::uint64_t computed, const std::string& merge_hint) const;

private:
    std::optional<ItemStore> store_;
    ItemPlan plan_;
    Shard shard_;
    bool writer_ = true;
};

}  // namespace ms::schedule
