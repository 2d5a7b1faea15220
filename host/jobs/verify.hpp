// --verify: recompute random texels of a bake with the scalar double oracle on independent points.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "jobs/bake.hpp"

namespace ms {

struct BakeVerification {
    std::size_t checked = 0;
    std::size_t failed = 0;
    double worst_z = 0;          // max |lut - oracle| / sqrt(se_lut^2 + se_oracle^2)
    double worst_abs_diff = 0;   // max |lut - oracle|
    double threshold = 0;        // the Student-t quantile a z-score may not exceed
    std::string worst_texel;     // "channel c, visibility i, n_dot_l j, n_dot_v k: lut x oracle y"
};

// Picks `count` distinct sampled texels (deterministically from the spec's seed) and evaluates each with
// the oracle at the bake's azimuth nodes (so the quadrature error cancels) on a point set with an
// independent seed and `samples` samples (0: the bake's batch size). A texel fails when
// |lut - oracle| > t * sqrt(se_lut^2 + se_oracle^2) + float rounding, t the two-sided Student-t quantile
// with replicates - 1 degrees of freedom at confidence 1 - 0.001 / count (Bonferroni: the whole check
// fails by chance with probability <= 0.001 when the bake is right).
BakeVerification verify_bake(const BakeSpec& spec, const BakeResult& result, std::size_t count,
                             std::uint64_t samples = 0, unsigned threads = 0);

}  // namespace ms
