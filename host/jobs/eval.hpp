// Batched evaluation of GenericM_g on a backend: the OpenCL kernels on one or more devices, or the
// scalar oracle. Provable zeros and v = 1 queries are answered exactly without sampling.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/types.hpp"
#include "device/runtime.hpp"
#include "sampling/point_set.hpp"

namespace ms {

// Per-(query, replicate) tallies: cone[q * R + r], hemisphere[q * R + r].
struct Tallies {
    std::vector<double> cone, hemisphere;
};

class TermBackend {
public:
    virtual ~TermBackend() = default;
    virtual std::string name() const = 0;
    // Tally every query over every replicate of the point set. Queries are valid and need sampling.
    virtual Tallies tally(const std::vector<Query>& queries, const TermOptions& options, const PointSet& points) = 0;
};

// The scalar double oracle, spread over `threads` threads (0: all hardware threads).
std::unique_ptr<TermBackend> make_oracle_backend(unsigned threads = 0);

// The OpenCL kernels on the given devices; batches of queries are shared out among them.
struct OpenClBackendConfig {
    ocl::BuildConfig build;
    std::size_t max_batch_queries = 1 << 15;  // bounds device memory per enqueue
    // Work-group size of the tally kernel (clamped to the device's limit). Fixed rather than left to
    // the runtime: PoCL compiles a work-group function per distinct local size, and with NullRange it
    // picks a new one for most new batch sizes. Results do not depend on it (tested).
    std::size_t local_size = 32;
};
std::unique_ptr<TermBackend> make_opencl_backend(const std::vector<ocl::DeviceInfo>& devices,
                                                 const OpenClBackendConfig& config = {});

// Throws std::invalid_argument naming the problem if a query is not valid input:
// visibility in [0, 1], alpha_x and alpha_y > 0 and finite, non-zero finite directions, wi above the horizon.
void validate_query(const Query& q);
// Unit-length copy of the query's directions.
Query normalised(const Query& q);

struct EvalStats {
    std::size_t sampled = 0;       // queries that were integrated
    std::size_t exact_zero = 0;    // zero region or light below the horizon: exactly 0
    std::size_t exact_one = 0;     // visibility 1: exactly 1
    double seconds = 0;
};

// Validates and normalises the queries, answers the trivial ones exactly, and tallies the rest on the
// backend with the point set of `plan`. Progress reports (done, total) queries.
std::vector<Estimate> evaluate(TermBackend& backend, const std::vector<Query>& queries, const TermOptions& options,
                               const SamplingPlan& plan, EvalStats* stats = nullptr,
                               const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace ms
