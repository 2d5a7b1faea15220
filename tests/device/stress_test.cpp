// Numerical stability at the extremes: the float OpenCL kernel against the double oracle on the SAME
// point set, over a grid of extreme roughness, anisotropy, view/light cosines and visibilities.
//
// Why the same points: both backends consume one ms::PointSet, so a difference is not sampling noise
// but the float kernel deciding a sample differently from the double oracle (a sample whose decisive
// dot product lies within float rounding of a cone boundary), or a systematic failure (a quantity the
// float kernel cannot represent). Each such "flip" moves the ratio by about 1 / hemisphere count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "jobs/eval.hpp"
#include "io/csv.hpp"
#include "device/runtime.hpp"
#include "oracle/oracle.hpp"
#include "sampling/point_set.hpp"

namespace ms {
namespace {

// The extremes of the domain. NdotV = 0 (wi at the horizon) is invalid input and tested separately.
const double kNdotV[] = {1e-7, 1e-3, 0.5, 1 - 1e-7, 1};
const double kNdotL[] = {0, 1e-7, 1e-3, 0.5, 1 - 1e-7, 1};
// Tiny visibilities down to 1e-12: float cos_t is 1 below ~6e-8, so these exercise the kernel's tangent
// form of the cone test (generic_term.cl). Below ~1e-12 the double oracle's own cosine test stops
// resolving 1 - cos_t = v/2 (double rounding ~1e-16), so it could no longer referee.
const double kVisibility[] = {0, 1e-12, 1e-10, 1e-7, 1e-5, 1e-3, 0.25, 0.5, 0.75, 1 - 1e-7, 1};
// Relative azimuth of wo to wi (radians); wi itself sits at 30 degrees, off both anisotropy axes.
const double kAzimuth[] = {0, M_PI / 2, M_PI};
constexpr double kPhiI = M_PI / 6;

struct Roughness {
    double ax, ay;
};
// alpha from 1e-4 to 1 isotropic, and alpha_x / alpha_y = 1000 both ways within [1e-4, 1].
const Roughness kRoughness[] = {{1e-4, 1e-4}, {1e-3, 1e-3}, {1e-2, 1e-2}, {0.1, 0.1}, {0.5, 0.5},
                                {1, 1},       {1, 1e-3},    {1e-3, 1},    {0.1, 1e-4}, {1e-4, 0.1}};

// A unit direction with the given cosine to the normal; exact (0,0,1) at cosine 1 (along the normal).
Vec3 direction(double cos_theta, double phi) {
    if (cos_theta == 1) return {0, 0, 1};
    const double s = std::sqrt((1 - cos_theta) * (1 + cos_theta));  // no cancellation near 1
    return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

struct Grid {
    std::vector<Query> queries;
    std::vector<std::string> labels;
    // Indices of queries that differ only in visibility (ascending), for the monotonicity check.
    std::vector<std::vector<std::size_t>> by_visibility;
};

Grid make_grid() {
    Grid g;
    for (const auto& r : kRoughness)
        for (double nv : kNdotV)
            for (double nl : kNdotL)
                for (double dphi : kAzimuth) {
                    if ((nv == 1 || nl == 1 || nl == 0) && dphi != 0) continue;  // azimuth undefined
                    std::vector<std::size_t> row;
                    for (double v : kVisibility) {
                        Query q;
                        q.visibility = v;
                        q.alpha_x = r.ax;
                        q.alpha_y = r.ay;
                        q.wi = direction(nv, kPhiI);
                        q.wo = direction(nl, kPhiI + dphi);
                        char label[200];
                        std::snprintf(label, sizeof label, "alpha=(%g,%g) NdotV=%.9g NdotL=%.9g dphi=%g deg v=%.9g",
                                      r.ax, r.ay, nv, nl, dphi * 180 / M_PI, v);
                        row.push_back(g.queries.size());
                        g.queries.push_back(q);
                        g.labels.push_back(label);
                    }
                    g.by_visibility.push_back(row);
                }
    return g;
}

std::unique_ptr<TermBackend> default_kernels() { return make_opencl_backend(ocl::select_devices("default")); }

// Small enough that the double oracle covers the ~4000-query grid in about a second per setting.
const SamplingPlan kPlan{Sequence::sobol, 4 * 1024, 4, 2024};

void expect_sane(const std::vector<Estimate>& r, const Grid& g, const std::string& who) {
    for (std::size_t i = 0; i < r.size(); ++i) {
        ASSERT_TRUE(std::isfinite(r[i].term) && std::isfinite(r[i].std_error)) << who << ": " << g.labels[i];
        ASSERT_GE(r[i].term, 0.0) << who << ": " << g.labels[i];
        ASSERT_LE(r[i].term, 1.0) << who << ": " << g.labels[i];
        ASSERT_GE(r[i].std_error, 0.0) << who << ": " << g.labels[i];
    }
    // Same points, growing cone: the cone condition set only grows with v, so tallies and the ratio
    // (same denominator) cannot decrease. Exact, no tolerance.
    for (const auto& row : g.by_visibility)
        for (std::size_t k = 1; k < row.size(); ++k)
            EXPECT_GE(r[row[k]].term, r[row[k - 1]].term) << who << ": not monotone at " << g.labels[row[k]];
}

// Cones the former cosine test could not resolve in float (1 - cos_t < 2^-12: up to 0.23 off at
// v = 1e-7). They are compared like every other query; the worst among them is reported apart.
bool tiny_cone(double visibility, AoWeighting ao) { return 1 - cone_cos_theta(visibility, ao) < 1.0 / 4096; }

struct Worst {
    double diff = 0;
    double flips = 0;  // the difference in samples: |diff| * hemisphere count
    std::string where;
    void update(double d, double f, const std::string& w) {
        if (d > diff) *this = {d, f, w};
    }
};

TEST(Stress, FloatKernelFollowsDoubleOracleAtTheExtremes) {
    const Grid g = make_grid();
    auto cl = default_kernels();
    auto oracle = make_oracle_backend();
    const PointSet points = make_point_set(kPlan);
    const std::size_t R = kPlan.replicates;
    // Two comparisons per query and weighting; Bonferroni keeps the family-wise false alarm <= 1e-3.
    const double k = student_t_quantile(1 - 1e-3 / double(2 * g.queries.size()), int(R) - 1);
    Worst worst, tiny_worst;
    std::size_t compared = 0, tiny = 0, sampled = 0;
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        const TermOptions opt{Form::height_correlated, ao};
        const auto a = evaluate(*cl, g.queries, opt, kPlan);
        EvalStats stats;
        const auto b = evaluate(*oracle, g.queries, opt, kPlan, &stats);
        sampled += stats.sampled;
        expect_sane(a, g, "opencl " + to_string(ao));
        expect_sane(b, g, "oracle " + to_string(ao));
        for (std::size_t i = 0; i < g.queries.size(); ++i) {
            const double diff = std::abs(a[i].term - b[i].term);
            // The kernel's hemisphere count: one sample decided differently moves the ratio by 1 / H.
            double hemi = 0;
            if (diff > 0) {
                const Tallies t = cl->tally({normalised(g.queries[i])}, opt, points);
                for (std::size_t r = 0; r < R; ++r) hemi += t.hemisphere[r];
            }
            const std::string where = g.labels[i] + " ao=" + to_string(ao);
            ++compared;
            worst.update(diff, diff * hemi, where);
            if (g.queries[i].visibility > 0 && tiny_cone(g.queries[i].visibility, ao)) {
                ++tiny;
                tiny_worst.update(diff, diff * hemi, where);
            }
            // Same points: what remains after the statistical error is at most one sample lying within
            // float rounding of a boundary (seen only where wo lies exactly on the cone, NdotL = cos_t).
            const double bound = k * std::hypot(a[i].std_error, b[i].std_error) + (hemi > 0 ? 1.0 / hemi : 0.0) + 1e-12;
            EXPECT_LE(diff, bound) << where << ": opencl " << a[i].term << " +- " << a[i].std_error << ", oracle "
                                   << b[i].term << " +- " << b[i].std_error;
        }
    }
    std::printf("[stress] %zu queries x 2 weightings (%zu sampled, %u x %u points each): %zu compared, worst "
                "|float - double| = %.3g (%.3g samples) at %s\n",
                g.queries.size(), sampled, kPlan.replicates, unsigned(kPlan.samples / kPlan.replicates), compared,
                worst.diff, worst.flips, worst.where.c_str());
    std::printf("[stress] of which tiny cones (1 - cos_t < 2^-12, 0 < v): %zu queries, worst %.3g (%.3g samples) at %s\n",
                tiny, tiny_worst.diff, tiny_worst.flips, tiny_worst.where.c_str());
}

TEST(Stress, FloatKernelResolvesConesOfEverySize) {
    // A family whose term hardly depends on the cone size: alpha = sin_t (the visible normals spread
    // over about the cone) and wo half a cone angle off the normal, so both cone conditions cut. The
    // former float cosine test was 0.04 off here at v = 1e-7 and counted nothing at 1e-9 (float cos_t
    // = 1); the tangent test must follow the oracle on the same points down to v = 1e-12, with a term
    // well inside (0, 1) so that agreement is not 0 = 0 or 1 = 1.
    auto cl = default_kernels();
    auto oracle = make_oracle_backend();
    const SamplingPlan plan{Sequence::sobol, 8 * 2048, 8, 77};
    const PointSet points = make_point_set(plan);
    const double visibilities[] = {1e-2, 1e-4, 1e-7, 1e-9, 1e-12};
    const double k = student_t_quantile(1 - 1e-3 / (2.0 * std::size(visibilities)), int(plan.replicates) - 1);
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        std::vector<Query> qs;
        for (double v : visibilities) {
            const double sin_t = std::sqrt(cone_sin2_theta(v, ao));
            const double half = 0.5 * std::asin(sin_t);  // from the sine: no cancellation for tiny angles
            Query q;
            q.visibility = v;
            q.alpha_x = sin_t;
            q.alpha_y = 0.7 * sin_t;
            q.wi = direction(0.6, 0.4);
            q.wo = {std::sin(half) * std::cos(2.0), std::sin(half) * std::sin(2.0), std::cos(half)};
            qs.push_back(q);
        }
        const TermOptions opt{Form::height_correlated, ao};
        const auto a = evaluate(*cl, qs, opt, plan);
        const auto b = evaluate(*oracle, qs, opt, plan);
        for (std::size_t i = 0; i < qs.size(); ++i) {
            const Tallies t = cl->tally({normalised(qs[i])}, opt, points);
            double hemi = 0;
            for (double h : t.hemisphere) hemi += h;
            ASSERT_GT(hemi, 0);
            const double bound = k * std::hypot(a[i].std_error, b[i].std_error) + 1.0 / hemi;
            EXPECT_GT(b[i].term, 0.05) << "v=" << qs[i].visibility << " ao=" << to_string(ao);
            EXPECT_LT(b[i].term, 0.95) << "v=" << qs[i].visibility << " ao=" << to_string(ao);
            EXPECT_LE(std::abs(a[i].term - b[i].term), bound)
                << "v=" << qs[i].visibility << " ao=" << to_string(ao) << ": opencl " << a[i].term << " +- "
                << a[i].std_error << ", oracle " << b[i].term << " +- " << b[i].std_error;
        }
    }
}

TEST(Stress, ViewAtTheHorizonIsRejected) {
    // wi.z = 0 makes the VNDF degenerate (the visible projected area is 0): invalid input, rejected
    // before any device work, however it is spelled.
    auto oracle = make_oracle_backend();
    for (const Vec3 wi : {Vec3{1, 0, 0}, Vec3{0, -1, 0}, Vec3{0.6, 0.8, 0}, Vec3{1, 0, -0.0}, Vec3{1, 0, -1e-300}}) {
        Query q;
        q.wi = wi;
        q.visibility = 0.5;
        EXPECT_THROW(validate_query(q), std::invalid_argument) << wi.x << "," << wi.y << "," << wi.z;
        EXPECT_THROW(evaluate(*oracle, {q}, {}, kPlan), std::invalid_argument);
    }
    // Grazing but valid: wi.z or wo.z so small that tan^2 overflows (z^2 underflows to 0). Smith
    // Lambda is then +inf (G1 = 0), never inf / inf; both backends must give a finite term in [0, 1].
    for (const auto& [wi, wo] : {std::pair{Vec3{1, 0, 1e-160}, direction(0.8, 0.3)},
                                 std::pair{Vec3{1, 0, 4.9e-324}, direction(0.8, 0.3)},
                                 std::pair{direction(0.5, 0.2), Vec3{0.8, 0.6, 1e-160}}}) {
        Query q;
        q.wi = wi;
        q.wo = wo;
        q.visibility = 0.9;  // outside the zero region even for wo at the horizon (2 v + NdotL > 1)
        for (auto* backend : {default_kernels().release(), make_oracle_backend().release()}) {
            std::unique_ptr<TermBackend> owned(backend);
            for (Form form : {Form::height_correlated, Form::uncorrelated}) {
                const auto r = evaluate(*owned, {q}, {form, AoWeighting::cosine}, kPlan);
                EXPECT_TRUE(std::isfinite(r[0].term) && r[0].term >= 0 && r[0].term <= 1)
                    << owned->name() << " " << to_string(form) << ": wi.z " << wi.z << " wo.z " << wo.z << ": " << r[0].term;
            }
        }
    }
}

TEST(Stress, BothFormsAgreeOnTheSamePointsAtTheExtremes) {
    // The Smith weight is constant per query apart from H(wo.wm) (generic_term.cl's header), so the
    // weighted oracle must give the same ratio in both forms, and the kernel (which drops the weight)
    // the same bits. Checked on the extreme grid's queries with 0 < v < 1 (tiny cones included) of one
    // roughness pair per anisotropy class to keep the double oracle's time small.
    const Grid g = make_grid();
    std::vector<Query> subset;
    for (std::size_t i = 0; i < g.queries.size(); ++i) {
        const Query& q = g.queries[i];
        const bool picked = (q.alpha_x == 1e-4 && q.alpha_y == 1e-4) || (q.alpha_x == 1 && q.alpha_y == 1e-3) ||
                            (q.alpha_x == 1e-4 && q.alpha_y == 0.1);
        if (picked && q.visibility > 0 && q.visibility < 1) subset.push_back(q);
    }
    auto cl = default_kernels();
    auto oracle = make_oracle_backend();
    for (AoWeighting ao : {AoWeighting::cosine, AoWeighting::uniform}) {
        const auto hc = evaluate(*oracle, subset, {Form::height_correlated, ao}, kPlan);
        const auto un = evaluate(*oracle, subset, {Form::uncorrelated, ao}, kPlan);
        const auto k_hc = evaluate(*cl, subset, {Form::height_correlated, ao}, kPlan);
        const auto k_un = evaluate(*cl, subset, {Form::uncorrelated, ao}, kPlan);
        for (std::size_t i = 0; i < subset.size(); ++i) {
            // Equal up to the rounding of two compensated double sums and one division.
            EXPECT_NEAR(hc[i].term, un[i].term, 1e-12) << i;
            EXPECT_EQ(k_hc[i].term, k_un[i].term) << i;
            EXPECT_EQ(k_hc[i].std_error, k_un[i].std_error) << i;
        }
    }
}

}  // namespace
}  // namespace ms
