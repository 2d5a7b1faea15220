// The reference data set of the benchmarks: fixed queries and seed-3d LUT texels with high-precision
// values from the scalar double oracle (host/oracle/), computed once and cached in bench/data/.
//
// Error bound. Each value is a ratio estimate from R independent Owen scrambles of a Hammersley net
// (ms::evaluate on the oracle backend), with the standard error se of reduce_replicates().
//  - Queries: bound = t * se, t the two-sided 99.9 % Student-t quantile with R - 1 degrees of freedom.
//  - Texels (mean over the relative azimuth phi uniform in [0, pi]): the mean is the trapezoid rule T_K
//    over K intervals. The term is an even, 2 pi-periodic function of phi, so T_K on [0, pi] equals the
//    periodic trapezoid rule with 2K nodes and converges at least as fast as O(K^-2) (exponentially where
//    the term is smooth); |T_K - T_{K/2}| bounds the quadrature error of T_K in that regime (it is about
//    3x the error for O(K^-2), far more for faster convergence). All nodes share one point set, so their
//    sampling errors are correlated: se comes from the spread over replicates r of x_r = sum_j w_j
//    ratio_{j,r} (each x_r already carries the correlation), as reduce_replicates() does for one query.
//    bound = t * se + |T_K - T_{K/2}|.
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <ostream>
#include <stdexcept>

#include "bench.hpp"
#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "io/atomic_file.hpp"
#include "io/csv.hpp"
#include "sampling/point_set.hpp"

namespace ms::bench {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRoughness[4] = {0.1, 0.4, 0.7, 1.0};  // seed-3d channels r, g, b, a

const std::vector<std::string> kColumns = {"kind",  "lut_size", "lut_x", "lut_y", "lut_z", "channel",
                                           "visibility", "alpha_x", "alpha_y", "wi_x", "wi_y", "wi_z",
                                           "wo_x",  "wo_y",     "wo_z",  "value", "std_error", "error_bound"};

std::uint64_t mix64(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

Vec3 direction(double cos_theta, double phi_deg) {
    const double s = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta)), phi = phi_deg * kPi / 180.0;
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

bool zero_texel(int x, int y, int n) {
    const double v = (x + 0.5) / n, n_dot_l = (y + 0.5) / n;
    return in_zero_region(cone_cos_theta(v, AoWeighting::cosine), n_dot_l);
}

}  // namespace

Query lut_texel_query(int x, int y, int z, int channel, int n, double azimuth) {
    Query q;
    q.visibility = (x + 0.5) / n;
    const double n_dot_l = (y + 0.5) / n, n_dot_v = (z + 0.5) / n;
    q.alpha_x = q.alpha_y = kRoughness[channel] * kRoughness[channel];  // alpha = roughness^2
    q.wi = {std::sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v};
    const double s = std::sqrt(1.0 - n_dot_l * n_dot_l);
    q.wo = {s * std::cos(azimuth), s * std::sin(azimuth), n_dot_l};
    return q;
}

std::vector<RefEntry> reference_design(const ReferenceConfig& cfg) {
    if (cfg.azimuth_intervals < 2 || cfg.azimuth_intervals % 2) throw std::invalid_argument("azimuth intervals must be even");
    std::vector<RefEntry> out;
    // Queries: 6 microsurfaces (4 isotropic from smooth to rough, 2 anisotropic) x 8 configurations that
    // include grazing view (NdotV 0.02, 0.05), grazing light (NdotL 0.05), normal view, and DESIGN.md's
    // azimuth example (NdotV 0.2, v 0.5, NdotL 0.8 at 0 / 90 / 180 degrees). The view has azimuth 30
    // degrees so the anisotropic cases are not axis-aligned; the light's azimuth is relative to it.
    const double alphas[6][2] = {{0.01, 0.01}, {0.16, 0.16}, {0.49, 0.49}, {1.0, 1.0}, {0.05, 0.5}, {0.6, 0.08}};
    const double configs[8][4] = {// visibility, NdotV, NdotL, relative azimuth (degrees)
                                  {0.5, 0.2, 0.8, 0},    {0.5, 0.2, 0.8, 90},  {0.5, 0.2, 0.8, 180}, {0.3, 0.02, 0.9, 45},
                                  {0.8, 0.7, 0.05, 120}, {0.1, 1.0, 0.95, 0},  {0.65, 0.05, 0.3, 160}, {0.9, 0.4, 0.6, 30}};
    for (const auto& a : alphas)
        for (const auto& c : configs) {
            RefEntry e;
            e.kind = 0;
            e.query.visibility = c[0];
            e.query.alpha_x = a[0];
            e.query.alpha_y = a[1];
            e.query.wi = direction(c[1], 30.0);
            e.query.wo = direction(c[2], 30.0 + c[3]);
            out.push_back(e);
        }
    // Texels: a deterministic draw over the LUT outside the zero region, every eighth forced onto each
    // grazing or extreme edge (first/last NdotV slice, first/last NdotL row, smallest visibility).
    const int n = cfg.lut_size;
    std::uint64_t state = 0x7e7e1u;
    auto draw = [&](int bound) { return int(mix64(state++) % std::uint64_t(bound)); };
    for (int t = 0; t < cfg.texels; ++t) {
        RefEntry e;
        e.kind = 1;
        e.lut_size = n;
        e.channel = (t + t / 8) % 4;
        do {
            e.lut_x = draw(n), e.lut_y = draw(n), e.lut_z = draw(n);
            switch (t % 8) {
                case 0: e.lut_z = 0; break;
                case 1: e.lut_z = n - 1; break;
                case 2: e.lut_y = 0; break;
                case 3: e.lut_y = n - 1; break;
                case 4: e.lut_x = 0, e.lut_y = n - 1; break;
                default: break;
            }
        } while (zero_texel(e.lut_x, e.lut_y, n));
        e.query = lut_texel_query(e.lut_x, e.lut_y, e.lut_z, e.channel, n, 0.0);
        out.push_back(e);
    }
    return out;
}

std::vector<RefEntry> make_reference(const ReferenceConfig& cfg, std::ostream& log) {
    std::vector<RefEntry> entries = reference_design(cfg);
    auto backend = make_oracle_backend(cfg.threads);
    const TermOptions term;  // height-correlated, cosine-weighted AO: the bake's defaults
    const double t = student_t_quantile(0.999, int(cfg.replicates) - 1);

    std::vector<Query> queries;
    std::vector<std::size_t> query_index;
    for (std::size_t i = 0; i < entries.size(); ++i)
        if (entries[i].kind == 0) queries.push_back(entries[i].query), query_index.push_back(i);
    SamplingPlan plan;
    plan.samples = cfg.query_samples;
    plan.replicates = cfg.replicates;
    plan.seed = cfg.seed;
    log << "reference: " << queries.size() << " queries x " << plan.samples << " oracle samples\n" << std::flush;
    const auto q_est = evaluate(*backend, queries, term, plan);
    for (std::size_t k = 0; k < queries.size(); ++k) {
        RefEntry& e = entries[query_index[k]];
        e.value = q_est[k].term;
        e.std_error = q_est[k].std_error;
        e.error_bound = t * e.std_error;
    }

    // Texels: K + 1 azimuth nodes each, evaluated in one batch.
    const int K = cfg.azimuth_intervals;
    std::vector<Query> nodes;
    std::vector<std::size_t> texel_index;
    for (std::size_t i = 0; i < entries.size(); ++i) {
        if (entries[i].kind != 1) continue;
        texel_index.push_back(i);
        const RefEntry& e = entries[i];
        for (int j = 0; j <= K; ++j)
            nodes.push_back(lut_texel_query(e.lut_x, e.lut_y, e.lut_z, e.channel, e.lut_size, kPi * j / K));
    }
    plan.samples = cfg.node_samples;
    plan.seed = cfg.seed + 1;
    log << "reference: " << texel_index.size() << " texels x " << (K + 1) << " azimuth nodes x " << plan.samples
        << " oracle samples\n" << std::flush;
    // Per-replicate tallies (the backend is evaluate()'s, minus its bookkeeping: texels are never in the
    // zero region and have v < 1), so the standard error can come from per-replicate azimuth means.
    const PointSet points = make_point_set(plan);
    const std::size_t R = points.replicates;
    const Tallies tl = backend->tally(nodes, term, points);
    auto ratio = [](double c, double h) { return h > 0 ? c / h : 0.0; };
    for (std::size_t k = 0; k < texel_index.size(); ++k) {
        double full = 0, half = 0;
        std::vector<double> x(R, 0.0);  // replicate r's own trapezoid mean
        for (int j = 0; j <= K; ++j) {
            const std::size_t node = k * (K + 1) + std::size_t(j);
            double c = 0, h = 0;
            for (std::size_t r = 0; r < R; ++r) c += tl.cone[node * R + r], h += tl.hemisphere[node * R + r];
            const double w = (j == 0 || j == K) ? 0.5 / K : 1.0 / K;
            full += w * ratio(c, h);
            if (j % 2 == 0) half += ((j == 0 || j == K) ? 1.0 : 2.0) / K * ratio(c, h);
            for (std::size_t r = 0; r < R; ++r) x[r] += w * ratio(tl.cone[node * R + r], tl.hemisphere[node * R + r]);
        }
        double mean = 0, ss = 0;
        for (double v : x) mean += v / double(R);
        for (double v : x) ss += (v - mean) * (v - mean);
        RefEntry& e = entries[texel_index[k]];
        e.value = full;
        e.std_error = std::sqrt(ss / double(R * (R - 1)));
        e.error_bound = t * e.std_error + std::fabs(full - half);
    }
    return entries;
}

void write_reference(const std::string& path, const std::vector<RefEntry>& entries, const ReferenceConfig& cfg,
                     const std::string& command_line, double seconds) {
    check_writable_destination(path);
    AtomicFile file(path);
    auto& out = file.stream();
    for (std::size_t c = 0; c < kColumns.size(); ++c) out << (c ? "," : "") << kColumns[c];
    out << "\n";
    double max_bound = 0;
    for (const auto& e : entries) {
        const Query& q = e.query;
        const double row[] = {double(e.kind), double(e.lut_size), double(e.lut_x), double(e.lut_y), double(e.lut_z),
                              double(e.channel), q.visibility, q.alpha_x, q.alpha_y, q.wi.x, q.wi.y, q.wi.z, q.wo.x,
                              q.wo.y, q.wo.z, e.value, e.std_error, e.error_bound};
        for (std::size_t c = 0; c < std::size(row); ++c) out << (c ? "," : "") << format_number(row[c]);
        out << "\n";
        max_bound = std::max(max_bound, e.error_bound);
    }
    nlohmann::json meta = {{"program", "microshadow_bench " MICROSHADOW_VERSION},
                           {"command_line", command_line},
                           {"backend", "oracle (scalar double)"},
                           {"form", "height-correlated"},
                           {"ao_weighting", "cosine"},
                           {"sequence", "sobol (Owen-scrambled Hammersley nets)"},
                           {"query_samples", cfg.query_samples},
                           {"azimuth_node_samples", cfg.node_samples},
                           {"replicates", cfg.replicates},
                           {"seed", cfg.seed},
                           {"azimuth_rule", "trapezoid over [0, pi], " + std::to_string(cfg.azimuth_intervals) + " intervals"},
                           {"error_bound", "99.9% Student-t x std_error (+ |T_K - T_K/2| for texels); see bench/reference.cpp"},
                           {"max_error_bound", max_bound},
                           {"seconds", seconds}};
    AtomicFile meta_file(path + ".json");
    meta_file.stream() << meta.dump(2) << "\n";
    file.commit();
    meta_file.commit();
}

std::vector<RefEntry> load_reference(const std::string& path) {
    const NumericCsv csv = read_numeric_csv(path, kColumns);
    std::vector<RefEntry> out;
    for (std::size_t i = 0; i < csv.rows.size(); ++i) {
        const auto& r = csv.rows[i];
        RefEntry e;
        e.kind = int(r[0]);
        if (e.kind != 0 && e.kind != 1)
            throw CsvError(path + ":" + std::to_string(csv.lines[i]) + ": kind must be 0 (query) or 1 (texel)");
        e.lut_size = int(r[1]), e.lut_x = int(r[2]), e.lut_y = int(r[3]), e.lut_z = int(r[4]), e.channel = int(r[5]);
        if (e.kind == 1 && (e.channel < 0 || e.channel > 3 || e.lut_size < 1))
            throw CsvError(path + ":" + std::to_string(csv.lines[i]) + ": bad texel coordinates");
        e.query.visibility = r[6], e.query.alpha_x = r[7], e.query.alpha_y = r[8];
        e.query.wi = {r[9], r[10], r[11]};
        e.query.wo = {r[12], r[13], r[14]};
        e.value = r[15], e.std_error = r[16], e.error_bound = r[17];
        validate_query(e.query);
        out.push_back(e);
    }
    if (out.empty()) throw CsvError(path + ": no reference rows");
    return out;
}

std::string default_reference_path() { return std::string(MICROSHADOW_BENCH_DIR) + "/data/reference.csv"; }

}  // namespace ms::bench
