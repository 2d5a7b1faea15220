#include "integrands/area_light/area_light_integrand.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/cancel.hpp"
#include "core/cone.hpp"
#include "core/estimate.hpp"
#include "integrands/area_light/light_geometry.hpp"
#include "microshadow_shared.h"
#include "oracle/area_light_oracle.hpp"

namespace ms::area {

static_assert(sizeof(ms_area_query) == 128, "ms_area_query layout must match the OpenCL C struct");

namespace {

double smith_lambda(const Vec3& w, double ax, double ay) {
    const double a = (ax * ax * w.x * w.x + ay * ay * w.y * w.y) / (w.z * w.z);
    return a / (2.0 * (1.0 + std::sqrt(1.0 + a)));
}

void put(float& x, float& y, float& z, const Vec3& v) { x = float(v.x), y = float(v.y), z = float(v.z); }

ms_area_query pack(const AreaQuery& q, const TermOptions& options) {
    ms_area_query p{};
    const double cos_t = cone_cos_theta(q.visibility, options.ao_weighting);
    const double sin2 = cone_sin2_theta(q.visibility, options.ao_weighting);
    p.cos_theta = float(cos_t);
    p.sin2_cone = float(sin2);
    p.cot2_cone = float(cos_t * cos_t / sin2);
    p.alpha_x = float(q.alpha_x);
    p.alpha_y = float(q.alpha_y);
    put(p.wi_x, p.wi_y, p.wi_z, q.wi);
    put(p.wis_x, p.wis_y, p.wis_z, unit({q.alpha_x * q.wi.x, q.alpha_y * q.wi.y, q.wi.z}));
    p.lambda_i = float(smith_lambda(q.wi, q.alpha_x, q.alpha_y));
    p.lobe = q.lobe == Lobe::lambert ? MS_LOBE_LAMBERT : MS_LOBE_GGX;
    p.cosine_technique = uses_cosine_technique(q) ? 1u : 0u;
    if (is_point_limit(q.light)) {
        // The point light at the centre: a cone of no width (every sample is the centre direction, no lobe
        // sample falls inside) of a stand-in density 1. Every light sample then has the same weight, so the
        // ratio is the term at the centre whatever the density; the lobe integral is set on the host.
        p.shape = MS_LIGHT_SPHERE;
        const Vec3 c = centre_direction(q.light);
        const Vec3 helper = std::fabs(c.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
        const Vec3 t1 = unit(cross(helper, c)), t2 = cross(c, t1);
        put(p.a_x, p.a_y, p.a_z, c);
        put(p.b_x, p.b_y, p.b_z, t1);
        put(p.c_x, p.c_y, p.c_z, t2);
        p.s0 = p.s1 = 0;
        p.inv_measure = 1;
        p.cosine_technique = 0;
    } else if (q.light.shape == LightShape::sphere) {
        p.shape = MS_LIGHT_SPHERE;
        const Vec3 c = q.light.sphere.centre;
        const Vec3 helper = std::fabs(c.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
        const Vec3 t1 = unit(cross(helper, c)), t2 = cross(c, t1);
        put(p.a_x, p.a_y, p.a_z, c);
        put(p.b_x, p.b_y, p.b_z, t1);
        put(p.c_x, p.c_y, p.c_z, t2);
        const double sh = std::sin(q.light.sphere.half_angle / 2);
        const double one_minus_cos = 2 * sh * sh;  // without the cancellation of 1 - cos for small gamma
        const double s = std::sin(q.light.sphere.half_angle);
        p.s0 = float(one_minus_cos);
        p.s1 = float(s * s);
        p.inv_measure = float(1.0 / (2 * kPi * one_minus_cos));
    } else {
        p.shape = MS_LIGHT_RECT;
        // Directions do not change when every position is scaled: bring the rectangle to unit distance
        // so float holds it whatever the scene's units.
        const auto& k = q.light.rect.corners;
        const Vec3 centre = scale({k[0].x + k[2].x, k[0].y + k[2].y, k[0].z + k[2].z}, 0.5);
        const double s = 1.0 / std::hypot(centre.x, centre.y, centre.z);
        const Vec3 p0 = scale(k[0], s), e1 = scale(sub(k[1], k[0]), s), e2 = scale(sub(k[3], k[0]), s);
        Vec3 n = cross(e1, e2);
        const double area = std::hypot(n.x, n.y, n.z);
        n = scale(n, 1.0 / area);
        double d = dot(n, p0);
        if (d < 0) n = scale(n, -1.0), d = -d;
        put(p.a_x, p.a_y, p.a_z, p0);
        put(p.b_x, p.b_y, p.b_z, e1);
        put(p.c_x, p.c_y, p.c_z, e2);
        put(p.n_x, p.n_y, p.n_z, n);
        p.s0 = float(d);
        p.inv_measure = float(1.0 / area);
    }
    return p;
}

// Per-replicate sums of one query (the device sums its chunks; the host estimator its directions).
struct ReplicateSums {
    std::vector<double> numerator, denominator;
    double passed = 0, weighted = 0;
    double weighted_inner_error = 0;  // Sum W/p |e| over every replicate (a given inner term's own errors)
    explicit ReplicateSums(std::size_t R) : numerator(R, 0.0), denominator(R, 0.0) {}
};

// points: per replicate, so that the lobe integral is the mean of W / p.
AreaEstimate finish(const ReplicateSums& s, std::uint32_t points) {
    AreaEstimate e;
    e.sampled = true;
    e.term = reduce_area_replicates(s.numerator, s.denominator, s.passed, s.weighted);
    const std::size_t R = s.numerator.size();
    std::vector<double> counts(R, double(points));
    e.lobe_integral = reduce_replicates(s.denominator.data(), counts.data(), R);
    double total = 0;
    for (double d : s.denominator) total += d;
    e.inner_error = total > 0 ? s.weighted_inner_error / total : 0.0;
    return e;
}

class DeviceWorker final : public schedule::Worker {
public:
    DeviceWorker(AreaIntegrand& owner, ocl::Device& device) : owner_(owner), device_(device) {
        ocl::require_build_support(device_.info(), owner_.config().build);
    }

    void run(std::uint64_t id) override {
        const std::vector<std::size_t> todo = owner_.answer_exact(id);
        if (todo.empty()) return;
        const JointPointSet& pts = owner_.points();
        upload(pts);
        const std::uint32_t R = pts.normals.replicates, n = pts.normals.points_per_replicate;
        const AreaRoutineConfig& config = owner_.config();
        // Chunks: at most max_points_per_work_item points per work-item (float lane sums), and enough
        // work-items to keep the device busy.
        std::uint32_t chunks = 1;
        while (n / chunks > config.max_points_per_work_item) chunks *= 2;
        const std::size_t target = std::size_t(device_.info().compute_units) * (device_.info().type == "GPU" ? 2048 : 8);
        while (todo.size() * R * chunks < target && n / (chunks * 2) >= 256) chunks *= 2;
        std::vector<ms_area_query> packed;
        packed.reserve(todo.size());
        for (std::size_t i : todo) packed.push_back(pack(owner_.queries()[i], owner_.options()));
        const std::size_t items = todo.size() * R * chunks;
        std::vector<float> sums(items * 32);
        std::vector<cl_uint> counts(items * 2);
        ocl::checked([&] {
            cl::Kernel kernel = device_.kernel("area_light/area_light.cl", "ms_area_light_tally", config.build);
            const std::size_t local = ocl::local_size(kernel, device_.info(), config.local_size);
            cl::Buffer qbuf(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(ms_area_query),
                            packed.data());
            cl::Buffer sbuf(device_.context(), CL_MEM_WRITE_ONLY, sums.size() * sizeof(float));
            cl::Buffer cbuf(device_.context(), CL_MEM_WRITE_ONLY, counts.size() * sizeof(cl_uint));
            kernel.setArg(0, qbuf);
            kernel.setArg(1, cl_uint(todo.size()));
            kernel.setArg(2, normals_.u1);
            kernel.setArg(3, normals_.u2);
            kernel.setArg(4, light_.u1);
            kernel.setArg(5, light_.u2);
            kernel.setArg(6, cl_uint(n));
            kernel.setArg(7, cl_uint(R));
            kernel.setArg(8, cl_uint(chunks));
            kernel.setArg(9, sbuf);
            kernel.setArg(10, cbuf);
            device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(ocl::round_up(items, local)),
                                                 cl::NDRange(local));
            device_.queue().enqueueReadBuffer(sbuf, CL_FALSE, 0, sums.size() * sizeof(float), sums.data());
            device_.queue().enqueueReadBuffer(cbuf, CL_TRUE, 0, counts.size() * sizeof(cl_uint), counts.data());
            return 0;
        });
        for (std::size_t k = 0; k < todo.size(); ++k) {
            ReplicateSums s(R);
            for (std::uint32_t r = 0; r < R; ++r)
                for (std::uint32_t c = 0; c < chunks; ++c) {
                    const std::size_t g = (k * R + r) * chunks + c;
                    for (int lane = 0; lane < 16; ++lane) {
                        s.numerator[r] += sums[g * 32 + lane];
                        s.denominator[r] += sums[g * 32 + 16 + lane];
                    }
                    s.passed += counts[2 * g];
                    s.weighted += counts[2 * g + 1];
                }
            AreaEstimate e = finish(s, n);
            const AreaQuery& q = owner_.queries()[todo[k]];
            // A point light's stand-in density says nothing of its lobe integral: f cos at the centre times
            // the solid angle.
            if (is_point_limit(q.light)) e.lobe_integral = {lobe_weight(q, centre_direction(q.light)) * solid_angle(q.light), 0.0};
            owner_.store(todo[k], e);
        }
        owner_.count_sampled(todo.size());
    }

private:
    void upload(const JointPointSet& pts) {
        if (uploaded_ == &pts) return;
        normals_ = ocl::upload_points(device_, pts.normals.u1, pts.normals.u2);
        light_ = ocl::upload_points(device_, pts.u3, pts.u4);
        uploaded_ = &pts;
    }
    AreaIntegrand& owner_;
    ocl::Device& device_;
    const JointPointSet* uploaded_ = nullptr;
    ocl::PointBuffers normals_, light_;
};

class OracleWorker final : public schedule::Worker {
public:
    explicit OracleWorker(AreaIntegrand& owner) : owner_(owner) {
        // Outer light directions and inner normals share the plan's samples per replicate n:
        // J = 2^max(4, m - max(10, ceil(m/2))) directions of M = n / J normals each (M >= 1024 from
        // n = 2^14 on, so the inner ratio's second-order bias stays far below the error bars).
        const SamplingPlan& plan = owner_.plan();
        const std::uint64_t n = plan.samples / plan.replicates;
        int m = 0;
        while ((std::uint64_t(1) << m) < n) ++m;
        const int mj = std::max(4, m - std::max(10, (m + 1) / 2));
        const std::uint64_t J = std::uint64_t(1) << mj, M = std::max<std::uint64_t>(16, n / J);
        SamplingPlan light = plan, normals = plan;
        light.samples = J * plan.replicates;
        light.seed = plan.seed ^ 0x6c69676874ull;  // "light": independent of the normals' scrambles
        normals.samples = M * plan.replicates;
        light_ = make_point_set(light);
        normals_ = make_point_set(normals);
    }
    void run(std::uint64_t id) override {
        const std::vector<std::size_t> todo = owner_.answer_exact(id);
        for (std::size_t i : todo) {
            const oracle::AreaTerm t = oracle::area_term(owner_.queries()[i], owner_.options(), light_, normals_);
            AreaEstimate e;
            e.sampled = true;
            e.term = t.term;
            e.lobe_integral = t.lobe_integral;
            owner_.store(i, e);
        }
        owner_.count_sampled(todo.size());
    }

private:
    AreaIntegrand& owner_;
    PointSet light_, normals_;
};

// The point query of the area query's surface towards the light direction wo.
Query surface_towards(const AreaQuery& q, const Vec3& wo) {
    Query point;
    point.visibility = q.visibility;
    point.alpha_x = q.alpha_x;
    point.alpha_y = q.alpha_y;
    point.wi = q.wi;
    point.wo = wo;
    return point;
}

class InnerTermWorker final : public schedule::Worker {
public:
    explicit InnerTermWorker(AreaIntegrand& owner) : owner_(owner) {}
    void run(std::uint64_t id) override {
        const std::vector<std::size_t> todo = owner_.answer_exact(id);
        if (todo.empty()) return;
        const JointPointSet& pts = owner_.points();
        const std::uint32_t R = pts.normals.replicates, n = pts.normals.points_per_replicate;
        for (std::size_t i : todo) {
            const AreaQuery& q = owner_.queries()[i];
            if (is_point_limit(q.light)) {
                // The point light at the centre: the inner term there, its error the inner term's own.
                const Query point = surface_towards(q, centre_direction(q.light));
                const InnerValue t = owner_.config().inner_term(point);
                AreaEstimate e;
                e.sampled = true;
                e.term = {t.term, 0.0};
                e.inner_error = std::fabs(t.error);
                e.lobe_integral = {lobe_weight(q, point.wo) * solid_angle(q.light), 0.0};
                owner_.store(i, e);
                continue;
            }
            ReplicateSums s(R);
            for (std::uint32_t r = 0; r < R; ++r) {
                throw_if_cancelled();
                for (std::uint32_t j = 0; j < n; ++j) {
                    const std::size_t k = std::size_t(r) * n + j;
                    const LightSample ls = sample_light(q, pts.u3[k], pts.u4[k]);
                    if (!(ls.weight > 0)) continue;
                    const InnerValue t = owner_.config().inner_term(surface_towards(q, ls.wo));
                    s.numerator[r] += ls.weight * t.term;
                    s.denominator[r] += ls.weight;
                    s.weighted_inner_error += ls.weight * std::fabs(t.error);
                    s.passed += t.term > 0;
                    s.weighted += 1;
                }
            }
            owner_.store(i, finish(s, n));
        }
        owner_.count_sampled(todo.size());
    }

private:
    AreaIntegrand& owner_;
};

}  // namespace

ExactCase classify(const AreaQuery& q, AoWeighting ao_weighting) {
    const double top = max_height(q.light);
    if (!(top > 0)) return ExactCase::below_horizon;
    const double cos_t = cone_cos_theta(q.visibility, ao_weighting);
    if (in_zero_region(cos_t, top)) return ExactCase::zero_region;
    if (q.visibility == 1.0) return ExactCase::visibility_one;
    return ExactCase::none;
}

Estimate reduce_area_replicates(const std::vector<double>& numerator, const std::vector<double>& denominator,
                                double passed, double weighted) {
    const std::size_t R = numerator.size();
    Estimate e = reduce_replicates(numerator.data(), denominator.data(), R);
    // As for the term: no sample passed in any replicate, so the spread says nothing. Report the
    // binomial bound on the fraction of weighted samples that could pass unseen, scaled so that the
    // 99.9 % bar (t x std_error) equals it.
    if (e.std_error == 0 && passed == 0 && weighted > 0) {
        const double t999 = R > 1 ? student_t_quantile(0.999, int(R) - 1) : 1.0;
        e.std_error = binomial_zero_bound(weighted, 0.999) / t999;
    }
    return e;
}

AreaIntegrand::AreaIntegrand(std::vector<AreaQuery> queries, TermOptions options, const SamplingPlan& plan,
                             AreaRoutineConfig config, std::size_t queries_per_item)
    : options_(options), plan_(plan), config_(std::move(config)), per_item_(std::max<std::size_t>(1, queries_per_item)) {
    if (plan.replicates == 0 || plan.samples / plan.replicates < 32)
        throw std::invalid_argument("area lights need at least 32 samples per replicate");
    queries_.reserve(queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
        try {
            validate(queries[i]);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("query " + std::to_string(i + 1) + ": " + e.what());
        }
        queries_.push_back(normalised(queries[i]));
    }
    results_.resize(queries_.size());
}

const JointPointSet& AreaIntegrand::points() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!points_) points_ = std::make_unique<JointPointSet>(make_joint_point_set(plan_));
    return *points_;
}

std::vector<std::size_t> AreaIntegrand::answer_exact(std::uint64_t id) {
    std::vector<std::size_t> todo;
    const std::size_t first = std::size_t(id) * per_item_, last = std::min(queries_.size(), first + per_item_);
    for (std::size_t i = first; i < last; ++i) {
        AreaEstimate e;
        switch (classify(queries_[i], options_.ao_weighting)) {
        case ExactCase::below_horizon: ++stats_.below_horizon; break;
        case ExactCase::zero_region: ++stats_.zero_region; break;
        case ExactCase::visibility_one: e.term = {1.0, 0.0}; ++stats_.visibility_one; break;
        case ExactCase::none: todo.push_back(i); continue;
        }
        results_[i] = e;
    }
    return todo;
}

std::unique_ptr<schedule::Worker> AreaIntegrand::device_worker(ocl::Device& device) {
    if (config_.inner_term) return std::make_unique<InnerTermWorker>(*this);
    return std::make_unique<DeviceWorker>(*this, device);
}

std::unique_ptr<schedule::Worker> AreaIntegrand::oracle_worker() {
    if (config_.inner_term) return std::make_unique<InnerTermWorker>(*this);
    return std::make_unique<OracleWorker>(*this);
}

std::size_t area_queries_per_item(bool oracle, const SamplingPlan& plan, const AreaRoutineConfig& config) {
    const std::uint64_t budget = std::uint64_t(1) << (config.inner_term ? 14 : oracle ? 21 : 26);
    const std::uint64_t per = std::max<std::uint64_t>(1, budget / std::max<std::uint64_t>(1, plan.samples));
    return std::size_t(std::min<std::uint64_t>(per, config.max_batch_queries));
}

}  // namespace ms::area
