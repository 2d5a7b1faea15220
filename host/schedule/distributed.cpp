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

namespace {

// A stored item set aside (`w` names it, the reason and where it went), with what follows: a resume
// computes it again; a merge cannot, and names the shard to rerun.
void warn_of(const ItemPlan& plan, const std::string& w) {
    if (plan.warn && !w.empty()) plan.warn(w + (plan.merge_only ? "; rerun its shard, then merge" : "; computed again"));
}

// A merge: every item from the store, each handed to `accept`; a missing one names its shard, to rerun
// before merging again (and nothing is accepted then, so nothing is written).
using ItemCheck = std::function<std::string(std::uint64_t, const std::string&)>;

std::optional<std::string> load_checked(const ItemStore& store, std::uint64_t id, std::string* warning, const ItemCheck& check) {
    if (!check) return store.load(id, warning);
    return store.load(id, warning, [&](const std::string& payload) { return check(id, payload); });
}

void merge_items(const ItemPlan& plan, std::uint64_t total, const std::function<void(std::uint64_t, const std::string&)>& accept,
                 ItemRunReport& report, const ItemCheck& check = {}) {
    if (!plan.store) throw std::logic_error("run_items: a merge needs a chunk store");
    const ItemStore& store = *plan.store;
    const std::uint32_t count = store.merge_shard_count();
    std::map<std::uint32_t, std::pair<std::uint64_t, std::uint64_t>> missing;  // shard -> (first id, how many)
    std::vector<std::string> payloads;
    for (std::uint64_t id = 0; id < total; ++id) {
        throw_if_cancelled();
        std::string warning;
        std::optional<std::string> payload = load_checked(store, id, &warning, check);
        warn_of(plan, warning);
        if (!payload) {
            auto& m = missing.try_emplace(std::uint32_t(id % count), id, 0).first->second;
            ++m.second;
            continue;
        }
        if (missing.empty()) accept(id, *payload);
        ++report.loaded;
    }
    if (!missing.empty()) {
        std::string msg = store.dir() + ": cannot merge, items are missing:";
        for (const auto& [s, m] : missing)
            msg += " shard " + std::to_string(s) + "/" + std::to_string(count) + " lacks " + std::to_string(m.second) +
                   " item(s) (the first is " + std::to_string(m.first) + ");";
        throw std::invalid_argument(msg + " rerun those shards (they resume), then merge; nothing was written");
    }
    report.complete = report.shard_complete = true;
    report.rerun = store.recorded_reruns();
    report.devices = store.recorded_devices();
}

// The finished items of this shard (or, MPI, of the whole job) found in the store, handed to `accept`.
std::vector<char> resume_items(const ItemPlan& plan, const Shard& shard, std::uint64_t total,
                               const std::function<void(std::uint64_t, const std::string&)>& accept, ItemRunReport& report,
                               const ItemCheck& check = {}) {
    std::vector<char> done(total, 0);
    if (!plan.store) return done;
    for (std::uint64_t id = shard.index; id < total; id += shard.count) {
        throw_if_cancelled();
        std::string warning;
        if (std::optional<std::string> payload = load_checked(*plan.store, id, &warning, check)) {
            accept(id, *payload);
            done[id] = 1;
            ++report.loaded;
        }
        warn_of(plan, warning);
    }
    return done;
}

// Rank 0 of an MPI world: the other ranks compute what is not done; each result is accepted and kept.
void coordinate_items(const ItemPlan& plan, std::uint64_t total, std::vector<char>& done,
                      const std::function<void(std::uint64_t, const std::string&)>& accept, const RunCallbacks& callbacks,
                      ItemRunReport& report) {
    std::deque<std::uint64_t> pending;
    for (std::uint64_t id = 0; id < total; ++id)
        if (!done[id]) pending.push_back(id);
    const std::uint64_t loaded = report.loaded;
    plan.transport->coordinate(
        std::move(pending),
        [&](std::uint64_t id, const std::string& payload) {
            if (id >= total || done[id]) throw std::runtime_error("MPI: a rank sent item " + std::to_string(id) + " twice or out of range");
            accept(id, payload);
            done[id] = 1;
            if (plan.store) plan.store->save(id, payload);  // synced in groups (chunk_store.hpp)
            ++report.run.done;
        },
        [&](std::uint64_t d, std::uint64_t t) {
            if (callbacks.progress) callbacks.progress(loaded + d, loaded + t);
        });
    if (plan.store) plan.store->commit();
    report.complete = report.shard_complete = true;
}

// A computing rank's end of the exchange: tell rank 0 how this rank's work ended, and rethrow.
template <class Body>
void as_computing_rank(const ItemPlan& plan, Body&& body) {
    try {
        body();
    } catch (const Cancelled&) {
        plan.transport->finish("cancelled");
        throw;
    } catch (const std::exception& e) {
        plan.transport->finish(e.what());
        throw;
    }
    plan.transport->finish("");
}

}  // namespace

ItemRunReport run_items(Scheduler& scheduler, Integrand& integrand, const ItemPlan& plan, const RunCallbacks& callbacks) {
    ItemRunReport report;
    const std::uint64_t total = integrand.work_items();
    if ((plan.store || plan.transport) && !integrand.distributable())
        throw std::invalid_argument(integrand.name() + " cannot be split into shards or MPI ranks");
    auto accept = [&](std::uint64_t id, const std::string& payload) { integrand.load_item(id, payload); };
    // What the store gives back is checked like any input; a damaged item is set aside (a merge then
    // names its shard to rerun, a resume computes it again).
    const ItemCheck check = [&](std::uint64_t id, const std::string& payload) { return integrand.check_item(id, payload); };
    if (plan.merge_only) {
        merge_items(plan, total, accept, report, check);
        return report;
    }
    if (plan.transport && !plan.transport->coordinator()) {
        // A computing rank: items come from rank 0 one at a time, results go back as they finish.
        WorkSelection selection;
        selection.next_item = [&](std::uint64_t& id) { return plan.transport->next_item(id); };
        RunCallbacks cb;
        cb.on_done = [&](std::uint64_t id) { plan.transport->send_result(id, integrand.save_item(id)); };
        as_computing_rank(plan, [&] { report.run = scheduler.run(integrand, selection, cb); });
        report.rerun = report.run.rerun;
        return report;
    }
    // Items already finished (a rerun after a kill, or an MPI job resumed): load them instead of computing.
    const Shard shard = plan.transport ? Shard{} : plan.shard;
    std::vector<char> done = resume_items(plan, shard, total, accept, report, check);
    if (plan.transport) {
        coordinate_items(plan, total, done, accept, callbacks, report);
        return report;
    }

    WorkSelection selection;
    selection.shard_index = shard.index;
    selection.shard_count = shard.count;
    selection.already_done = [&](std::uint64_t id) { return done[id] != 0; };
    selection.max_items = plan.max_items;
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
    // A run held to max_items may stop before its shard is done: its manifest says so, and a rerun resumes.
    std::uint64_t mine = 0;
    for (std::uint64_t id = shard.index; id < total; id += shard.count) ++mine;
    report.shard_complete = report.loaded + report.run.done >= mine;
    if (plan.store) plan.store->write_manifest(report.shard_complete, place_labels(scheduler), report.rerun);
    report.complete = shard.count == 1 && report.shard_complete;
    return report;
}

ItemRunReport run_item_job(const ItemJob& job, const ItemPlan& plan, const std::vector<std::string>& places,
                           const RunCallbacks& callbacks) {
    ItemRunReport report;
    const std::uint64_t total = job.items;
    if (plan.merge_only) {
        merge_items(plan, total, job.accept, report, job.check);
        return report;
    }
    if (plan.transport && !plan.transport->coordinator()) {
        as_computing_rank(plan, [&] {
            std::uint64_t id = 0;
            while (plan.transport->next_item(id)) {
                throw_if_cancelled();
                plan.transport->send_result(id, job.compute(id));
                ++report.run.done;
            }
        });
        return report;
    }
    const Shard shard = plan.transport ? Shard{} : plan.shard;
    std::vector<char> done = resume_items(plan, shard, total, job.accept, report, job.check);
    if (plan.transport) {
        coordinate_items(plan, total, done, job.accept, callbacks, report);
        return report;
    }
    const bool manifest = plan.store && shard.count > 1;
    if (manifest) plan.store->write_manifest(false, places, 0);
    std::uint64_t mine = 0, finished = 0;
    for (std::uint64_t id = shard.index; id < total; id += shard.count) ++mine;
    finished = report.loaded;
    if (callbacks.progress) callbacks.progress(finished, mine);
    for (std::uint64_t id = shard.index; id < total; id += shard.count) {
        if (done[id]) continue;
        throw_if_cancelled();
        const std::string payload = job.compute(id);
        if (plan.store) plan.store->save(id, payload);
        job.accept(id, payload);
        ++report.run.done;
        if (callbacks.on_done) callbacks.on_done(id);
        if (callbacks.progress) callbacks.progress(++finished, mine);
    }
    if (manifest) plan.store->write_manifest(true, places, 0);
    if (plan.store) plan.store->commit();
    report.shard_complete = true;
    report.complete = shard.count == 1;
    return report;
}

Distribution::Distribution(const DistributionRequest& request, const StoreKey& key, const std::string& default_store,
                           std::function<void(const std::string&)> warn) {
    if (request.merge && (request.shard_given || request.transport))
        throw std::invalid_argument("--merge assembles the shards a chunk store holds: it takes neither --shard nor --mpi");
    if (request.transport && request.shard_given) throw std::invalid_argument("--mpi shares the items among the ranks: it takes no --shard");
    // An MPI world or a merge is one job, not a task of an array: Slurm's array variables do not apply.
    shard_ = request.merge || request.transport ? Shard{} : request.shard;
    const bool sharded = shard_.count > 1;
    const bool rank0 = !request.transport || request.transport->coordinator();
    // Only rank 0 keeps the store (the other ranks send it their items).
    // --shard 0/1 beside an existing store opens it, so that a store split another way is refused
    // instead of ignored.
    std::error_code exists_error;
    const bool existing_store = request.shard_given && std::filesystem::exists(default_store, exists_error);
    const std::string dir = !rank0                  ? ""
                            : !request.store.empty() ? request.store
                            : (sharded || request.merge || existing_store) ? default_store
                                                                           : "";
    if (request.merge) {
        store_.emplace(ItemStore::open_for_merge(dir, key, {}, warn));
        plan_.merge_only = true;
    } else if (!dir.empty()) {
        store_.emplace(dir, key, shard_, CommitPolicy{}, ChunkLayout{}, warn);
    }
    if (store_) plan_.store = &*store_;
    plan_.shard = shard_;
    plan_.transport = request.transport;
    plan_.warn = std::move(warn);
    writer_ = rank0 && !sharded;
}

std::string Distribution::shard_finished(std::uint64_t loaded, std::uint64_t computed, const std::string& merge_hint) const {
    return "shard " + std::to_string(shard_.index) + "/" + std::to_string(shard_.count) + " finished in " +
           (store_ ? store_->dir() : std::string("?")) + " (" + std::to_string(loaded) + " of its items found there, " +
           std::to_string(computed) + " computed); when every shard has, " + merge_hint;
}

}  // namespace ms::schedule
