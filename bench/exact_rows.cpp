// The C++ exact evaluator's per-query path (exact_term_integrand.cpp): isotropic queries through one
// azimuth grid per row against exact::exact_term per query, in one process on one thread, interleaved.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "bench.hpp"
#include "core/query.hpp"
#include "exact/exact_term.hpp"
#include "integrands/exact_term/exact_term_integrand.hpp"

namespace ms::bench {

namespace {

Vec3 unit_direction(double cos_theta, double azimuth) {
    const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    return {s * std::cos(azimuth), s * std::sin(azimuth), cos_theta};
}

struct QuerySet {
    std::string name;
    std::vector<Query> queries;
};

// Isotropic query sets: the design reference region (visibility 0.5-0.98, roughness 0.3-0.9, NdotV
// 0.2-1) and the whole domain, one query a row, in the LUT's frame (view at azimuth 0) and at random
// orientations; and rows of 9 azimuth nodes over [0, pi] (a representation bake's texels).
std::vector<QuerySet> query_sets(std::size_t count) {
    std::mt19937_64 rng(36);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<QuerySet> sets;
    auto singles = [&](const std::string& name, double v_lo, double v_hi, double r_lo, double r_hi, double nv_lo, bool rotated) {
        QuerySet s{name, {}};
        for (std::size_t i = 0; i < count; ++i) {
            Query q;
            const double r = r_lo + (r_hi - r_lo) * u(rng), base = rotated ? 2 * kPi * u(rng) : 0;
            q.visibility = v_lo + (v_hi - v_lo) * u(rng);
            q.alpha_x = q.alpha_y = r * r;
            q.wi = unit_direction(nv_lo + (1 - nv_lo) * u(rng), base);
            q.wo = unit_direction(1e-3 + 0.999 * u(rng), base + kPi * u(rng));
            s.queries.push_back(normalised(q));
        }
        sets.push_back(std::move(s));
    };
    singles("design region, one a row", 0.5, 0.98, 0.3, 0.9, 0.2, false);
    singles("design region, rotated", 0.5, 0.98, 0.3, 0.9, 0.2, true);
    singles("whole domain, one a row", 0.02, 1.0, 0.05, 1.0, 0.02, false);
    singles("whole domain, rotated", 0.02, 1.0, 0.05, 1.0, 0.02, true);
    QuerySet rows{"rows of 9 azimuth nodes", {}};
    while (rows.queries.size() < count) {
        const double r = 0.05 + 0.95 * u(rng), v = 0.02 + 0.98 * u(rng), nv = 0.02 + 0.98 * u(rng), nl = 1e-3 + 0.999 * u(rng);
        for (int k = 0; k < 9; ++k) {
            Query q;
            q.visibility = v;
            q.alpha_x = q.alpha_y = r * r;
            q.wi = unit_direction(nv, 0);
            q.wo = unit_direction(nl, kPi * k / 8);
            rows.queries.push_back(normalised(q));
        }
    }
    sets.push_back(std::move(rows));
    return sets;
}

}  // namespace

Table run_exact_rows(const Options& opt) {
    const std::size_t count = opt.smoke ? 64 : 16384;
    const int repeats = opt.smoke ? 1 : 5;
    Table t;
    t.name = "exact per-query path: rows through the azimuth grid against exact_term per query (one thread)";
    t.columns = {"queries", "tolerance", "count", "rows_us_per_query", "per_query_us_per_query", "ratio_median", "ratio_min",
                 "ratio_max", "max_abs_difference", "max_difference_over_estimates"};
    const auto evaluator = exact_term::make_cpu_evaluator(1);
    for (const double tolerance : {1e-10, 1e-6})
        for (const QuerySet& set : query_sets(count)) {
            const std::vector<AoWeighting> weighting(set.queries.size(), AoWeighting::cosine);
            std::vector<double> ratios;
            double rows_s = 0, per_query_s = 0, max_diff = 0, max_ratio = 0;
            for (int r = 0; r < repeats; ++r) {
                std::vector<exact::ExactValue> rows, per_query(set.queries.size());
                const auto t0 = std::chrono::steady_clock::now();
                evaluator->terms(set.queries, weighting, tolerance, rows);
                const auto t1 = std::chrono::steady_clock::now();
                for (std::size_t i = 0; i < set.queries.size(); ++i) per_query[i] = exact::exact_term(set.queries[i], weighting[i], tolerance);
                const auto t2 = std::chrono::steady_clock::now();
                const double a = std::chrono::duration<double>(t1 - t0).count(), b = std::chrono::duration<double>(t2 - t1).count();
                rows_s += a, per_query_s += b;
                ratios.push_back(a / b);
                for (std::size_t i = 0; i < rows.size(); ++i) {
                    const double d = std::fabs(rows[i].term - per_query[i].term), both = rows[i].error + per_query[i].error;
                    max_diff = std::max(max_diff, d);
                    if (both > 0) max_ratio = std::max(max_ratio, d / both);
                }
            }
            std::sort(ratios.begin(), ratios.end());
            const double n = double(set.queries.size()) * repeats;
            t.rows.push_back({set.name, fmt(tolerance, 2), std::to_string(set.queries.size()), fmt(rows_s / n * 1e6, 3),
                              fmt(per_query_s / n * 1e6, 3), fmt(ratios[ratios.size() / 2], 3), fmt(ratios.front(), 3),
                              fmt(ratios.back(), 3), fmt(max_diff, 3), fmt(max_ratio, 3)});
            if (opt.log) *opt.log << "exact-rows: " << set.name << " at " << tolerance << " done\n";
        }
    return t;
}

}  // namespace ms::bench
