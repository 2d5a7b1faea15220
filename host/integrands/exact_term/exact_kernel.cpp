#include "integrands/exact_term/exact_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/cone.hpp"
#include "exact/cap_region.hpp"
#include "exact/gauss_kronrod.hpp"
#include "exact/gauss_legendre.hpp"
#include "microshadow_shared.h"

namespace ms::exact {

static_assert(sizeof(ms_exact_query) == 80, "ms_exact_query layout");
static_assert(sizeof(ms_exact_texel) == 48, "ms_exact_texel layout");
static_assert(sizeof(ms_exact_rule) == 48, "ms_exact_rule layout");
static_assert(sizeof(ms_exact_value) == 32, "ms_exact_value layout");

namespace {

constexpr const char* kKernelFile = "exact/exact_term.cl";

// A double as two floats whose (double) sum is the double to ~48 bits: the float kernel reads hi.
void split(double x, float& hi, float& lo) {
    hi = static_cast<float>(x);
    lo = static_cast<float>(x - static_cast<double>(hi));
}
double join(float hi, float lo) { return static_cast<double>(hi) + static_cast<double>(lo); }

// The C++ evaluator's normalisation (scaled first, so extreme components neither under- nor overflow),
// so that both evaluators start from the same unit vectors.
Vec3 unit(const Vec3& a) {
    const double m = std::max({std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)});
    const Vec3 b{a.x / m, a.y / m, a.z / m};
    const double inv = 1.0 / std::sqrt(b.x * b.x + b.y * b.y + b.z * b.z);
    return {b.x * inv, b.y * inv, b.z * inv};
}

// The rules of a launch, packed as the kernel reads them (nodes then weights per rule), in the kernel's
// precision, with the launch's rule description.
struct LaunchRules {
    ms_exact_rule rule{};
    std::vector<double> table;
};

int append_rule(std::vector<double>& table, int n) {
    const GaussRule& g = gauss_legendre(n);
    const int at = static_cast<int>(table.size());
    table.insert(table.end(), g.nodes.begin(), g.nodes.end());
    table.insert(table.end(), g.weights.begin(), g.weights.end());
    return at;
}

// The Gauss-Kronrod pair of `gauss_nodes` as two rules on the same 2n + 1 nodes: the Kronrod weights
// and the Gauss weights (zero at the Kronrod-only nodes), so that the kernel evaluates each node once.
void append_kronrod_pair(std::vector<double>& table, int gauss_nodes, int& points, int& kronrod_at, int& gauss_at) {
    const KronrodRule& pair = gauss_kronrod(gauss_nodes);
    points = pair.points;
    kronrod_at = static_cast<int>(table.size());
    table.insert(table.end(), pair.nodes, pair.nodes + pair.points);
    table.insert(table.end(), pair.kronrod_weights, pair.kronrod_weights + pair.points);
    gauss_at = static_cast<int>(table.size());
    table.insert(table.end(), pair.nodes, pair.nodes + pair.points);
    table.insert(table.end(), pair.gauss_weights, pair.gauss_weights + pair.points);
}

// `tolerance` is the tolerance of each output value; the arc rule is the one the C++ evaluator uses for
// the terms it integrates (the mean's terms get a quarter of the mean's tolerance).
LaunchRules launch_rules(double tolerance, double term_tolerance) {
    LaunchRules r;
    const ArcRule arc = arc_rule_for(term_tolerance);
    const AzimuthRule azimuth = azimuth_rule_for(tolerance);
    r.rule.arc_high = arc.high;
    r.rule.arc_low = arc.low;
    r.rule.arc_high_at = append_rule(r.table, arc.high);
    r.rule.arc_low_at = append_rule(r.table, arc.low);
    append_kronrod_pair(r.table, azimuth.nodes, r.rule.azimuth_high, r.rule.azimuth_high_at, r.rule.azimuth_low_at);
    r.rule.azimuth_low = r.rule.azimuth_high;
    r.rule.arc_rho = static_cast<float>(arc.rho);  // 3, 3.5 or 4: exact in float
    split(tolerance, r.rule.tolerance_hi, r.rule.tolerance_lo);
    return r;
}

}  // namespace

ExactKernel::ExactKernel(ocl::Device& device, const ocl::BuildConfig& build) : device_(device), build_(build) {
    ocl::require_build_support(device_.info(), build_);
    ocl::checked([&] {
        term_kernel_ = device_.kernel(kKernelFile, "ms_exact_term", build_);
        mean_kernel_ = device_.kernel(kKernelFile, "ms_exact_azimuth_mean", build_);
        return 0;
    });
}

std::size_t ExactKernel::batch_size(std::size_t item_bytes) const {
    // Input and output of one item together; a quarter of the device's memory at most (other jobs may
    // share it), and 2^20 items per launch so that a launch stays short on a display GPU.
    const std::uint64_t per_buffer = std::max<std::uint64_t>(1, device_.info().max_alloc / std::max(item_bytes, sizeof(ms_exact_value)));
    const std::uint64_t by_memory =
        std::max<std::uint64_t>(1, device_.info().global_memory / 4 / (item_bytes + sizeof(ms_exact_value)));
    return static_cast<std::size_t>(std::min<std::uint64_t>({per_buffer, by_memory, std::uint64_t(1) << 20}));
}

template <class Item>
void ExactKernel::run(cl::Kernel& kernel, const std::vector<Item>& items, double tolerance, double term_tolerance,
                      std::vector<ExactValue>& out) {
    out.assign(items.size(), ExactValue{});
    stack_limited_ = 0;
    unresolved_.clear();
    if (items.empty()) return;
    const LaunchRules rules = launch_rules(tolerance, term_tolerance);
    const std::size_t batch = std::min(items.size(), batch_size(sizeof(Item)));
    std::vector<ms_exact_value> values(batch);
    ocl::checked([&] {
        cl::Buffer gauss;
        if (build_.double_precision) {
            gauss = cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, rules.table.size() * sizeof(double),
                               const_cast<double*>(rules.table.data()));
        } else {
            std::vector<float> narrow(rules.table.begin(), rules.table.end());
            gauss = cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, narrow.size() * sizeof(float),
                               narrow.data());
        }
        cl::Buffer in(device_.context(), CL_MEM_READ_ONLY, batch * sizeof(Item));
        cl::Buffer result(device_.context(), CL_MEM_WRITE_ONLY, batch * sizeof(ms_exact_value));
        // Work-items of one group take very different paths (closed forms, deep subdivisions): small
        // groups keep a slow item from holding many idle lanes on a GPU. On PoCL's CPU device 1, 8 and
        // 64 measured the same within the noise of a loaded machine.
        const std::size_t local = ocl::local_size(kernel, device_.info(), 8);
        for (std::size_t first = 0; first < items.size(); first += batch) {
            const std::size_t count = std::min(batch, items.size() - first);
            device_.queue().enqueueWriteBuffer(in, CL_FALSE, 0, count * sizeof(Item), items.data() + first);
            kernel.setArg(0, in);
            kernel.setArg(1, cl_uint(count));
            kernel.setArg(2, rules.rule);
            kernel.setArg(3, gauss);
            kernel.setArg(4, result);
            device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(ocl::round_up(count, local)),
                                                 cl::NDRange(local));
            device_.queue().enqueueReadBuffer(result, CL_TRUE, 0, count * sizeof(ms_exact_value), values.data());
            for (std::size_t i = 0; i < count; ++i) {
                const ms_exact_value& v = values[i];
                ExactValue& o = out[first + i];
                o.term = join(v.term_hi, v.term_lo);
                o.error = join(v.error_hi, v.error_lo);
                o.quadrature_pieces = static_cast<int>(v.quadrature_pieces);
                if (v.flags & MS_EXACT_FLAG_STACK_FULL) ++stack_limited_;
                if (v.flags & MS_EXACT_FLAG_UNRESOLVED) unresolved_.push_back(first + i);
            }
        }
        return 0;
    });
}

void ExactKernel::terms(const std::vector<Query>& q, AoWeighting weighting, double tolerance, std::vector<ExactValue>& out) {
    std::vector<ms_exact_query> items(q.size());
    for (std::size_t i = 0; i < q.size(); ++i) {
        const Vec3 wi = unit(q[i].wi), wo = unit(q[i].wo);
        ms_exact_query& k = items[i];
        split(cone_cos_theta(q[i].visibility, weighting), k.cos_theta_hi, k.cos_theta_lo);
        split(cone_sin2_theta(q[i].visibility, weighting), k.sin2_cone_hi, k.sin2_cone_lo);
        split(q[i].alpha_x, k.alpha_x_hi, k.alpha_x_lo);
        split(q[i].alpha_y, k.alpha_y_hi, k.alpha_y_lo);
        split(wi.x, k.wi_x_hi, k.wi_x_lo);
        split(wi.y, k.wi_y_hi, k.wi_y_lo);
        split(wi.z, k.wi_z_hi, k.wi_z_lo);
        split(wo.x, k.wo_x_hi, k.wo_x_lo);
        split(wo.y, k.wo_y_hi, k.wo_y_lo);
        split(wo.z, k.wo_z_hi, k.wo_z_lo);
    }
    run(term_kernel_, items, tolerance, tolerance, out);
    // What float cannot resolve, the C++ evaluator computes in double (see exact_kernel.hpp).
    if (!build_.double_precision)
        for (std::size_t i = 0; i < q.size(); ++i)
            if (std::max(q[i].alpha_x, q[i].alpha_y) > kFloatAnisotropyLimit * std::min(q[i].alpha_x, q[i].alpha_y))
                unresolved_.push_back(i);
    std::sort(unresolved_.begin(), unresolved_.end());
    unresolved_.erase(std::unique(unresolved_.begin(), unresolved_.end()), unresolved_.end());
    for (std::size_t i : unresolved_) out[i] = exact_term(q[i], weighting, tolerance);
}

void ExactKernel::azimuth_means(const std::vector<ExactTexel>& texels, AoWeighting weighting, double tolerance,
                                std::vector<ExactValue>& out) {
    std::vector<ms_exact_texel> items(texels.size());
    for (std::size_t i = 0; i < texels.size(); ++i) {
        const ExactTexel& t = texels[i];
        ms_exact_texel& k = items[i];
        split(cone_cos_theta(t.visibility, weighting), k.cos_theta_hi, k.cos_theta_lo);
        split(cone_sin2_theta(t.visibility, weighting), k.sin2_cone_hi, k.sin2_cone_lo);
        split(t.alpha, k.alpha_hi, k.alpha_lo);
        split(t.n_dot_v, k.n_dot_v_hi, k.n_dot_v_lo);
        split(t.n_dot_l, k.n_dot_l_hi, k.n_dot_l_lo);
        k.pad1 = k.pad2 = 0;
    }
    // exact_azimuth_mean gives each term a quarter of the mean's tolerance.
    run(mean_kernel_, items, tolerance, 0.25 * tolerance, out);
    // A texel carries only the cosines: float's 1 - NdotL^2 keeps few digits of the sine within
    // kFloatNearNormal of the normal (see exact_kernel.hpp); those go to the C++ evaluator.
    if (!build_.double_precision)
        for (std::size_t i = 0; i < texels.size(); ++i) {
            const auto near_normal = [](double c) { return c < 1 && c > 1 - kFloatNearNormal; };
            if (near_normal(texels[i].n_dot_l) || near_normal(texels[i].n_dot_v)) unresolved_.push_back(i);
        }
    std::sort(unresolved_.begin(), unresolved_.end());
    unresolved_.erase(std::unique(unresolved_.begin(), unresolved_.end()), unresolved_.end());
    for (std::size_t i : unresolved_) {
        const ExactTexel& t = texels[i];
        out[i] = exact_azimuth_mean(t.visibility, t.alpha, t.n_dot_v, t.n_dot_l, weighting, tolerance);
    }
}

}  // namespace ms::exact
