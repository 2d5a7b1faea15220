#include "integrands/irradiance/irradiance_integrand.hpp"

#include <algorithm>
#include <stdexcept>

#include "core/cancel.hpp"

namespace ms::irradiance {

IrradianceIntegrand::IrradianceIntegrand(const Source& source, std::vector<Target> targets, std::size_t per_item, RoutineConfig config,
                                         CpuEstimate oracle)
    : source_(source), targets_(std::move(targets)), per_item_(std::max<std::size_t>(1, per_item)), config_(std::move(config)),
      oracle_(std::move(oracle)) {
    const std::size_t texels = 6ull * source_.size * source_.size;
    if (source_.size == 0 || source_.vector.size() != 4 * texels || source_.radiance.size() != 4 * texels ||
        source_.spread.size() != 4 * texels)
        throw std::invalid_argument("irradiance: the packed source does not hold 6 x size^2 texels of four floats per array");
    values_.resize(targets_.size());
}

class IrradianceDeviceWorker final : public schedule::Worker {
public:
    IrradianceDeviceWorker(IrradianceIntegrand& owner, ocl::Device& device) : owner_(owner), device_(device) {
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
    void run(std::uint64_t id) override {
        throw_if_cancelled();
        const std::size_t first = id * owner_.per_item_;
        const std::size_t count = std::min(owner_.per_item_, owner_.targets_.size() - first);
        std::vector<cl_float4> packed(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Target& t = owner_.targets_[first + i];
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
            Value& v = owner_.values_[first + i];
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

class IrradianceCpuWorker final : public schedule::Worker {
public:
    explicit IrradianceCpuWorker(IrradianceIntegrand& owner) : owner_(owner) {
        if (!owner_.oracle_) throw std::invalid_argument("irradiance: no oracle given for the oracle backend");
    }
    void run(std::uint64_t id) override {
        const std::size_t first = id * owner_.per_item_;
        const std::size_t count = std::min(owner_.per_item_, owner_.targets_.size() - first);
        for (std::size_t i = 0; i < count; ++i) {
            throw_if_cancelled();
            owner_.values_[first + i] = owner_.oracle_(owner_.targets_[first + i]);
        }
    }

private:
    IrradianceIntegrand& owner_;
};

std::unique_ptr<schedule::Worker> IrradianceIntegrand::device_worker(ocl::Device& device) {
    return std::make_unique<IrradianceDeviceWorker>(*this, device);
}
std::unique_ptr<schedule::Worker> IrradianceIntegrand::oracle_worker() { return std::make_unique<IrradianceCpuWorker>(*this); }

}  // namespace ms::irradiance
