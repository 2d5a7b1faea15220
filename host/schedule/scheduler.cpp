#include "schedule/scheduler.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <exception>
#include <iostream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <set>
#include <thread>

#include "core/cancel.hpp"

namespace ms::schedule {

Backend Backend::opencl(std::vector<ocl::DeviceInfo> devices) {
    Backend b;
    b.kind = Kind::opencl;
    b.devices = std::move(devices);
    return b;
}

Backend Backend::oracle(unsigned threads) {
    Backend b;
    b.kind = Kind::oracle;
    b.oracle_threads = threads;
    return b;
}

BackendSpec BackendSpec::parse(const std::string& kind, const std::string& device, unsigned threads) {
    if (kind == "oracle") return oracle(threads);
    if (kind == "opencl") {
        BackendSpec spec = opencl(device);
        spec.threads = threads;
        return spec;
    }
    throw std::invalid_argument("backend '" + kind + "' (opencl or oracle)");
}

FaultInjection fault_injection_from_environment() {
    FaultInjection f;
    const char* env = std::getenv("MICROSHADOW_FAIL_DEVICE");
    if (!env || !*env) return f;
    const std::string s(env);
    const auto colon = s.find(':');
    try {
        f.place = std::stol(s.substr(0, colon));
        f.after = colon == std::string::npos ? 0 : std::stol(s.substr(colon + 1));
    } catch (const std::exception&) {
        throw std::invalid_argument("MICROSHADOW_FAIL_DEVICE must be <place index>:<items>, not '" + s + "'");
    }
    return f;
}

Backend Backend::from(const BackendSpec& spec) {
    if (spec.is_oracle()) return oracle(spec.threads);
    // No OpenCL runtime on this machine at all (no libOpenCL.so.1 / OpenCL.dll) and no device asked for
    // by name: the job runs on the C++ backend (the oracle; the exact method's C++ evaluator), and says
    // so once per process. A named device still fails, with the reason.
    std::string detail;
    if ((spec.device.empty() || spec.device == "default") && !ocl::opencl_runtime_loaded(&detail)) {
        static std::once_flag told;
        std::call_once(told, [&] {
            std::cerr << "note: no OpenCL runtime is installed (" << detail
                      << "); running on the CPU with the C++ backend (--backend oracle)\n";
        });
        return oracle(spec.threads);
    }
    return opencl(ocl::select_devices(spec.device));
}

Scheduler::Scheduler(Backend backend) : backend_(std::move(backend)) {
    if (backend_.kind == Backend::Kind::oracle) {
        oracle_threads_ = backend_.oracle_threads ? backend_.oracle_threads : std::max(1u, std::thread::hardware_concurrency());
    } else {
        if (backend_.devices.empty()) throw ocl::NoDeviceError("no OpenCL device selected");
        for (const auto& d : backend_.devices) devices_.push_back(std::make_unique<ocl::Device>(d));
    }
}

Scheduler::Scheduler(const BackendSpec& spec) : Scheduler(Backend::from(spec)) {
    // The hook fails devices: an oracle thread has no device to fail over from (its failure is the job's).
    if (!is_oracle()) fault_ = fault_injection_from_environment();
}

Scheduler::~Scheduler() = default;

std::size_t Scheduler::places() const { return is_oracle() ? oracle_threads_ : devices_.size(); }

std::string Scheduler::place_label(std::size_t place) const {
    if (is_oracle()) return "oracle thread " + std::to_string(place);
    return devices_.at(place)->info().label() + " (device " + std::to_string(place) + ")";
}

std::string Scheduler::name() const {
    if (is_oracle()) return "oracle (scalar double, " + std::to_string(oracle_threads_) + " threads)";
    std::string s = "opencl (";
    for (std::size_t i = 0; i < devices_.size(); ++i) s += (i ? "; " : "") + devices_[i]->info().label();
    return s + ")";
}

std::string Scheduler::results_label() const {
    if (is_oracle()) return "oracle (scalar double)";
    std::set<std::string> kinds;
    for (const auto& d : devices_) kinds.insert(d->info().label());
    std::string s = "opencl (";
    for (auto it = kinds.begin(); it != kinds.end(); ++it) s += (it == kinds.begin() ? "" : "; ") + *it;
    return s + ")";
}

std::vector<std::string> Scheduler::device_labels() const {
    std::vector<std::string> labels;
    for (const auto& d : devices_) labels.push_back(d->info().label());
    return labels;
}

RunReport Scheduler::run(Integrand& integrand, const WorkSelection& selection, const RunCallbacks& callbacks) {
    if (selection.shard_count == 0 || selection.shard_index >= selection.shard_count)
        throw std::invalid_argument("scheduler: bad shard " + std::to_string(selection.shard_index) + "/" +
                                    std::to_string(selection.shard_count));
    const auto start = std::chrono::steady_clock::now();
    RunReport report;
    std::deque<std::uint64_t> queue;
    const std::uint64_t total = integrand.work_items();
    // A pull source (next_item) feeds the queue as places go idle; `selected` then counts what it gave.
    const bool pulled = bool(selection.next_item);
    bool source_left = pulled;
    if (!pulled) {
        for (std::uint64_t id = selection.shard_index; id < total; id += selection.shard_count)
            if (!selection.already_done || !selection.already_done(id)) queue.push_back(id);
        if (selection.max_items && queue.size() > selection.max_items) queue.resize(selection.max_items);
    }
    report.selected = queue.size();

    std::mutex mutex;
    std::condition_variable changed;
    std::size_t alive = places();
    std::size_t in_flight = 0;
    std::exception_ptr fatal;
    bool stop = false;

    auto place_loop = [&](std::size_t place) {
        std::unique_ptr<Worker> worker;
        long items_started = 0;
        for (;;) {
            std::uint64_t id;
            {
                // An idle place waits while items are in flight elsewhere: one of them may come back
                // to the queue when its device fails, and a place that had left could not rerun it.
                std::unique_lock<std::mutex> lock(mutex);
                changed.wait(lock, [&] { return stop || !queue.empty() || source_left || in_flight == 0; });
                if (!stop && queue.empty() && source_left) {
                    std::uint64_t next = 0;
                    try {
                        source_left = selection.next_item(next);
                    } catch (...) {
                        if (!fatal) fatal = std::current_exception();
                        stop = true;
                        --alive;
                        changed.notify_all();
                        return;
                    }
                    if (source_left) {
                        if (next >= total) {
                            fatal = std::make_exception_ptr(std::runtime_error(
                                "scheduler: the work source gave item " + std::to_string(next) + " of " +
                                std::to_string(total) + " items"));
                            stop = true;
                            --alive;
                            changed.notify_all();
                            return;
                        }
                        queue.push_back(next);
                        ++report.selected;
                    }
                    changed.notify_all();
                    continue;
                }
                if (stop || queue.empty()) return;
                id = queue.front();
                queue.pop_front();
                ++in_flight;
            }
            try {
                if (long(place) == fault_.place && items_started >= fault_.after)
                    throw ocl::Error("injected failure (MICROSHADOW_FAIL_DEVICE)", CL_DEVICE_NOT_AVAILABLE);
                ++items_started;
                if (!worker) worker = is_oracle() ? integrand.oracle_worker() : integrand.device_worker(*devices_[place]);
                worker->run(id);
                std::lock_guard<std::mutex> lock(mutex);
                --in_flight;
                ++report.done;
                if (callbacks.on_done) callbacks.on_done(id);
                changed.notify_all();
            } catch (const ocl::Error& e) {
                std::lock_guard<std::mutex> lock(mutex);
                --in_flight;
                if (is_oracle()) {  // no device to blame: a real error
                    if (!fatal) fatal = std::current_exception();
                    stop = true;
                } else {
                    // The device failed: give the item back and retire this place; the others rerun it.
                    queue.push_front(id);
                    ++report.rerun;
                    report.failed_places.push_back(place_label(place) + ": " + e.what());
                }
                --alive;
                changed.notify_all();
                return;
            } catch (...) {
                std::lock_guard<std::mutex> lock(mutex);
                --in_flight;
                if (!fatal) fatal = std::current_exception();
                stop = true;
                --alive;
                changed.notify_all();
                return;
            }
        }
    };

    std::vector<std::thread> threads;
    for (std::size_t p = 0; p < places(); ++p) threads.emplace_back(place_loop, p);
    {
        // The calling thread reports progress, watches for Ctrl-C, and notices when no place is left.
        std::unique_lock<std::mutex> lock(mutex);
        for (;;) {
            if (callbacks.progress) {
                const std::uint64_t d = report.done;
                lock.unlock();
                callbacks.progress(d, report.selected);
                lock.lock();
            }
            if ((report.done == report.selected && !source_left) || fatal || alive == 0) break;
            if (cancel_requested()) break;
            changed.wait_for(lock, std::chrono::milliseconds(100));
        }
        stop = true;
        changed.notify_all();
    }
    for (auto& t : threads) t.join();
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // The final count: items can finish while a progress call is running, after which the loop above
    // leaves without reporting them.
    if (callbacks.progress && !fatal) callbacks.progress(report.done, report.selected);
    if (fatal) std::rethrow_exception(fatal);
    throw_if_cancelled();
    if (report.done != report.selected) {
        std::string msg = "every selected device failed; " + std::to_string(report.selected - report.done) + " of " +
                          std::to_string(report.selected) + " work items of " + integrand.name() +
                          " are missing, nothing was written:";
        for (const auto& f : report.failed_places) msg += "\n  " + f;
        throw ocl::Error(integrand.name(), CL_DEVICE_NOT_AVAILABLE, msg);
    }
    return report;
}

}  // namespace ms::schedule
