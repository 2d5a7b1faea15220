// --mpi: the job's work items spread over the ranks of an MPI world (mpirun -np N microshadow JOB --mpi).
// Rank 0 hands items out as ranks ask, gathers the results and writes every output; the other ranks
// compute on their own devices through the scheduler and write nothing. MPI is optional at build time
// (CMake's find_package(MPI)); without it --mpi is refused as bad input.
#pragma once

#include <functional>
#include <memory>

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

}  // namespace ms::cli
