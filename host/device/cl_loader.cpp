// The OpenCL runtime, loaded when first used (libOpenCL.so.1, the ICD loader, on Linux; OpenCL.dll on
// Windows) instead of linked: the program starts, and runs its C++ backends, on a machine without any
// OpenCL runtime. This file defines the OpenCL functions the program calls (those the C++ bindings
// use); each forwards to the loaded runtime, or reports that there is none: clGetPlatformIDs answers
// CL_PLATFORM_NOT_FOUND_KHR, as an ICD loader without drivers does, so every caller's "no platform"
// path covers it.
#include "device/cl.hpp"
#include "device/runtime.hpp"

#include <CL/cl_ext.h>

#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

#include "platform/dynamic_library.hpp"

namespace ms::ocl {

namespace {

// X(return type, name, parameter list, argument list, value when the runtime or the function is missing)
#define MS_OPENCL_FUNCTIONS(X)                                                                                          \
    X(cl_int, clGetPlatformIDs, (cl_uint n, cl_platform_id * platforms, cl_uint * count), (n, platforms, count),         \
      (count ? (*count = 0, CL_PLATFORM_NOT_FOUND_KHR) : CL_PLATFORM_NOT_FOUND_KHR))                                     \
    X(cl_int, clGetPlatformInfo, (cl_platform_id p, cl_platform_info i, size_t s, void* v, size_t* r), (p, i, s, v, r), \
      CL_INVALID_PLATFORM)                                                                                              \
    X(cl_int, clGetDeviceIDs, (cl_platform_id p, cl_device_type t, cl_uint n, cl_device_id * d, cl_uint * c),          \
      (p, t, n, d, c), CL_INVALID_PLATFORM)                                                                             \
    X(cl_int, clGetDeviceInfo, (cl_device_id d, cl_device_info i, size_t s, void* v, size_t* r), (d, i, s, v, r),      \
      CL_INVALID_DEVICE)                                                                                                \
    X(cl_int, clRetainDevice, (cl_device_id d), (d), CL_INVALID_DEVICE)                                                 \
    X(cl_int, clReleaseDevice, (cl_device_id d), (d), CL_INVALID_DEVICE)                                                \
    X(cl_context, clCreateContext,                                                                                      \
      (const cl_context_properties* p, cl_uint n, const cl_device_id* d,                                                \
       void(CL_CALLBACK * notify)(const char*, const void*, size_t, void*), void* u, cl_int* e),                        \
      (p, n, d, notify, u, e), (e ? (*e = CL_INVALID_PLATFORM, nullptr) : nullptr))                                     \
    X(cl_int, clRetainContext, (cl_context c), (c), CL_INVALID_CONTEXT)                                                 \
    X(cl_int, clReleaseContext, (cl_context c), (c), CL_INVALID_CONTEXT)                                                \
    X(cl_command_queue, clCreateCommandQueue, (cl_context c, cl_device_id d, cl_command_queue_properties p, cl_int* e), \
      (c, d, p, e), (e ? (*e = CL_INVALID_CONTEXT, nullptr) : nullptr))                                                 \
    X(cl_int, clRetainCommandQueue, (cl_command_queue q), (q), CL_INVALID_COMMAND_QUEUE)                                \
    X(cl_int, clReleaseCommandQueue, (cl_command_queue q), (q), CL_INVALID_COMMAND_QUEUE)                               \
    X(cl_mem, clCreateBuffer, (cl_context c, cl_mem_flags f, size_t s, void* h, cl_int* e), (c, f, s, h, e),            \
      (e ? (*e = CL_INVALID_CONTEXT, nullptr) : nullptr))                                                               \
    X(cl_int, clRetainMemObject, (cl_mem m), (m), CL_INVALID_MEM_OBJECT)                                                \
    X(cl_int, clReleaseMemObject, (cl_mem m), (m), CL_INVALID_MEM_OBJECT)                                               \
    X(cl_program, clCreateProgramWithSource, (cl_context c, cl_uint n, const char** s, const size_t* l, cl_int* e),    \
      (c, n, s, l, e), (e ? (*e = CL_INVALID_CONTEXT, nullptr) : nullptr))                                              \
    X(cl_int, clRetainProgram, (cl_program p), (p), CL_INVALID_PROGRAM)                                                 \
    X(cl_int, clReleaseProgram, (cl_program p), (p), CL_INVALID_PROGRAM)                                                \
    X(cl_int, clBuildProgram,                                                                                           \
      (cl_program p, cl_uint n, const cl_device_id* d, const char* o, void(CL_CALLBACK * notify)(cl_program, void*),    \
       void* u),                                                                                                        \
      (p, n, d, o, notify, u), CL_INVALID_PROGRAM)                                                                      \
    X(cl_int, clGetProgramInfo, (cl_program p, cl_program_info i, size_t s, void* v, size_t* r), (p, i, s, v, r),      \
      CL_INVALID_PROGRAM)                                                                                               \
    X(cl_int, clGetProgramBuildInfo,                                                                                    \
      (cl_program p, cl_device_id d, cl_program_build_info i, size_t s, void* v, size_t* r), (p, d, i, s, v, r),        \
      CL_INVALID_PROGRAM)                                                                                               \
    X(cl_kernel, clCreateKernel, (cl_program p, const char* n, cl_int* e), (p, n, e),                                   \
      (e ? (*e = CL_INVALID_PROGRAM, nullptr) : nullptr))                                                               \
    X(cl_int, clRetainKernel, (cl_kernel k), (k), CL_INVALID_KERNEL)                                                    \
    X(cl_int, clReleaseKernel, (cl_kernel k), (k), CL_INVALID_KERNEL)                                                   \
    X(cl_int, clSetKernelArg, (cl_kernel k, cl_uint i, size_t s, const void* v), (k, i, s, v), CL_INVALID_KERNEL)       \
    X(cl_int, clGetKernelWorkGroupInfo,                                                                                 \
      (cl_kernel k, cl_device_id d, cl_kernel_work_group_info i, size_t s, void* v, size_t* r), (k, d, i, s, v, r),     \
      CL_INVALID_KERNEL)                                                                                                \
    X(cl_int, clFlush, (cl_command_queue q), (q), CL_INVALID_COMMAND_QUEUE)                                             \
    X(cl_int, clFinish, (cl_command_queue q), (q), CL_INVALID_COMMAND_QUEUE)                                            \
    X(cl_int, clEnqueueReadBuffer,                                                                                      \
      (cl_command_queue q, cl_mem m, cl_bool b, size_t o, size_t s, void* p, cl_uint n, const cl_event* w, cl_event* e), \
      (q, m, b, o, s, p, n, w, e), CL_INVALID_COMMAND_QUEUE)                                                            \
    X(cl_int, clEnqueueWriteBuffer,                                                                                     \
      (cl_command_queue q, cl_mem m, cl_bool b, size_t o, size_t s, const void* p, cl_uint n, const cl_event* w,        \
       cl_event* e),                                                                                                    \
      (q, m, b, o, s, p, n, w, e), CL_INVALID_COMMAND_QUEUE)                                                            \
    X(cl_int, clEnqueueNDRangeKernel,                                                                                   \
      (cl_command_queue q, cl_kernel k, cl_uint d, const size_t* o, const size_t* g, const size_t* l, cl_uint n,        \
       const cl_event* w, cl_event* e),                                                                                 \
      (q, k, d, o, g, l, n, w, e), CL_INVALID_COMMAND_QUEUE)                                                            \
    X(cl_int, clWaitForEvents, (cl_uint n, const cl_event* e), (n, e), CL_INVALID_EVENT)                                \
    X(cl_int, clRetainEvent, (cl_event e), (e), CL_INVALID_EVENT)                                                       \
    X(cl_int, clReleaseEvent, (cl_event e), (e), CL_INVALID_EVENT)

struct Runtime {
#define MS_OPENCL_POINTER(ret, name, params, args, missing) ret(CL_API_CALL* name) params = nullptr;
    MS_OPENCL_FUNCTIONS(MS_OPENCL_POINTER)
#undef MS_OPENCL_POINTER
    bool loaded = false;
    std::string library;  // the file loaded, or why none was
};

// The runtime's library names, the platform's usual one first; MICROSHADOW_OPENCL_LIBRARY names another.
std::vector<std::string> library_names() {
    if (const char* chosen = std::getenv("MICROSHADOW_OPENCL_LIBRARY"); chosen && *chosen) return {chosen};
#if defined(_WIN32)
    return {"OpenCL.dll"};
#elif defined(__APPLE__)
    return {"/System/Library/Frameworks/OpenCL.framework/OpenCL"};
#else
    return {"libOpenCL.so.1", "libOpenCL.so"};
#endif
}

const Runtime& runtime() {
    static Runtime r;
    static std::once_flag once;
    std::call_once(once, [] {
        std::string why;
        for (const auto& name : library_names()) {
            std::string error;
            void* library = platform::open_library(name, error);
            if (!library) {
                why += (why.empty() ? "" : "; ") + (error.rfind(name, 0) == 0 ? error : name + ": " + error);
                continue;
            }
            // A missing function (a runtime older than OpenCL 1.2) stays null and answers as missing.
#define MS_OPENCL_RESOLVE(ret, name, params, args, missing) \
    r.name = reinterpret_cast<decltype(r.name)>(platform::library_symbol(library, #name));
            MS_OPENCL_FUNCTIONS(MS_OPENCL_RESOLVE)
#undef MS_OPENCL_RESOLVE
            r.loaded = r.clGetPlatformIDs != nullptr;
            if (r.loaded) {
                r.library = name;
                return;
            }
            why += (why.empty() ? "" : "; ") + name + ": has no clGetPlatformIDs";
        }
        r.library = why;
    });
    return r;
}

}  // namespace

bool opencl_runtime_loaded(std::string* detail) {
    const Runtime& r = runtime();
    if (detail) *detail = r.library;
    return r.loaded;
}

}  // namespace ms::ocl

// The definitions the C++ bindings link against. Declared by CL/cl.h with C linkage.
#define MS_OPENCL_FORWARD(ret, name, params, args, missing)             \
    extern "C" CL_API_ENTRY ret CL_API_CALL name params {                 \
        const auto& ms_opencl = ms::ocl::runtime();                       \
        return ms_opencl.name ? ms_opencl.name args : missing;            \
    }
MS_OPENCL_FUNCTIONS(MS_OPENCL_FORWARD)
#undef MS_OPENCL_FORWARD
