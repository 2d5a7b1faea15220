// The 2D point sets fed to the VNDF sampler, generated once on the host and shared by every query of
// a batch, by the OpenCL kernels and by the oracle (so both can be compared on the same points).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/types.hpp"

namespace ms {

// R replicates of n = 2^m points each, stored replicate-major in structure-of-arrays form
// (u1[r * n + i], u2[r * n + i]), values in [0, 1) with 24 significant bits so they are exact in float.
struct PointSet {
    Sequence sequence = Sequence::sobol;
    std::uint32_t replicates = 0;
    std::uint32_t points_per_replicate = 0;
    std::uint64_t seed = 0;
    std::vector<float> u1, u2;

    std::uint64_t total() const { return std::uint64_t(replicates) * points_per_replicate; }
};

// Smallest admissible sample count >= requested: replicates * a power of two >= 16 (one SIMD block).
std::uint64_t round_up_samples(std::uint64_t requested, std::uint32_t replicates);

// sobol: each replicate is the 2D Hammersley (0,m,2)-net in base 2, (i / n, radical_inverse(i)),
// which is also the first two dimensions of the Sobol' sequence up to order, with an independent
// nested uniform (Owen) scramble per replicate and dimension (hash-based, after Laine & Karras 2011
// and Burley 2020). Scrambled nets keep the net structure, are unbiased, and converge at about
// n^(-3/4) on indicator integrands like this one.
// random: independent uniform points from a counter-based hash of (seed, replicate, index, dim).
// Deterministic: the same plan gives the same bits. Throws std::invalid_argument on a bad plan.
PointSet make_point_set(const SamplingPlan& plan);

// The same point set, generated once and shared: repeated evaluations with one plan (benchmarks,
// sweeps, bakes of many batches) neither regenerate the points nor, in the OpenCL backend, upload them
// again. Keeps the few most recently used plans; thread-safe.
std::shared_ptr<const PointSet> shared_point_set(const SamplingPlan& plan);

// The building blocks, exposed for tests.
std::uint32_t reverse_bits(std::uint32_t x);
std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed);

}  // namespace ms
