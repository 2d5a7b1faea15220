// Where and how work runs: one scheduler for every job (eval, bake, sweep, verify, and what comes next).
//
// A backend is a set of places: the selected OpenCL devices (one host thread drives each), or N threads
// of the scalar oracle. run() deals an integrand's work ids to the places from one queue, in increasing
// id order, so a faster place simply takes more items. It
//   - fails over: an item whose device throws ocl::Error goes back to the front of the queue, that
//     device is retired for the rest of the run and the others rerun the item (the bits do not change);
//     the run fails, naming every failure, only when no place is left;
//   - cancels: ms::cancel_requested() (SIGINT/SIGTERM in the CLI) stops dealing new items at once; items
//     in flight finish or throw ms::Cancelled (routines keep items well under a second); run() then
//     throws ms::Cancelled, and jobs commit nothing, so old outputs stay intact;
//   - reports progress (items done of items selected) from the calling thread every 100 ms and at the end;
//   - calls on_done(id) after each item, one call at a time (jobs stream results there: sweep chunks);
//   - or pulls items one at a time from WorkSelection::next_item (a rank of an MPI world fed by rank 0);
//   - shards: WorkSelection picks ids by id % count == index and skips finished ones, which is all a
//     distributed engine (ranks of an MPI world, tasks of a Slurm array) needs to split a job.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "device/runtime.hpp"
#include "schedule/integrand.hpp"

namespace ms::schedule {

struct BackendSpec;

struct Backend {
    enum class Kind { opencl, oracle };
    Kind kind = Kind::opencl;
    std::vector<ocl::DeviceInfo> devices;  // opencl
    unsigned oracle_threads = 0;           // oracle: 0 = every hardware thread

    static Backend opencl(std::vector<ocl::DeviceInfo> devices);
    static Backend oracle(unsigned threads = 0);
    // The places a spec names: its OpenCL devices selected (std::invalid_argument when none matches),
    // or the oracle's threads.
    static Backend from(const BackendSpec& spec);
};

// Where a job runs, as a user names it (--backend, --device, --threads): the one type every job's
// options hold (their `backend` field), the command line's flags become (cli/common.hpp) and the
// library's options map to (api/facade.hpp). It is resolved in one place, Scheduler's constructor from
// a BackendSpec: the devices selected (Backend::from, so a device name means the same everywhere) and
// the test hook MICROSHADOW_FAIL_DEVICE applied (fault_injection_from_environment).
struct BackendSpec {
    Backend::Kind kind = Backend::Kind::opencl;
    std::string device = "default";  // opencl: default, all, an index or part of a name (ocl::select_devices)
    unsigned threads = 0;            // oracle: host threads (0: all)

    static BackendSpec oracle(unsigned threads = 0) { return {Backend::Kind::oracle, "default", threads}; }
    static BackendSpec opencl(std::string device = "default") { return {Backend::Kind::opencl, std::move(device), 0}; }
    // The words a user writes: kind "opencl" or "oracle" (std::invalid_argument naming both otherwise),
    // the device and the threads.
    static BackendSpec parse(const std::string& kind, const std::string& device = "default", unsigned threads = 0);
    bool is_oracle() const { return kind == Backend::Kind::oracle; }
    // "opencl" or "oracle", as --backend spells it (and outputs record it).
    const char* kind_name() const { return is_oracle() ? "oracle" : "opencl"; }
};

struct WorkSelection {
    std::uint64_t shard_index = 0, shard_count = 1;  // ids with id % shard_count == shard_index
    std::function<bool(std::uint64_t)> already_done;  // ids to skip (resume); empty: none
    std::uint64_t max_items = 0;                      // > 0: stop after this many items (resumable runs)
    // A pull source instead of the shard's ids (an MPI rank asking its coordinator): called, one call at
    // a time, whenever a place is idle and nothing is queued; returns false when no item is left.
    std::function<bool(std::uint64_t& id)> next_item;
};

// A test hook: place P throws a device error on every item after its first N, so that failover (the
// item rerun on the other places, the bits unchanged) can be tested with working devices.
struct FaultInjection {
    long place = -1;
    long after = 0;
};

// MICROSHADOW_FAIL_DEVICE=P:N (tests only), read here and nowhere else: every scheduler made from a
// BackendSpec on OpenCL devices applies it, so the command line, the library and Python all see it.
// Unset or empty: no fault. Throws std::invalid_argument when malformed.
FaultInjection fault_injection_from_environment();

struct RunCallbacks {
    std::function<void(std::uint64_t done, std::uint64_t total)> progress;
    std::function<void(std::uint64_t id)> on_done;
};

struct RunReport {
    std::uint64_t selected = 0, done = 0;
    std::uint64_t rerun = 0;                   // items rerun after a place failed
    std::vector<std::string> failed_places;    // "label: error"
    double seconds = 0;
};

class Scheduler {
public:
    // The places a user named: the one function that resolves a BackendSpec (devices selected, the
    // fault-injection hook of the environment applied to OpenCL places).
    explicit Scheduler(const BackendSpec& spec);
    // Places chosen by the caller (tests, benchmarks): no hook is read.
    explicit Scheduler(Backend backend);
    ~Scheduler();
    Scheduler(const Scheduler&) = delete;
    Scheduler& operator=(const Scheduler&) = delete;

    const Backend& backend() const { return backend_; }
    bool is_oracle() const { return backend_.kind == Backend::Kind::oracle; }
    std::size_t places() const;
    std::string place_label(std::size_t place) const;
    // "opencl (device; device)" or "oracle (scalar double, N threads)".
    std::string name() const;
    // What decides the bits of the results (recorded and hashed by resumable jobs): the distinct kinds of
    // device, not how many there are ("opencl (D)" for one D or for two D alike), or "oracle (scalar
    // double)" whatever the thread count.
    std::string results_label() const;
    // The devices' labels (empty for the oracle).
    std::vector<std::string> device_labels() const;

    void set_fault_injection(FaultInjection f) { fault_ = f; }

    // Runs the selected items of the integrand. Throws ms::Cancelled, the first non-device error of a
    // worker, or ocl::Error naming every failed place when no place is left.
    RunReport run(Integrand& integrand, const WorkSelection& selection = {}, const RunCallbacks& callbacks = {});

private:
    Backend backend_;
    unsigned oracle_threads_ = 1;
    // Devices (context, queue, program cache) live as long as the scheduler, so a job that runs several
    // integrands (bake, then verify) compiles each program once.
    std::vector<std::unique_ptr<ocl::Device>> devices_;
    FaultInjection fault_;
};

}  // namespace ms::schedule
