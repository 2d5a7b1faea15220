#include "sampling/joint_point_set.hpp"

namespace ms {

namespace {

// splitmix64's finaliser, for seeds independent of the ones make_point_set derives (other constants).
std::uint64_t mix(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

float unit_float(std::uint32_t bits) { return float(bits >> 8) * (1.0f / 16777216.0f); }

// Direction numbers v_k (0.32 fixed point) of a Sobol' dimension with primitive polynomial of degree s
// and inner coefficients a (bit j-1 of a is a_j), initial m_1..m_s: v_k = a_1 v_{k-1} ^ ... ^
// a_{s-1} v_{k-s+1} ^ v_{k-s} ^ (v_{k-s} >> s) (Bratley & Fox 1988).
struct DirectionNumbers {
    std::uint32_t v[32];
    DirectionNumbers(int s, std::uint32_t a, const std::uint32_t* m) {
        for (int k = 0; k < s; ++k) v[k] = m[k] << (31 - k);
        for (int k = s; k < 32; ++k) {
            std::uint32_t x = v[k - s] ^ (v[k - s] >> s);
            for (int j = 1; j < s; ++j)
                if ((a >> (s - 1 - j)) & 1u) x ^= v[k - j];
            v[k] = x;
        }
    }
    std::uint32_t apply(std::uint32_t i) const {
        std::uint32_t x = 0;
        for (int k = 0; i; ++k, i >>= 1)
            if (i & 1u) x ^= v[k];
        return x;
    }
};

const DirectionNumbers& dimension3() {
    static const std::uint32_t m[2] = {1, 3};
    static const DirectionNumbers d(2, 1u, m);
    return d;
}

}  // namespace

std::uint32_t sobol_dimension3(std::uint32_t i) { return dimension3().apply(i); }

JointPointSet make_joint_point_set(const SamplingPlan& plan) {
    JointPointSet ps;
    ps.normals = make_point_set(plan);  // validates the plan
    const std::uint32_t n = ps.normals.points_per_replicate;
    ps.u3.resize(ps.total());
    ps.u4.resize(ps.total());
    for (std::uint32_t r = 0; r < ps.normals.replicates; ++r) {
        const std::uint64_t key = mix(plan.seed ^ mix(0x4a11000000000000ull + r));
        const std::uint32_t seed3 = std::uint32_t(mix(key ^ 0x35)), seed4 = std::uint32_t(mix(key ^ 0x6b));
        float* u3 = ps.u3.data() + std::uint64_t(r) * n;
        float* u4 = ps.u4.data() + std::uint64_t(r) * n;
        for (std::uint32_t i = 0; i < n; ++i) {
            if (plan.sequence == Sequence::sobol) {
                u3[i] = unit_float(owen_scramble(sobol_pascal(i), seed3));
                u4[i] = unit_float(owen_scramble(sobol_dimension3(i), seed4));
            } else {
                const std::uint64_t bits = mix(key ^ mix(0x7100000000000000ull + i));
                u3[i] = unit_float(std::uint32_t(bits));
                u4[i] = unit_float(std::uint32_t(bits >> 32));
            }
        }
    }
    return ps;
}

}  // namespace ms
