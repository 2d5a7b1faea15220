// The plain C++ baseline of the tally loop: the same computation as kernels/generic_term.cl (spherical-
// cap VNDF, cone/hemisphere counts on the same point buffer), written so that GCC vectorises it, and
// compiled on its own with -O3 -march=native -fno-math-errno -fopenmp (bench/CMakeLists.txt). The
// benchmarks use it to show what the OpenCL kernel should reach on this CPU.
#pragma once

#include <cstdint>
#include <vector>

#include "microshadow_shared.h"

namespace ms::bench {

// Tallies every query over every replicate: out[q * replicates + r]. Points are replicate-major
// (u1[r * n + i]) like ms::PointSet. OpenMP spreads (query, replicate, chunk) items over all cores.
void baseline_tally(const std::vector<ms_query>& queries, const float* u1, const float* u2, std::uint32_t points_per_replicate,
                    std::uint32_t replicates, std::vector<ms_tally>& out);

// Number of samples of one query and replicate whose cone or hemisphere decision lies within a
// relative `margin` of its threshold: there a float evaluation in another order (fma contraction,
// another sincos rounding) may decide differently. Used to check kernel and baseline agree "within
// float rounding": |count difference| <= this number. Scalar, not timed.
std::uint64_t borderline_samples(const ms_query& q, const float* u1, const float* u2, std::uint32_t count, float margin);

// OpenMP threads the baseline runs on.
int baseline_threads();

}  // namespace ms::bench
