// Four-dimensional point sets for integrals over a light's directions and the visible normals at once
// (the area-light integrand): (u1, u2) drive the VNDF sampler, (u3, u4) the light direction.
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.hpp"
#include "sampling/point_set.hpp"

namespace ms {

// R replicates of n = 2^m points, replicate-major like PointSet. sobol: (u1, u2) are exactly the points
// of make_point_set(plan) (the scrambled Hammersley net i / n, radical inverse of i); u3 and u4 are
// Sobol's dimensions 2 and 3 (primitive polynomials x + 1 and x^2 + x + 1) of the same index i, each
// with its own nested uniform scramble per replicate. (i / n, then the first three dimensions of the
// Sobol' (1, 3)-sequence) is a scrambled (1, m, 4)-net: every 1D projection is stratified into n equal
// intervals, (u1, u2) is a (0, m, 2)-net and so is (u2, u3). random: independent uniform points.
struct JointPointSet {
    PointSet normals;             // u1, u2
    std::vector<float> u3, u4;    // the light's two coordinates, same indexing
    std::uint64_t total() const { return normals.total(); }
};

JointPointSet make_joint_point_set(const SamplingPlan& plan);

// Sobol's dimension 3 (x^2 + x + 1, direction numbers m = 1, 3) applied to the bits of i, as a 0.32
// fixed-point fraction; exposed for tests.
std::uint32_t sobol_dimension3(std::uint32_t i);

}  // namespace ms
