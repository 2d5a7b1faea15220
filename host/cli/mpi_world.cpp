#include "cli/mpi_world.hpp"

#include "cli/common.hpp"

#include <stdexcept>

#ifdef MICROSHADOW_HAVE_MPI

#include <mpi.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "cli/progress.hpp"
#include "core/cancel.hpp"

namespace ms::cli {

namespace {

// The messages between rank 0 and the others. A computing rank asks for an item (request), rank 0
// answers with its id or kStop (item), the rank sends each result back (result: the id, then the
// payload) and, when its scheduler has no more work, says whether it failed (finished: "" or the error).
enum Tag : int { request = 1, item = 2, result = 3, finished = 4 };
constexpr std::uint64_t kStop = ~std::uint64_t(0);

class MpiTransport final : public schedule::ItemTransport {
public:
    MpiTransport(int rank, int ranks) : rank_(rank), ranks_(ranks) {}
    int rank() const override { return rank_; }
    int ranks() const override { return ranks_; }
    bool unclean() const { return unclean_; }
    void mark_unclean() { unclean_ = true; }

    void coordinate(std::deque<std::uint64_t> pending,
                    const std::function<void(std::uint64_t, const std::string&)>& on_result,
                    const std::function<void(std::uint64_t, std::uint64_t)>& progress) override {
        const std::uint64_t total = pending.size();
        std::uint64_t done = 0;
        int running = ranks_ - 1;
        std::map<int, std::set<std::uint64_t>> handed;  // per rank: items handed out and not yet returned
        std::string failure;
        auto last_progress = std::chrono::steady_clock::now();
        if (progress) progress(0, total);
        std::vector<char> buffer;
        while (running > 0) {
            if (cancel_requested()) {
                // The other ranks were signalled too (mpirun forwards the signal); the world is aborted
                // on the way out, and the chunk store keeps what was gathered.
                unclean_ = true;
                throw_if_cancelled();
            }
            int flag = 0;
            MPI_Status status;
            MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
            if (!flag) {
                // Polling, not a blocking receive, so Ctrl-C and progress work while ranks compute.
                std::this_thread::sleep_for(std::chrono::microseconds(200));
                if (progress && std::chrono::steady_clock::now() - last_progress > std::chrono::milliseconds(100)) {
                    progress(done, total);
                    last_progress = std::chrono::steady_clock::now();
                }
                continue;
            }
            const int from = status.MPI_SOURCE;
            int bytes = 0;
            MPI_Get_count(&status, MPI_BYTE, &bytes);
            buffer.resize(std::size_t(bytes) + 1);
            MPI_Recv(buffer.data(), bytes, MPI_BYTE, from, status.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            if (status.MPI_TAG == request) {
                std::uint64_t id = kStop;
                if (failure.empty() && !pending.empty()) {
                    id = pending.front();
                    pending.pop_front();
                    handed[from].insert(id);
                }
                MPI_Send(&id, 8, MPI_BYTE, from, item, MPI_COMM_WORLD);
            } else if (status.MPI_TAG == result) {
                std::uint64_t id = 0;
                if (bytes < 8) {
                    if (failure.empty()) failure = "rank " + std::to_string(from) + " sent a result without an item id";
                    continue;
                }
                std::memcpy(&id, buffer.data(), 8);
                if (!handed[from].erase(id)) {
                    if (failure.empty())
                        failure = "rank " + std::to_string(from) + " sent item " + std::to_string(id) + ", which it was not given";
                    continue;
                }
                if (!failure.empty()) continue;  // stopping: what still arrives is not kept
                try {
                    on_result(id, std::string(buffer.data() + 8, std::size_t(bytes) - 8));
                    ++done;
                } catch (const std::exception& e) {
                    failure = "rank 0 could not keep item " + std::to_string(id) + " from rank " + std::to_string(from) + ": " + e.what();
                }
            } else if (status.MPI_TAG == finished) {
                --running;
                const std::string error(buffer.data(), std::size_t(bytes));
                const auto& open = handed[from];
                if (failure.empty() && (!error.empty() || !open.empty())) {
                    failure = "rank " + std::to_string(from) + " failed";
                    if (!open.empty()) failure += " on item " + std::to_string(*open.begin());
                    failure += ": " + (error.empty() ? std::string("it stopped with items unfinished") : error);
                }
            } else if (failure.empty()) {
                failure = "rank " + std::to_string(from) + " sent an unknown message (tag " + std::to_string(status.MPI_TAG) + ")";
            }
        }
        coordinated_ = true;  // every rank has stopped: the world can finalise whatever comes next
        if (progress) progress(done, total);
        if (!failure.empty())
            throw std::runtime_error("MPI: " + failure + "; nothing was written (with --store, the items gathered are kept and a rerun resumes)");
        if (done != total)
            throw std::runtime_error("MPI: " + std::to_string(total - done) + " of " + std::to_string(total) +
                                     " items never came back; nothing was written");
    }

    bool next_item(std::uint64_t& id) override {
        MPI_Send(nullptr, 0, MPI_BYTE, 0, request, MPI_COMM_WORLD);
        MPI_Recv(&id, 8, MPI_BYTE, 0, item, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        return id != kStop;
    }

    void send_result(std::uint64_t id, const std::string& payload) override {
        std::string message(8, '\0');
        std::memcpy(message.data(), &id, 8);
        message += payload;
        if (message.size() > std::size_t(INT32_MAX)) throw std::runtime_error("MPI: item " + std::to_string(id) + " is over 2 GiB");
        MPI_Send(message.data(), int(message.size()), MPI_BYTE, 0, result, MPI_COMM_WORLD);
    }

    void finish(const std::string& failure) override {
        if (finished_) return;
        finished_ = true;
        MPI_Send(failure.data(), int(failure.size()), MPI_BYTE, 0, finished, MPI_COMM_WORLD);
        if (failure == "cancelled") unclean_ = true;
    }

    // After this rank failed outside the exchange (bad input found on rank 0, a device that would not
    // start on another): tell the others, so every rank stops and the world ends cleanly.
    void stop_after_failure(const std::string& what) {
        if (unclean_) return;
        if (rank_ == 0 && !coordinated_) {
            try {
                coordinate({}, [](std::uint64_t, const std::string&) {}, nullptr);
            } catch (const std::exception&) {
                // The ranks' own failures matter less than rank 0's, which main reports.
            }
        } else if (rank_ != 0) {
            finish(what.empty() ? std::string("failed") : what);
        }
    }

private:
    int rank_, ranks_;
    bool unclean_ = false, coordinated_ = false, finished_ = false;
};

}  // namespace

struct MpiWorld::State {
    std::unique_ptr<MpiTransport> transport;
};

bool mpi_built_in() { return true; }

MpiWorld::MpiWorld() : state_(std::make_unique<State>()) {
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (initialised) throw std::logic_error("MPI is already initialised");
    // The scheduler's threads call MPI one at a time (under its lock): SERIALIZED is enough.
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
    int rank = 0, ranks = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks);
    if (provided < MPI_THREAD_SERIALIZED) {
        MPI_Finalize();
        throw std::runtime_error("--mpi: this MPI library does not offer MPI_THREAD_SERIALIZED");
    }
    if (ranks < 2) {
        MPI_Finalize();
        throw std::invalid_argument("--mpi needs at least 2 ranks (rank 0 hands out work and writes; the others compute): "
                                    "start it with mpirun -np N (N >= 2) or srun, or run without --mpi");
    }
    state_->transport = std::make_unique<MpiTransport>(rank, ranks);
}

MpiWorld::~MpiWorld() {
    if (state_->transport && state_->transport->unclean()) {
        // Cancelled: the other ranks may wait on a message that never comes; end the whole world (MPI_Abort
        // does not return, so the message main would print is printed here).
        std::cerr << "microshadow: interrupted (rank " << state_->transport->rank() << "); nothing was written\n";
        MPI_Abort(MPI_COMM_WORLD, interrupted_exit_status());
        return;
    }
    // No rank leaves before every rank is here: rank 0 reports a failure before it gets here, and a rank
    // that exited with an error earlier could make mpirun end rank 0 before its message is out.
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
}

schedule::ItemTransport& MpiWorld::transport() { return *state_->transport; }
bool MpiWorld::writer() const { return state_->transport->rank() == 0; }

void MpiWorld::guard(const std::function<void()>& body) {
    try {
        body();
    } catch (const Cancelled&) {
        // Every rank was signalled (mpirun forwards the signal): the world is aborted on the way out.
        state_->transport->mark_unclean();
        throw;
    } catch (const std::exception& e) {
        state_->transport->stop_after_failure(e.what());
        throw;
    } catch (...) {
        state_->transport->stop_after_failure("failed");
        throw;
    }
}

}  // namespace ms::cli

#else  // no MPI built in

namespace ms::cli {

struct MpiWorld::State {};

bool mpi_built_in() { return false; }

MpiWorld::MpiWorld() {
    throw std::invalid_argument("--mpi: this microshadow was built without MPI (install Open MPI, e.g. Debian's "
                                "libopenmpi-dev, and configure again; CMake finds it by default)");
}
MpiWorld::~MpiWorld() = default;
schedule::ItemTransport& MpiWorld::transport() { throw std::logic_error("no MPI"); }
bool MpiWorld::writer() const { return true; }
void MpiWorld::guard(const std::function<void()>& body) { body(); }

}  // namespace ms::cli

#endif

namespace ms::cli {

void add_distribution_options(CLI::App* cmd, DistributionArgs& args, const std::string& items, const std::string& default_store) {
    args.cmd = cmd;
    cmd->add_option("--shard", args.shard,
                    "run only the " + items + " i with i % N == I (I/N; default: the Slurm array task's, from SLURM_ARRAY_TASK_ID "
                    "and SLURM_ARRAY_TASK_COUNT), keeping them in the chunk store; write the outputs with --merge");
    if (!default_store.empty())
        cmd->add_option("--store", args.store,
                        "chunk store folder of finished " + items + " (default with --shard or --merge: " + default_store +
                            "); a rerun resumes from it");
    cmd->add_flag("--merge", args.merge,
                  "write the outputs from the " + items + " the shards left in the chunk store (same options, no --shard)");
    cmd->add_flag("--mpi", args.mpi,
                  "share the " + items + " among the ranks of an MPI world (mpirun -np N, N >= 2): rank 0 hands them out and writes");
}

bool distribution_given(const DistributionArgs& args) {
    for (const char* o : {"--shard", "--store", "--merge", "--mpi"})
        if (args.cmd->get_option_no_throw(o) && args.cmd->get_option(o)->count() > 0) return true;
    return false;
}

schedule::DistributionRequest distribution_request(const DistributionArgs& args, MpiWorld* world) {
    schedule::DistributionRequest r;
    r.shard_given = args.cmd->get_option("--shard")->count() > 0;
    if (args.merge && (r.shard_given || args.mpi))
        throw std::invalid_argument("--merge assembles the shards a chunk store holds: it takes neither --shard nor --mpi");
    if (args.mpi && r.shard_given) throw std::invalid_argument("--mpi shares the work among the ranks: it takes no --shard");
    if (!args.merge && !args.mpi) r.shard = resolve_shard(args.shard);
    r.store = args.store;
    r.merge = args.merge;
    r.transport = world ? &world->transport() : nullptr;
    return r;
}

void with_distribution(const DistributionArgs& args, const std::function<void(MpiWorld*)>& body) {
    if (!args.mpi) return body(nullptr);
    MpiWorld world;
    try {
        world.guard([&] { body(&world); });
    } catch (const Cancelled&) {
        throw;  // the world is aborted on the way out, with its own message
    } catch (...) {
        if (!world.writer()) throw;
        // Rank 0 speaks for the world: its message goes out while the world still stands (the other ranks
        // wait for it at the end), then main adds nothing.
        const int status = report_error(std::current_exception());
        std::cerr.flush();
        throw ReportedError(status);
    }
}

}  // namespace ms::cli
