// Compiled with -O3 -march=native -fno-math-errno -fopenmp (see bench/CMakeLists.txt); nothing else in
// the project is. The loop mirrors kernels/generic_term.cl operation by operation (same polynomial
// sincos, same fma placement, same tangent-form cone tests without a normalisation) so the counts
// agree with the kernel's up to samples that sit on a threshold within float rounding; see
// borderline_samples().
#include "baseline/baseline_tally.hpp"

#include <omp.h>

#include <cmath>

namespace ms::bench {

namespace {

struct Prepared {
    float ax, ay, wx, wy, wz, ox, oy, oz;
    float k2, p1x, p1y, p2x, p2y, p2z;  // cot^2 of the cone and the scaled frame around wo (see the kernel)
    // Provably zero (the kernel's guard). An int, not a bool: a bool member kept GCC from vectorising
    // loops that read the struct ("no vectype for stmt", -fopt-info-vec-missed).
    int zero;
};

Prepared prepare(const ms_query& q) {
    Prepared p{};
    p.zero = q.wo_z <= 0.0f || q.sin2_cone <= 0.0f || q.wo_z < 1.0f - 2.0f * q.sin2_cone - 0x1p-22f;
    const float sx = q.alpha_x * q.wi_x, sy = q.alpha_y * q.wi_y, sz = q.wi_z;
    const float inv = 1.0f / std::sqrt(sx * sx + sy * sy + sz * sz);
    p.ax = q.alpha_x, p.ay = q.alpha_y;
    p.wx = sx * inv, p.wy = sy * inv, p.wz = sz * inv;
    p.ox = q.wo_x, p.oy = q.wo_y, p.oz = q.wo_z;
    const float k = q.cos_theta / std::sqrt(q.sin2_cone);
    p.k2 = k * k;
    const float r = std::sqrt(std::fma(q.wo_x, q.wo_x, q.wo_y * q.wo_y));
    const bool polar = r < 1e-18f;
    const float cos_po = polar ? 1.0f : q.wo_x / r, sin_po = polar ? 0.0f : q.wo_y / r;
    p.p1x = -k * sin_po, p.p1y = k * cos_po;
    p.p2x = -k * q.wo_z * cos_po, p.p2y = -k * q.wo_z * sin_po, p.p2z = k * r;
    return p;
}

// One sample's unnormalised microfacet normal m (see the kernel): returns the quantities its tests
// compare: mz, mx^2 + my^2, m.wo and e1^2 + e2^2 (k^2 |m x wo|^2 from the frame around wo).
inline void sample(const Prepared& p, float r1, float r2, float& mz, float& rho2, float& mdl, float& e2sum) {
    // sincos(2 pi r1): quadrant q = round(4 r1), remainder a in [-pi/4, pi/4], Taylor polynomials.
    const float t = r1 * 4.0f;
    const int qd = int(t + 0.5f);
    const float a = (t - float(qd)) * 1.57079632679489662f;
    const float a2 = a * a;
    const float sa = a * (1.0f + a2 * (-1.0f / 6.0f + a2 * (1.0f / 120.0f + a2 * (-1.0f / 5040.0f))));
    const float ca = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24.0f + a2 * (-1.0f / 720.0f + a2 * (1.0f / 40320.0f))));
    const int quadrant = qd & 3;
    const bool odd = (quadrant & 1) != 0;
    const float c = odd ? sa : ca;
    const float s_ = odd ? ca : sa;
    const float cos_phi = (quadrant == 1 || quadrant == 2) ? -c : c;
    const float sin_phi = quadrant >= 2 ? -s_ : s_;
    // Spherical cap in z, then unstretch (Dupuy & Benyoub 2023).
    const float z = std::fma(1.0f - r2, 1.0f + p.wz, -p.wz);
    const float one_minus_z2 = 1.0f - z * z;
    // A select, not std::fmax: fmaxf (NaN rules) has no vector form without -ffinite-math-only.
    const float s = std::sqrt(one_minus_z2 > 0.0f ? one_minus_z2 : 0.0f);
    const float mx = p.ax * std::fma(s, cos_phi, p.wx);
    const float my = p.ay * std::fma(s, sin_phi, p.wy);
    mz = z + p.wz;
    rho2 = std::fma(mx, mx, my * my);
    mdl = std::fma(mx, p.ox, std::fma(my, p.oy, mz * p.oz));
    const float e1 = std::fma(mx, p.p1x, my * p.p1y);
    const float e2 = std::fma(mx, p.p2x, std::fma(my, p.p2y, mz * p.p2z));
    e2sum = std::fma(e1, e1, e2 * e2);
}

ms_tally tally_range(const Prepared& p, const float* __restrict u1, const float* __restrict u2, std::uint32_t count) {
    if (p.zero) return {0u, 0u};
    const Prepared c = p;  // a local copy: no aliasing question for the vectoriser
    int cone = 0, hemisphere = 0;
    // Branch-free body so GCC if-converts it into masked vector code (checked with -fopt-info-vec).
#pragma omp simd reduction(+ : cone, hemisphere)
    for (std::uint32_t i = 0; i < count; ++i) {
        float mz, rho2, mdl, e2sum;
        sample(c, u1[i], u2[i], mz, rho2, mdl, e2sum);
        const int up = int(mz > 0.0f) & int(mdl > 0.0f);
        hemisphere += up;
        cone += up & int(mz * mz > c.k2 * rho2) & int(mdl * mdl > e2sum);
    }
    return {std::uint32_t(cone), std::uint32_t(hemisphere)};
}

}  // namespace

int baseline_threads() { return omp_get_max_threads(); }

void baseline_tally(const std::vector<ms_query>& queries, const float* u1, const float* u2, std::uint32_t n,
                    std::uint32_t replicates, std::vector<ms_tally>& out) {
    const std::size_t pairs = queries.size() * replicates;
    // Split replicates into chunks so there are a few items per thread for dynamic balancing, like the
    // OpenCL host code does; chunks stay long (>= 4096 points) so the loop runs at vector speed.
    std::uint32_t chunks = 1;
    while (pairs * chunks < std::size_t(8 * omp_get_max_threads()) && n / (chunks * 2) >= 4096) chunks *= 2;
    const std::uint32_t per_chunk = n / chunks;
    std::vector<ms_tally> items(pairs * chunks);
    std::vector<Prepared> prepared(queries.size());
    for (std::size_t q = 0; q < queries.size(); ++q) prepared[q] = prepare(queries[q]);
#pragma omp parallel for schedule(dynamic, 1)
    for (std::ptrdiff_t g = 0; g < std::ptrdiff_t(items.size()); ++g) {
        const std::size_t chunk = std::size_t(g) % chunks;
        const std::size_t pair = std::size_t(g) / chunks;
        const std::size_t q = pair / replicates, r = pair % replicates;
        const std::size_t first = r * n + chunk * per_chunk;
        items[std::size_t(g)] = tally_range(prepared[q], u1 + first, u2 + first, per_chunk);
    }
    out.assign(pairs, ms_tally{0u, 0u});
    for (std::size_t g = 0; g < items.size(); ++g) {
        out[g / chunks].cone += items[g].cone;
        out[g / chunks].hemisphere += items[g].hemisphere;
    }
}

std::uint64_t borderline_samples(const ms_query& q, const float* u1, const float* u2, std::uint32_t count, float margin) {
    const Prepared p = prepare(q);
    if (p.zero) return 0;
    std::uint64_t border = 0;
    auto near = [margin](float a, float b) { return std::fabs(a - b) <= margin * std::fmax(std::fabs(a), std::fabs(b)); };
    for (std::uint32_t i = 0; i < count; ++i) {
        float mz, rho2, mdl, e2sum;
        sample(p, u1[i], u2[i], mz, rho2, mdl, e2sum);
        // Each comparison of the kernel, with its scale: the sign tests against |m|, the cone tests
        // between their two sides.
        const float len = std::sqrt(std::fma(mz, mz, rho2));
        if (std::fabs(mz) <= margin * len || std::fabs(mdl) <= margin * len || near(mz * mz, p.k2 * rho2) ||
            near(mdl * mdl, e2sum))
            ++border;
    }
    return border;
}

}  // namespace ms::bench
