// OpenCL failures as exceptions that name the call and the symbolic error code.
#pragma once

#include <stdexcept>
#include <string>

namespace ms::ocl {

// Symbolic name of an OpenCL status code ("CL_OUT_OF_RESOURCES"), or "CL_UNKNOWN_ERROR(<code>)".
std::string error_name(int code);

class Error : public std::runtime_error {
public:
    Error(std::string call, int code, const std::string& detail = "");
    const std::string& call() const { return call_; }
    int code() const { return code_; }

private:
    std::string call_;
    int code_;
};

// A kernel build that failed, carrying the compiler's log.
class BuildError : public Error {
public:
    BuildError(const std::string& device, const std::string& options, const std::string& log);
    const std::string& log() const { return log_; }

private:
    std::string log_;
};

// No OpenCL platform or device could be found or selected; the message says what to do.
class NoDeviceError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};
// A device selector (--device 3, a name) that matches no device of this machine: the caller's input is
// wrong, not the machine (the command line exits with status 2 for it, as for any bad option).
class UnknownDeviceError : public NoDeviceError {
public:
    using NoDeviceError::NoDeviceError;
};

// Runs f, turning the C++ bindings' cl::Error (which names the failed call) into ms::ocl::Error.
template <class F>
auto checked(F&& f) -> decltype(f());

}  // namespace ms::ocl

#include "device/cl.hpp"

namespace ms::ocl {
template <class F>
auto checked(F&& f) -> decltype(f()) {
    try {
        return f();
    } catch (const cl::Error& e) {
        throw Error(e.what(), e.err());
    }
}
}  // namespace ms::ocl
