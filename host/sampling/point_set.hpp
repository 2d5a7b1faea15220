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

// Azimuth-stratified bakes (integrands/lut_slice, --azimuth-quadrature stratified): the points of
// make_point_set(plan), each replicate reordered cell-major into `cells` cells of n / cells points
// (cell c = points [c n / cells, (c + 1) n / cells) of the replicate, in increasing index i within a
// cell). cells is a power of two <= n / 16. sobol: the cell is the top log2(cells) bits of a third
// coordinate u3(i) = owen_scramble(sobol_pascal(i)) with its own independent scramble, so that
// (i / n, radical_inverse(i), u3) is a scrambled (0,m,3)-net in base 2 (a (0,2)-sequence, Sobol's first two
// dimensions, with i / n appended): the points of one cell are then themselves a scrambled
// (0, m - log2(cells), 2)-net in (u1, u2), and the cells split the net evenly. random: cell c is the
// block of indices [c n / cells, (c + 1) n / cells) (independent points: any split is as good).
// Throws std::invalid_argument on a bad plan or cell count.
PointSet make_cell_point_set(const SamplingPlan& plan, std::uint32_t cells);
// Cached like shared_point_set (cells 0: shared_point_set(plan) itself).
std::shared_ptr<const PointSet> shared_point_set(const SamplingPlan& plan, std::uint32_t cells);

// The generator matrix of Sobol's second dimension (upper-triangular Pascal matrix mod 2) applied to
// the bits of i, as a 0.32 fixed-point fraction; exposed for tests.
std::uint32_t sobol_pascal(std::uint32_t i);

// The building blocks, exposed for tests.
std::uint32_t reverse_bits(std::uint32_t x);
std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed);

}  // namespace ms
