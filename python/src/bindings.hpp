// What every binding file of microshadow._microshadow shares: the numpy array type, running a long call
// without the GIL while Ctrl-C and the progress callback still work, and one declaration per job's
// binding (module.cpp calls them in order). The argument checks that name the argument and index, the
// broadcasting and the documentation live in the Python package (python/microshadow/).
#pragma once

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <microshadow/microshadow.hpp>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace microshadow_python {

namespace py = pybind11;
using namespace microshadow;  // NOLINT: the bindings name every public type
using namespace pybind11::literals;

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

// One job's bindings each (a file of its own: options.cpp, evaluate.cpp, files.cpp, bake.cpp, sweep.cpp,
// ibl.cpp, area.cpp, scene.cpp, design.cpp).
void bind_options(py::module_& m);
void bind_evaluate(py::module_& m);
void bind_files(py::module_& m);
void bind_bake(py::module_& m);
void bind_sweep(py::module_& m);
void bind_ibl(py::module_& m);
void bind_area(py::module_& m);
void bind_scene(py::module_& m);
void bind_design(py::module_& m);

// An ao_weighting as the CLI spells it ("cosine", "uniform"); std::invalid_argument otherwise.
AoWeighting parse_ao_weighting(const std::string& text);

// --- progress, Ctrl-C and the GIL --------------------------------------------------------------------

// The Progress of one long call. Each report takes the GIL for a moment and calls the user's callback;
// the calling thread meanwhile runs Python's signal handlers every 0.1 s (check_signals: Ctrl-C raises
// KeyboardInterrupt there). Python runs signal handlers only in its main thread, and the library
// reports progress from whichever worker thread finishes an item, so the reports cannot be where
// Ctrl-C is noticed. Either raising stops the call (the next report returns false and the C++ side
// throws Cancelled); the Python exception is kept and raised again once the call has unwound.
class PythonProgress {
public:
    explicit PythonProgress(py::object callback) : callback_(std::move(callback)) {}
    ~PythonProgress() {
        if (type_ || value_ || traceback_) {
            py::gil_scoped_acquire gil;
            Py_XDECREF(type_);
            Py_XDECREF(value_);
            Py_XDECREF(traceback_);
        }
    }
    Progress progress() {
        return [this](std::uint64_t done, std::uint64_t total) {
            py::gil_scoped_acquire gil;
            if (pending()) return false;
            if (!callback_.is_none()) {
                try {
                    callback_(done, total);
                } catch (py::error_already_set& e) {
                    e.restore();
                    keep_error();
                    return false;
                }
            }
            return true;
        };
    }
    // Whether a signal handler or the callback raised (their exception is kept for raise()).
    bool stopped() const { return pending(); }
    // Runs Python's signal handlers (the caller holds the GIL); one that raises stops the call.
    void check_signals() {
        if (!pending() && PyErr_CheckSignals() != 0) keep_error();
    }
    // After Cancelled: the exception that stopped the call (KeyboardInterrupt when none was kept).
    [[noreturn]] void raise() {
        if (pending()) {
            PyErr_Restore(type_, value_, traceback_);
            type_ = value_ = traceback_ = nullptr;
            throw py::error_already_set();
        }
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        throw py::error_already_set();
    }

private:
    bool pending() const { return type_ != nullptr; }
    void keep_error() { PyErr_Fetch(&type_, &value_, &traceback_); }
    py::object callback_;
    PyObject* type_ = nullptr;
    PyObject* value_ = nullptr;
    PyObject* traceback_ = nullptr;
};

// Runs `call(progress)` on a thread of its own without the GIL (so other Python threads run
// meanwhile), while this thread wakes every 0.1 s to run Python's signal handlers.
template <class Call>
auto run_long(const py::object& callback, Call&& call) {
    using Result = decltype(call(std::declval<Progress>()));
    PythonProgress bridge(callback);
    std::optional<Result> result;
    std::exception_ptr failure;
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    {
        py::gil_scoped_release release;
        std::thread worker([&] {
            try {
                result.emplace(call(bridge.progress()));
            } catch (...) {
                failure = std::current_exception();
            }
            const std::lock_guard<std::mutex> lock(mutex);
            done = true;
            finished.notify_one();
        });
        std::unique_lock<std::mutex> lock(mutex);
        while (!finished.wait_for(lock, std::chrono::milliseconds(100), [&] { return done; })) {
            lock.unlock();
            {
                py::gil_scoped_acquire gil;
                bridge.check_signals();
            }
            lock.lock();
        }
        lock.unlock();
        worker.join();
    }
    if (failure) {
        try {
            std::rethrow_exception(failure);
        } catch (const Cancelled&) {
            bridge.raise();
        }
    }
    // A Ctrl-C (or a callback's exception) after the last report still stops the caller.
    if (bridge.stopped()) bridge.raise();
    return std::move(*result);
}

template <class T>
py::array_t<T> to_array(const std::vector<T>& values, std::vector<py::ssize_t> shape) {
    py::array_t<T> out(shape);
    if (!values.empty()) std::memcpy(out.mutable_data(), values.data(), values.size() * sizeof(T));
    return out;
}

}  // namespace microshadow_python
