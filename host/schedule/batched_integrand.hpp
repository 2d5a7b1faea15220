// The common shape of a per-target integral (the DFG LUT's texels, a prefiltered cubemap's texels, an
// irradiance map's texels): a list of targets, each with its own result in `slots_per_target` slots of
// one storage vector, and work items that are batches of `per_item` consecutive targets. What differs
// between integrals is only how one batch runs on a device (the kernel call: pack the batch's targets,
// enqueue, read back, reduce into the batch's slots) and the oracle of one target. A new integral
// derives from BatchedIntegrand<Target, Slot> and supplies those two:
//
//   class MyIntegrand final : public schedule::BatchedIntegrand<MyTarget, MyValue> {
//       std::unique_ptr<DeviceRoutine> make_device_routine(ocl::Device& d) override;  // buffers, then run(batch)
//       void oracle(const MyTarget& t, MyValue* slots) override;                       // thread-safe
//   };
//
// The base provides the work items, the workers (the device routine made on the place's thread, the
// oracle looped over the batch), the cancellation checks (before each device batch, before each oracle
// target), and for trivially copyable slots the bytes of an item for distributed runs.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/cancel.hpp"
#include "schedule/integrand.hpp"

namespace ms::schedule {

template <class Target, class Slot>
class BatchedIntegrand : public Integrand {
public:
    // One work item: targets [first, first + count) and their slots, [first, first + count) x slots_per_target.
    struct Batch {
        std::size_t first = 0, count = 0;
        const Target* targets = nullptr;
        Slot* slots = nullptr;
    };
    // A device's state for the run (compiled kernels, uploaded inputs), made on the place's own thread;
    // run() computes one batch completely. Throws ocl::Error when the device fails.
    class DeviceRoutine {
    public:
        virtual ~DeviceRoutine() = default;
        virtual void run(const Batch& batch) = 0;
    };

    BatchedIntegrand(std::vector<Target> targets, std::size_t per_item, std::size_t slots_per_target = 1)
        : targets_(std::move(targets)), per_item_(std::max<std::size_t>(1, per_item)), stride_(slots_per_target),
          slots_(targets_.size() * slots_per_target) {}

    std::uint64_t work_items() const override { return (targets_.size() + per_item_ - 1) / per_item_; }
    std::unique_ptr<Worker> device_worker(ocl::Device& device) final {
        return std::make_unique<DeviceWorker>(*this, make_device_routine(device));
    }
    std::unique_ptr<Worker> oracle_worker() final {
        check_oracle();
        return std::make_unique<OracleWorker>(*this);
    }

    const std::vector<Target>& targets() const { return targets_; }
    std::size_t per_item() const { return per_item_; }
    std::size_t slots_per_target() const { return stride_; }
    const std::vector<Slot>& slots() const { return slots_; }
    std::vector<Slot> take_slots() { return std::move(slots_); }

    // An item's slots as bytes, and back (schedule/integrand.hpp). Integrals that may be distributed
    // also override distributable() to return true.
    std::string save_item(std::uint64_t id) const override {
        if constexpr (std::is_trivially_copyable_v<Slot>) {
            const std::size_t first = std::size_t(id) * per_item_, count = std::min(per_item_, targets_.size() - first);
            return std::string(reinterpret_cast<const char*>(slots_.data() + first * stride_), count * stride_ * sizeof(Slot));
        } else {
            return Integrand::save_item(id);
        }
    }
    void load_item(std::uint64_t id, const std::string& bytes) override {
        if constexpr (std::is_trivially_copyable_v<Slot>) {
            const Batch b = batch(id);
            if (bytes.size() != b.count * stride_ * sizeof(Slot))
                throw std::runtime_error(name() + ": item " + std::to_string(id) + " holds " + std::to_string(bytes.size()) + " bytes, not " +
                                         std::to_string(b.count * stride_ * sizeof(Slot)));
            std::memcpy(b.slots, bytes.data(), bytes.size());
        } else {
            Integrand::load_item(id, bytes);
        }
    }

protected:
    virtual std::unique_ptr<DeviceRoutine> make_device_routine(ocl::Device& device) = 0;
    // The oracle of one target into its slot_per_target slots (which start value-initialised, so an
    // oracle may add into them). Called from several oracle threads at once.
    virtual void oracle(const Target& target, Slot* slots) = 0;
    // Refuses the oracle backend before any work when it cannot run (std::invalid_argument).
    virtual void check_oracle() const {}

    Batch batch(std::uint64_t id) {
        Batch b;
        b.first = std::size_t(id) * per_item_;
        b.count = std::min(per_item_, targets_.size() - b.first);
        b.targets = targets_.data() + b.first;
        b.slots = slots_.data() + b.first * stride_;
        return b;
    }

private:
    class DeviceWorker final : public Worker {
    public:
        DeviceWorker(BatchedIntegrand& owner, std::unique_ptr<DeviceRoutine> routine) : owner_(owner), routine_(std::move(routine)) {}
        void run(std::uint64_t id) override {
            throw_if_cancelled();
            routine_->run(owner_.batch(id));
        }

    private:
        BatchedIntegrand& owner_;
        std::unique_ptr<DeviceRoutine> routine_;
    };
    class OracleWorker final : public Worker {
    public:
        explicit OracleWorker(BatchedIntegrand& owner) : owner_(owner) {}
        void run(std::uint64_t id) override {
            const Batch b = owner_.batch(id);
            for (std::size_t i = 0; i < b.count; ++i) {
                throw_if_cancelled();
                owner_.oracle(b.targets[i], b.slots + i * owner_.stride_);
            }
        }

    private:
        BatchedIntegrand& owner_;
    };

    std::vector<Target> targets_;
    std::size_t per_item_, stride_;
    std::vector<Slot> slots_;
};

}  // namespace ms::schedule
