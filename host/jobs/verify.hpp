// --verify: recompute random texels of a bake with the scalar double oracle on independent points.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "jobs/bake.hpp"

namespace ms {

struct BakeVerification {
    Method reference = Method::exact;  // what the texels were recomputed with
    std::size_t checked = 0;
    std::size_t failed = 0;
    double worst_z = 0;          // max of the texels' z-scores (below)
    double worst_abs_diff = 0;   // max |lut - reference|
    double threshold = 0;        // the Student-t quantile a z-score may not exceed (1 for an exact bake)
    double max_reference_error = 0;  // exact reference: the largest estimated error of a reference value
    std::string worst_texel;     // "channel c, visibility i, n_dot_l j, n_dot_v k: lut x reference y"
};

// Picks `count` distinct sampled texels (deterministically from the spec's seed) and recomputes each
// at the azimuth rule the bake estimates, so the quadrature error cancels: a fixed K's trapezoid nodes,
// a stratified bake's cell midpoints, a fixed angle; for the adaptive default (rows end at different K)
// every K the bake's rows used, the texel being judged against the closest.
//
// reference = exact (the default): the deterministic evaluator (host/exact/) on `threads` oracle-backend
// threads. A texel fails when |lut - exact| > t * se_lut + e_exact + float rounding, e_exact the exact
// values' estimated error (node-weighted), t the two-sided Student-t quantile with replicates - 1
// degrees of freedom at confidence 1 - 0.001 / count (Bonferroni: the whole check fails by chance with
// probability <= 0.001 when the bake is right). The reference carries no sampling noise, so the check
// is as sharp as the bake's own error bar.
//
// An exact bake against the exact reference: its recorded error is an estimated bound, so a texel fails
// when |lut - exact| > e_lut + e_exact + float rounding (the limit on z is 1).
//
// reference = sampled: the scalar double oracle on a point set with an independent seed and `samples`
// samples (0: the bake's batch size), at the reference grid for adaptive bakes; a texel fails when
// |lut - oracle| > t * sqrt(se_lut^2 + se_oracle^2) + float rounding.
BakeVerification verify_bake(const BakeSpec& spec, const BakeResult& result, std::size_t count,
                             std::uint64_t samples = 0, unsigned threads = 0, Method reference = Method::exact);

// The check as the file's metadata records it ("verify": method, texels, failed, worst z, threshold,
// worst |diff|, largest reference error).
nlohmann::json verification_record(const BakeVerification& check);
// Throws std::runtime_error ("verification failed: ... nothing was written") when a texel failed.
void throw_if_failed(const BakeVerification& check);

}  // namespace ms
