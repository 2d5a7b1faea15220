// What to integrate: the interface every integral of microshadow implements (the per-query term, the
// LUT slice pass, and next the DFG LUT and the prefiltered environments).
//
// An integrand is a numbered set of deterministic work items 0 .. work_items() - 1. Each item's result
// depends on the integrand and its id alone, never on where or in what order it ran, so the scheduler
// may hand items to any place, rerun an item after a device failed, or split the ids into shards
// (processes, MPI ranks, Slurm array tasks) and the outputs are the same bits. An integrand provides two
// ways to compute an item: its kernel routine on an OpenCL device, and its scalar double oracle. Each
// writes the item's values and error estimates into storage the integrand owns, one disjoint slot per
// item, so workers on different places never share an output.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include "device/runtime.hpp"

namespace ms::schedule {

// The state one place keeps while it runs items: compiled kernels and device buffers for a device,
// scratch for an oracle thread. Made on the place's own thread; used by that thread only.
class Worker {
public:
    virtual ~Worker() = default;
    // Computes item `id` completely (values, errors, into the integrand's slot for id). Throws
    // ocl::Error when the device fails (the scheduler reruns the item elsewhere), ms::Cancelled when
    // cancellation was requested mid-item, anything else to stop the whole run.
    virtual void run(std::uint64_t id) = 0;
};

class Integrand {
public:
    virtual ~Integrand() = default;
    virtual std::string name() const = 0;
    virtual std::uint64_t work_items() const = 0;
    // The kernel routine on an OpenCL device. Throws std::invalid_argument for an option the routine
    // cannot honour on that device (e.g. double kernels without cl_khr_fp64).
    virtual std::unique_ptr<Worker> device_worker(ocl::Device& device) = 0;
    // The scalar double oracle on one CPU thread.
    virtual std::unique_ptr<Worker> oracle_worker() = 0;

    // Distributed runs (shards of a Slurm array, MPI ranks; schedule/distributed.hpp): the finished
    // result of item `id` (its slot in the integrand's storage) as bytes, and those bytes put back into
    // the slot on another process. load_item(id, save_item(id)) must restore the slot bit for bit: a
    // merge or an MPI gather then writes the same outputs as one process. Integrands that cannot be
    // distributed keep these defaults.
    virtual bool distributable() const { return false; }
    virtual std::string save_item(std::uint64_t) const { throw std::logic_error(name() + " cannot be distributed"); }
    virtual void load_item(std::uint64_t, const std::string&) { throw std::logic_error(name() + " cannot be distributed"); }
    // A stored item's bytes checked like any input before load_item (its values' range, finiteness and
    // counts): "" when sound, else "tag: reason"; the store then sets the item aside and it is computed
    // again. The default trusts load_item's own checks.
    virtual std::string check_item(std::uint64_t, const std::string&) const { return ""; }
};

}  // namespace ms::schedule
