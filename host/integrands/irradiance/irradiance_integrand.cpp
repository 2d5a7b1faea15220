#include "integrands/irradiance/irradiance_integrand.hpp"

#include <algorithm>
#include <stdexcept>

#include "core/cancel.hpp"

namespace ms::irradiance {

IrradianceIntegrand::IrradianceIntegrand(const Source& source, std::vector<Target> targets, std::size_t per_item, RoutineConfig config,
                                         CpuEstimate oracle)
    : BatchedIntegrand(std::move(targets), per_item), source_(source), config_(std::move(config)), oracle_(std::move(oracle)) {
    const std::size_t texels = 6ull * source_.size * source_.size;
    if (source_.size == 0 || source_.vector.size() != 4 * texels || source_.radiance.size() != 4 * texels ||
        source_.spread.size() != 4 * texels)
        throw std::invalid_argument("irradiance: the packed source does not hold 6 x size^2 texels of four floats per array");
}

// The kernel on one device: the reduced source uploaded once, then one call per batch of directions.
class IrradianceKernelRoutine final : public IrradianceIntegrand::DeviceRoutine {
public:
    IrradianceKernelRoutine(IrradianceIntegrand& owner, ocl::Device& device) : owner_(owner), device_(device) {
        ocl::require_build_support(device_.info(), owner_.config_.build);
        const Source& s = owner_.source_;
        auto upload = [&](const std::vector<float>& v) {
            return cl::Buffer(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, v.size() * sizeof(float), const_cast<float*>(v.data()));
        };
        ocl::checked([&] {
            vector_ = upload(s.vector);
            radiance_ = upload(s.radiance);
            spread_ = upload(s.spread);
            return 0;
        });
    }
    void run(const IrradianceIntegrand::Batch& batch) override {
        const std::size_t count = batch.count;
        std::vector<cl_float4> packed(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Target& t = batch.targets[i];
            packed[i] = {{float(t.x), float(t.y), float(t.z), 0.0f}};
        }
        std::vector<float> sums(count * 12);
        ocl::checked([&] {
            cl::Kernel kernel = device_.kernel("irradiance/irradiance.cl", "ms_irradiance", owner_.config_.build);
            const std::size_t local = ocl::local_size(kernel, device_.info(), owner_.config_.local_size);
            cl::Buffer tbuf(device_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, packed.size() * sizeof(cl_float4), packed.data());
            cl::Buffer obuf(device_.context(), CL_MEM_WRITE_ONLY, sums.size() * sizeof(float));
            int a = 0;
            kernel.setArg(a++, vector_);
            kernel.setArg(a++, radiance_);
            kernel.setArg(a++, spread_);
            kernel.setArg(a++, cl_uint(owner_.source_.size));
            kernel.setArg(a++, tbuf);
            kernel.setArg(a++, cl_uint(count));
            kernel.setArg(a++, obuf);
            device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(ocl::round_up(count, local)), cl::NDRange(local));
            device_.queue().enqueueReadBuffer(obuf, CL_TRUE, 0, sums.size() * sizeof(float), sums.data());
            return 0;
        });
        const double u = 1.0 / double(1 << 24);  // float's unit roundoff
        for (std::size_t i = 0; i < count; ++i) {
            Value& v = batch.slots[i];
            const float* o = &sums[i * 12];
            for (int c = 0; c < 3; ++c) {
                v.irradiance[c] = o[c];
                // o[4 + c]: the reduction's bound, o[8 + c]: the rounding scale (see kRoundingUnits).
                v.error_bound[c] = double(o[4 + c]) * (1 + 8 * u) + kRoundingUnits * u * double(o[8 + c]);
            }
        }
    }

private:
    IrradianceIntegrand& owner_;
    ocl::Device& device_;
    cl::Buffer vector_, radiance_, spread_;
};

void IrradianceIntegrand::check_oracle() const {
    if (!oracle_) throw std::invalid_argument("irradiance: no oracle given for the oracle backend");
}

std::unique_ptr<IrradianceIntegrand::DeviceRoutine> IrradianceIntegrand::make_device_routine(ocl::Device& device) {
    return std::make_unique<IrradianceKernelRoutine>(*this, device);
}

}  // namespace ms::irradiance
