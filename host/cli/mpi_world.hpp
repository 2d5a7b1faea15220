// --mpi: the job's work items spread over the ranks of an MPI world (mpirun -np N microshadow JOB --mpi).
// Rank 0 hands items out as ranks ask, gathers the results and writes every output; the other ranks
// compute on their own devices through the scheduler and write nothing. MPI is optional at build time
// (CMake's find_package(MPI)); without it --mpi is refused as bad input.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <string>

#include "schedule/distributed.hpp"

namespace ms::cli {

// Whether this program was built with MPI.
bool mpi_built_in();

// The world of this process: initialises MPI on construction and finalises it on destruction (or aborts
// the world when the job was cancelled or failed without telling the other ranks). Throws
// std::invalid_argument without MPI built in, or for a world of one rank.
class MpiWorld {
public:
    MpiWorld();
    ~MpiWorld();
    MpiWorld(const MpiWorld&) = delete;
    MpiWorld& operator=(const MpiWorld&) = delete;
    schedule::ItemTransport& transport();
    bool writer() const;  // rank 0
    // Runs the job's body. When it throws outside the exchange (bad input on rank 0, a device that will
    // not start), the other ranks are told and stop, so the world ends cleanly; then it rethrows.
    void guard(const std::function<void()>& body);

private:
    struct State;
    std::unique_ptr<State> state_;
};

// --shard, --store, --merge and --mpi of a command whose work items can be spread (docs/cluster.md).
struct DistributionArgs {
    std::string shard, store;
    bool merge = false, mpi = false;
    CLI::App* cmd = nullptr;
};
// `items` names the command's items in the help ("slices", "chunks", "roughness nodes");
// `default_store` the store folder without --store ("" : the command has no --store).
void add_distribution_options(CLI::App* cmd, DistributionArgs& args, const std::string& items, const std::string& default_store);
// True when any of the four was given (a command that cannot spread some of its modes refuses them).
bool distribution_given(const DistributionArgs& args);
// The request of the options: --shard, or the Slurm array task's when not given (never for --merge or
// --mpi: one job, not a task of an array), and the world's transport.
schedule::DistributionRequest distribution_request(const DistributionArgs& args, MpiWorld* world);
// Runs `body` inside an MPI world when --mpi was given (its argument then the world, else null): every
// rank reads the same command line, and a failure on any rank stops the others cleanly.
void with_distribution(const DistributionArgs& args, const std::function<void(MpiWorld*)>& body);

}  // namespace ms::cli
