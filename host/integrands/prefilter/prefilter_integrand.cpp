#include "integrands/prefilter/prefilter_integrand.hpp"

#include <algorithm>
#include <stdexcept>

#include "core/cancel.hpp"

namespace ms::prefilter {

PrefilterIntegrand::PrefilterIntegrand(const SourceChain& chain, std::vector<Target> targets, std::size_t per_item,
                                       const PointSet& points, RoutineConfig config, CpuSums cpu)
    : BatchedIntegrand(std::move(targets), per_item, 4 * std::size_t(points.replicates)), chain_(chain), points_(points),
      config_(std::move(config)), cpu_(std::move(cpu)) {
    for (const auto& t : this->targets())
        if (!(t.roughness > 0)) throw std::invalid_argument("prefilter: roughness must be > 0 (roughness 0 is the source)");
}

// The kernel on one device: the source chain and the points uploaded once, then one call per batch.
class PrefilterKernelRoutine final : public PrefilterIntegrand::DeviceRoutine {
public:
    PrefilterKernelRoutine(PrefilterIntegrand& owner, ocl::Device& device) : owner_(owner), device_(device) {
        ocl::require_build_support(device_.info(), owner_.config_.build);
        const SourceChain& c = owner_.chain_;
        const PointSet& p = owner_.points_;
        ocl::checked([&] {
            chain_ = cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, c.rgb.size() * sizeof(float),
                                const_cast<float*>(c.rgb.data()));
            offset_ = cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, c.offset.size() * sizeof(cl_uint),
                                 const_cast<std::uint32_t*>(c.offset.data()));
            return 0;
        });
        const ocl::PointBuffers b = ocl::upload_points(device_, p.u1, p.u2);
        u1_ = b.u1;
        u2_ = b.u2;
    }
    void run(const PrefilterIntegrand::Batch& batch) override {
        const std::size_t count = batch.count;
        const std::uint32_t R = owner_.points_.replicates;
        std::vector<cl_float4> packed(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Target& t = batch.targets[i];
            packed[i] = {{float(t.x), float(t.y), float(t.z), float(t.roughness)}};
        }
        const std::size_t items = count * R;
        std::vector<float> sums(items * 4);
        ocl::checked([&] {
            cl::Kernel kernel = device_.kernel("prefilter/prefilter.cl", "ms_prefilter", owner_.config_.build);
            const std::size_t local = ocl::local_size(kernel, device_.info(), owner_.config_.local_size);
            cl::Buffer tbuf(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(cl_float4),
                            packed.data());
            cl::Buffer obuf(device_.context(), CL_MEM_WRITE_ONLY, sums.size() * sizeof(float));
            int a = 0;
            kernel.setArg(a++, chain_);
            kernel.setArg(a++, offset_);
            kernel.setArg(a++, cl_uint(owner_.chain_.offset.size()));
            kernel.setArg(a++, cl_uint(owner_.chain_.size0));
            kernel.setArg(a++, tbuf);
            kernel.setArg(a++, cl_uint(count));
            kernel.setArg(a++, u1_);
            kernel.setArg(a++, u2_);
            kernel.setArg(a++, cl_uint(owner_.points_.points_per_replicate));
            kernel.setArg(a++, cl_uint(R));
            kernel.setArg(a++, cl_float(float(owner_.points_.total())));
            kernel.setArg(a++, cl_float(float(owner_.config_.lod_bias)));
            kernel.setArg(a++, cl_int(owner_.config_.filtered ? 1 : 0));
            kernel.setArg(a++, obuf);
            device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(ocl::round_up(items, local)), cl::NDRange(local));
            device_.queue().enqueueReadBuffer(obuf, CL_TRUE, 0, sums.size() * sizeof(float), sums.data());
            return 0;
        });
        // The batch's slots hold the kernel's layout, [(k R + r) 4 + c], widened to double.
        std::copy(sums.begin(), sums.end(), batch.slots);
    }

private:
    PrefilterIntegrand& owner_;
    ocl::Device& device_;
    cl::Buffer chain_, offset_, u1_, u2_;
};

void PrefilterIntegrand::check_oracle() const {
    if (!cpu_) throw std::invalid_argument("prefilter: no CPU estimator given for the oracle backend");
}

std::unique_ptr<PrefilterIntegrand::DeviceRoutine> PrefilterIntegrand::make_device_routine(ocl::Device& device) {
    return std::make_unique<PrefilterKernelRoutine>(*this, device);
}

}  // namespace ms::prefilter
