// Deriving independent seeds: one mixer (SplitMix64's finaliser) for every place that needs a new
// randomisation from a user's seed (a bake's later batches, verification's independent points).
#pragma once

#include <cstdint>

namespace ms {

inline std::uint64_t mix64(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

// Batch 0 uses the seed itself (the same points as `eval --seed`); later batches derive independent
// seeds from (seed, batch).
inline std::uint64_t batch_seed(std::uint64_t seed, std::uint32_t batch) {
    return batch == 0 ? seed : mix64(seed ^ mix64(0xba7c4ull + batch));
}

}  // namespace ms
