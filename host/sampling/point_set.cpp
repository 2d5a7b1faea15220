#include "sampling/point_set.hpp"

#include <algorithm>
#include <list>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>

namespace ms {

namespace {

// splitmix64 finaliser: a bijective 64-bit mixer, used to derive independent seeds and random bits.
std::uint64_t mix64(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

// Keep the top 24 bits so the value is exactly representable in float and strictly below 1.
float to_unit_float(std::uint32_t bits) { return float(bits >> 8) * (1.0f / 16777216.0f); }

bool is_power_of_two(std::uint64_t x) { return x && !(x & (x - 1)); }

// The per-replicate key every scramble seed of replicate r derives from.
std::uint64_t replicate_key(std::uint64_t seed, std::uint32_t r) { return mix64(seed ^ mix64(r + 1)); }

}  // namespace

std::uint32_t reverse_bits(std::uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}

// Nested uniform scrambling flips each bit of x depending only on the bits above it. In bit-reversed
// order "the bits above" become "the bits below", and a multiply-xorshift hash whose every step only
// propagates information upwards (x * odd, x ^ (x * even)) has exactly that dependency structure.
// Constants from Burley, "Practical Hash-based Owen Scrambling", JCGT 2020.
std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) {
    x = reverse_bits(x);
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return reverse_bits(x);
}

std::uint64_t round_up_samples(std::uint64_t requested, std::uint32_t replicates) {
    if (replicates == 0) throw std::invalid_argument("replicates must be at least 1");
    std::uint64_t n = 16;
    while (n * replicates < requested) n <<= 1;
    return n * replicates;
}

PointSet make_point_set(const SamplingPlan& plan) {
    if (plan.replicates < 1 || plan.replicates > 1024)
        throw std::invalid_argument("replicates must be in [1, 1024], got " + std::to_string(plan.replicates));
    if (plan.samples % plan.replicates != 0)
        throw std::invalid_argument("samples (" + std::to_string(plan.samples) + ") must be a multiple of replicates");
    const std::uint64_t n = plan.samples / plan.replicates;
    if (!is_power_of_two(n) || n < 16 || n > (1ull << 28))
        throw std::invalid_argument("samples per replicate must be a power of two in [16, 2^28], got " + std::to_string(n));

    PointSet ps;
    ps.sequence = plan.sequence;
    ps.replicates = plan.replicates;
    ps.points_per_replicate = std::uint32_t(n);
    ps.seed = plan.seed;
    ps.u1.resize(ps.total());
    ps.u2.resize(ps.total());

    int m = 0;
    while ((1ull << m) < n) ++m;
    // Replicates are independent: generate them on all hardware threads (the output does not depend
    // on the thread count).
    auto generate = [&](std::uint32_t r) {
        const std::uint64_t rep_key = replicate_key(plan.seed, r);
        const std::uint32_t seed0 = std::uint32_t(mix64(rep_key ^ 0x51));
        const std::uint32_t seed1 = std::uint32_t(mix64(rep_key ^ 0xa3));
        float* u1 = ps.u1.data() + std::uint64_t(r) * n;
        float* u2 = ps.u2.data() + std::uint64_t(r) * n;
        for (std::uint32_t i = 0; i < n; ++i) {
            if (plan.sequence == Sequence::sobol) {
                const std::uint32_t x0 = m == 0 ? 0u : i << (32 - m);  // i / n in 0.32 fixed point
                const std::uint32_t x1 = reverse_bits(i);              // radical inverse of i
                u1[i] = to_unit_float(owen_scramble(x0, seed0));
                u2[i] = to_unit_float(owen_scramble(x1, seed1));
            } else {
                const std::uint64_t bits = mix64(rep_key ^ mix64(0x9000000000000000ull + i));
                u1[i] = to_unit_float(std::uint32_t(bits));
                u2[i] = to_unit_float(std::uint32_t(bits >> 32));
            }
        }
    };
    const unsigned threads = std::min<unsigned>(plan.replicates, std::max(1u, std::thread::hardware_concurrency()));
    if (threads <= 1 || ps.total() < (1u << 16)) {
        for (std::uint32_t r = 0; r < plan.replicates; ++r) generate(r);
    } else {
        std::vector<std::thread> pool;
        for (unsigned t = 0; t < threads; ++t)
            pool.emplace_back([&, t] {
                for (std::uint32_t r = t; r < plan.replicates; r += threads) generate(r);
            });
        for (auto& th : pool) th.join();
    }
    return ps;
}

std::uint32_t sobol_pascal(std::uint32_t i) {
    // Direction numbers of Sobol's dimension 2 (primitive polynomial x + 1): v_0 = 1/2,
    // v_j = v_{j-1} ^ (v_{j-1} >> 1); bit j of i selects v_j.
    std::uint32_t v = 0x80000000u, x = 0;
    for (; i; i >>= 1, v ^= v >> 1)
        if (i & 1u) x ^= v;
    return x;
}

PointSet make_cell_point_set(const SamplingPlan& plan, std::uint32_t cells) {
    PointSet ps = make_point_set(plan);
    const std::uint32_t n = ps.points_per_replicate;
    if (!is_power_of_two(cells) || std::uint64_t(cells) * 16 > n)
        throw std::invalid_argument("azimuth cells must be a power of two with 16 points per cell and replicate (" +
                                    std::to_string(cells) + " cells, " + std::to_string(n) + " points per replicate)");
    if (cells == 1 || plan.sequence != Sequence::sobol) return ps;  // random: index blocks are the cells
    int k = 0;
    while ((1u << k) < cells) ++k;
    const std::uint32_t per_cell = n / cells;
    std::vector<std::uint32_t> cell(n), next(cells);
    std::vector<float> u1(n), u2(n);
    for (std::uint32_t r = 0; r < ps.replicates; ++r) {
        const std::uint32_t seed2 = std::uint32_t(mix64(replicate_key(plan.seed, r) ^ 0xc7));
        for (std::uint32_t c = 0; c < cells; ++c) next[c] = c * per_cell;
        float* a = ps.u1.data() + std::uint64_t(r) * n;
        float* b = ps.u2.data() + std::uint64_t(r) * n;
        for (std::uint32_t i = 0; i < n; ++i) {
            const std::uint32_t c = owen_scramble(sobol_pascal(i), seed2) >> (32 - k);
            // A (0,m,3)-net puts exactly n / cells points into every slab of u3: a full cell is a bug.
            if (next[c] >= (c + 1) * per_cell) throw std::logic_error("make_cell_point_set: uneven cells");
            u1[next[c]] = a[i];
            u2[next[c]] = b[i];
            ++next[c];
        }
        std::copy(u1.begin(), u1.end(), a);
        std::copy(u2.begin(), u2.end(), b);
    }
    return ps;
}

std::shared_ptr<const PointSet> shared_point_set(const SamplingPlan& plan) { return shared_point_set(plan, 0); }

std::shared_ptr<const PointSet> shared_point_set(const SamplingPlan& plan, std::uint32_t cells) {
    using Key = std::tuple<int, std::uint64_t, std::uint32_t, std::uint64_t, std::uint32_t>;
    static std::mutex mutex;
    static std::list<std::pair<Key, std::shared_ptr<const PointSet>>> recent;  // most recent first
    const Key key{int(plan.sequence), plan.samples, plan.replicates, plan.seed, cells};
    std::lock_guard<std::mutex> lock(mutex);
    for (auto it = recent.begin(); it != recent.end(); ++it)
        if (it->first == key) {
            recent.splice(recent.begin(), recent, it);
            return recent.front().second;
        }
    auto points = std::make_shared<const PointSet>(cells ? make_cell_point_set(plan, cells) : make_point_set(plan));
    recent.emplace_front(key, points);
    // A handful of plans covers a bake's batches or a sweep's chunks; bound the memory.
    if (recent.size() > 4) recent.pop_back();
    return points;
}

}  // namespace ms
