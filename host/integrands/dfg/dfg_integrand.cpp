#include "integrands/dfg/dfg_integrand.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/cancel.hpp"
#include "core/estimate.hpp"
#include "exact/dfg_exact.hpp"
#include "integrands/dfg/dfg_quadrature.hpp"

namespace ms::dfg {

void validate(const DfgPoint& p) {
    if (!(p.n_dot_v > 0 && p.n_dot_v <= 1))
        throw std::invalid_argument("DFG: NdotV must be in (0, 1], not " + std::to_string(p.n_dot_v));
    if (!(p.alpha > 0 && p.alpha <= 1)) throw std::invalid_argument("DFG: alpha must be in (0, 1], not " + std::to_string(p.alpha));
}

DfgIntegrand::DfgIntegrand(std::vector<DfgPoint> points, std::size_t points_per_item, const SamplingPlan& plan,
                           DfgRoutineConfig config)
    : BatchedIntegrand(std::move(points), points_per_item), plan_(plan), config_(std::move(config)) {
    for (const auto& p : targets()) validate(p);
}

const PointSet& DfgIntegrand::point_set() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!point_set_) point_set_ = shared_point_set(plan_);
    return *point_set_;
}

// The VNDF kernel on one device: the point set uploaded once, then one kernel call per batch of points.
class DfgKernelRoutine final : public DfgIntegrand::DeviceRoutine {
public:
    DfgKernelRoutine(DfgIntegrand& owner, ocl::Device& device) : owner_(owner), device_(device) {
        ocl::require_build_support(device_.info(), owner_.config_.build);
        const PointSet& pts = owner_.point_set();
        const ocl::PointBuffers b = ocl::upload_points(device_, pts.u1, pts.u2);
        u1_ = b.u1;
        u2_ = b.u2;
    }

    void run(const DfgIntegrand::Batch& batch) override {
        const PointSet& pts = owner_.point_set();
        const std::size_t count = batch.count;
        const std::uint32_t R = pts.replicates, n = pts.points_per_replicate;
        const std::uint32_t per_chunk = std::min<std::uint32_t>(n, owner_.config_.max_points_per_work_item);
        const std::uint32_t chunks = n / per_chunk;  // both powers of two
        std::vector<cl_float4> packed(count);
        for (std::size_t i = 0; i < count; ++i) {
            const DfgPoint& p = batch.targets[i];
            packed[i] = {{float(p.alpha), float(p.n_dot_v), float(std::sqrt(std::max(0.0, 1 - p.n_dot_v * p.n_dot_v))), 0.0f}};
        }
        const std::size_t items = count * R * chunks;
        std::vector<float> sums(items * 32);
        ocl::checked([&] {
            ocl::BuildConfig build = owner_.config_.build;
            build.defines["MS_DFG_WARP"] = std::to_string(owner_.config_.warp);
            cl::Kernel kernel = device_.kernel("dfg/dfg.cl", "ms_dfg_tally", build);
            const std::size_t local = ocl::local_size(kernel, device_.info(), owner_.config_.local_size);
            const std::size_t global = ocl::round_up(items, local);
            cl::Buffer tbuf(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(cl_float4),
                            packed.data());
            cl::Buffer sbuf(device_.context(), CL_MEM_WRITE_ONLY, sums.size() * sizeof(float));
            kernel.setArg(0, tbuf);
            kernel.setArg(1, cl_uint(count));
            kernel.setArg(2, u1_);
            kernel.setArg(3, u2_);
            kernel.setArg(4, cl_uint(n));
            kernel.setArg(5, cl_uint(R));
            kernel.setArg(6, cl_uint(chunks));
            kernel.setArg(7, sbuf);
            device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global), cl::NDRange(local));
            device_.queue().enqueueReadBuffer(sbuf, CL_TRUE, 0, sums.size() * sizeof(float), sums.data());
            return 0;
        });
        // Per replicate: the sum of its chunks' lanes, in double; "hemisphere" is the point count, so the
        // replicate ratio is the replicate's mean.
        std::vector<double> a(R), b(R), e(R), count_r(R, double(n));
        for (std::size_t t = 0; t < count; ++t) {
            for (std::uint32_t r = 0; r < R; ++r) {
                double sa = 0, sb = 0;
                for (std::uint32_t c = 0; c < chunks; ++c) {
                    const float* s = &sums[((t * R + r) * chunks + c) * 32];
                    for (int k = 0; k < 16; ++k) sa += s[k], sb += s[16 + k];
                }
                a[r] = sa, b[r] = sb, e[r] = sa + sb;
            }
            DfgValue& v = batch.slots[t];
            v.scale = reduce_replicates(a.data(), count_r.data(), R);
            v.bias = reduce_replicates(b.data(), count_r.data(), R);
            v.albedo = reduce_replicates(e.data(), count_r.data(), R);
        }
    }

private:
    DfgIntegrand& owner_;
    ocl::Device& device_;
    cl::Buffer u1_, u2_;
};

std::unique_ptr<DfgIntegrand::DeviceRoutine> DfgIntegrand::make_device_routine(ocl::Device& device) {
    return std::make_unique<DfgKernelRoutine>(*this, device);
}

void DfgIntegrand::oracle(const DfgPoint& p, DfgValue* slot) {
    DfgValue& v = *slot;
    if (config_.host_rule == DfgHostRule::exact) {
        const exact::DfgExact e = exact::dfg_exact(p.n_dot_v, p.alpha, config_.sheen, config_.exact_order);
        v.scale = {e.scale, e.scale_error};
        v.bias = {e.bias, e.bias_error};
        v.albedo = {e.scale + e.bias, e.scale_error + e.bias_error};
        if (config_.sheen) v.sheen = {e.sheen, e.sheen_error};
        return;
    }
    const DfgQuadrature q = dfg_quadrature(p.n_dot_v, p.alpha, config_.quadrature_order, config_.sheen);
    v.scale = {q.scale, q.scale_error};
    v.bias = {q.bias, q.bias_error};
    v.albedo = {q.scale + q.bias, q.scale_error + q.bias_error};
    if (config_.sheen) v.sheen = {q.sheen, q.sheen_error};
}

}  // namespace ms::dfg
