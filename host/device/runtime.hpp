// OpenCL devices, kernel sources and build options, and a per-device program cache.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "device/error.hpp"

namespace ms::ocl {

struct DeviceInfo {
    std::size_t index = 0;  // position in enumerate_devices(), the number `--device N` takes
    std::string platform, name, vendor, version, driver, type;
    unsigned compute_units = 0;
    std::uint64_t global_memory = 0;
    std::uint64_t max_alloc = 0;  // CL_DEVICE_MAX_MEM_ALLOC_SIZE: the largest single buffer
    bool fp64 = false;
    cl::Device device;

    std::string label() const { return name + " [" + platform + "]"; }
};

// Whether an OpenCL runtime could be loaded (libOpenCL.so.1 on Linux, OpenCL.dll on Windows, or the file
// MICROSHADOW_OPENCL_LIBRARY names; device/cl_loader.cpp): the program runs without one, on its C++
// backends. `detail`: the file loaded, or why none could be.
bool opencl_runtime_loaded(std::string* detail = nullptr);

// Every device of every platform, in platform order. Throws NoDeviceError when there is no platform.
// Calls prepare_opencl_environment() first.
std::vector<DeviceInfo> enumerate_devices();

// Checks and fixes what makes PoCL fail without a useful message, before the first OpenCL call:
//   - POCL_MAX_PTHREAD_COUNT and POCL_MAX_WORK_GROUP_SIZE must be decimal integers in range (PoCL 3.1
//     crashes on -1 (SIGSEGV) or 0/"abc" (assertion), or aborts on 100000 threads): EnvironmentError;
//   - when POCL_CACHE_DIR is unset and PoCL's default kernel cache ($XDG_CACHE_HOME/pocl/kcache or
//     $HOME/.cache/pocl/kcache) cannot be created or written (a read-only HOME made PoCL report no
//     device at all), POCL_CACHE_DIR is set to $TMPDIR/microshadow-pocl-cache-UID (a note on stderr);
//   - a SIGABRT inside PoCL prints the cache directory as a hint (a damaged entry check_kernel_cache
//     does not recognise).
// Idempotent; the cache is set up once, the variables are checked on every call.
void prepare_opencl_environment();

// Entries of PoCL's kernel cache that are damaged (an empty or non-bitcode program.bc, a kernel .so
// that is not ELF: PoCL aborts with exit 134 or fails with CL_INVALID_KERNEL_NAME on them).
std::vector<std::string> damaged_kernel_cache_entries();
// Throws std::runtime_error naming the damaged entries and the directories to remove. Device's
// constructor calls it (once per process), before any kernel is built.
void check_kernel_cache();

// Bad OpenCL environment settings (exit status 2: bad input, like a bad option).
class EnvironmentError : public std::invalid_argument {
public:
    using std::invalid_argument::invalid_argument;
};

// PoCL's kernel cache directory as PoCL will use it (POCL_CACHE_DIR or its default).
std::string pocl_cache_dir();

// Device selection by a user's spec:
//   "" or "default": PoCL's CPU device if present, else the first CPU device, else device 0;
//   "all": every device;  "N" or "N,M": by index;  anything else: devices whose name or platform
//   contains the text (case-insensitive). Throws NoDeviceError with the list of devices when nothing matches.
std::vector<DeviceInfo> select_devices(const std::string& spec);

// Everything that changes the compiled program. build_options() is the one place that turns it into
// compiler flags: strict IEEE float by default; fast math only when asked (and then recorded by callers).
struct BuildConfig {
    bool fast_math = false;
    bool double_precision = false;               // MS_REAL=double, for devices with cl_khr_fp64
    std::map<std::string, std::string> defines;  // extra -D NAME=VALUE
};
std::string build_options(const BuildConfig& config);

// The program source of kernels/<file> (a path such as "term/generic_term.cl"): the common preamble
// (preamble_files(), in order) followed by the file. Embedded at build time, or read from the directory
// in $MICROSHADOW_KERNEL_DIR when set (a development switch: edit kernels without rebuilding).
std::string kernel_source(const std::string& file);
const std::vector<std::string>& preamble_files();
// A digest of the kernel sources a run builds from when $MICROSHADOW_KERNEL_DIR is set (every embedded
// kernel's name and the bytes of the file of that name in the folder), "" when it is not (the embedded
// sources are the build's own, which its source fingerprint covers). Part of every cache key.
std::string overridden_kernels_digest();

// What every kernel routine needs (CLBlast's routine base, in three functions):
// the wanted work-group size, or the kernel's limit on this device if that is smaller (at least 1);
std::size_t local_size(const cl::Kernel& kernel, const DeviceInfo& device, std::size_t wanted);
// n rounded up to a multiple (kernels check their range, so global sizes are padded);
inline std::size_t round_up(std::size_t n, std::size_t multiple) { return (n + multiple - 1) / multiple * multiple; }
// throws std::invalid_argument when the device cannot build the configuration (double kernels
// without cl_khr_fp64), naming the device, instead of a build log full of errors.
void require_build_support(const DeviceInfo& device, const BuildConfig& config);

// A point set's two coordinate arrays as read-only device buffers (every sampling routine uploads one).
struct PointBuffers {
    cl::Buffer u1, u2;
};
class Device;
PointBuffers upload_points(Device& device, const std::vector<float>& u1, const std::vector<float>& u2);

// A device with its own context and in-order queue. Programs are built once per (source hash,
// options) and cached; build times are recorded so benchmarks can report them apart from run time.
class Device {
public:
    explicit Device(DeviceInfo info);
    const DeviceInfo& info() const { return info_; }
    cl::Context& context() { return context_; }
    cl::CommandQueue& queue() { return queue_; }

    cl::Program& program(const std::string& file, const BuildConfig& config);
    cl::Kernel kernel(const std::string& file, const std::string& kernel_name, const BuildConfig& config);
    double last_build_seconds() const { return last_build_seconds_; }

private:
    DeviceInfo info_;
    cl::Context context_;
    cl::CommandQueue queue_;
    std::mutex mutex_;
    std::map<std::string, cl::Program> programs_;
    double last_build_seconds_ = 0;
};

}  // namespace ms::ocl
