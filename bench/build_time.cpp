// Kernel build time, reported apart from run time. PoCL compiles in two steps: clBuildProgram (OpenCL C
// to LLVM IR) and, at the first launch of a kernel, the work-group function for the device; both are
// cached on disk under POCL_CACHE_DIR. "Cold" points POCL_CACHE_DIR at a fresh empty directory before
// the first OpenCL call of the process; "cached" is a new process (or, without one, a new context) over
// the cache the cold build filled; "in-process" is ms::ocl::Device's program cache.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "bench.hpp"
#include "microshadow_shared.h"
#include "device/runtime.hpp"

namespace ms::bench {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Probe {
    double build = 0, first_launch = 0, steady_launch = 0, lookup = 0;
};

// Builds generic_term.cl on a new Device (context) and launches it on one 16-point query three times.
Probe probe(const ocl::DeviceInfo& info) {
    Probe p;
    ocl::Device device(info);
    const ocl::BuildConfig build;
    auto start = Clock::now();
    device.program("term/generic_term.cl", build);
    p.build = since(start);
    start = Clock::now();
    device.program("term/generic_term.cl", build);
    p.lookup = since(start);
    ocl::checked([&] {
        cl::Kernel kernel = device.kernel("term/generic_term.cl", "ms_tally_queries", build);
        ms_query q{};
        q.cos_theta = 0.5f, q.sin2_cone = 0.75f, q.alpha_x = q.alpha_y = 0.5f, q.wi_z = 1.0f, q.wo_z = 1.0f;
        float u[16];
        for (int i = 0; i < 16; ++i) u[i] = (i + 0.5f) / 16.0f;
        cl::Buffer qb(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof q, &q);
        cl::Buffer ub(device.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof u, u);
        cl::Buffer tb(device.context(), CL_MEM_WRITE_ONLY, sizeof(ms_tally));
        kernel.setArg(0, qb), kernel.setArg(1, cl_uint(1)), kernel.setArg(2, ub), kernel.setArg(3, ub);
        kernel.setArg(4, cl_uint(16)), kernel.setArg(5, cl_uint(1)), kernel.setArg(6, cl_uint(1)), kernel.setArg(7, tb);
        auto launch = [&] {
            const auto t = Clock::now();
            device.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(1), cl::NullRange);
            device.queue().finish();
            return since(t);
        };
        p.first_launch = launch();
        p.steady_launch = std::min(launch(), launch());
        return 0;
    });
    return p;
}

}  // namespace

int build_time_probe(const std::string& device) {
    const Probe p = probe(ocl::select_devices(device).front());
    std::cout << "build=" << p.build << " launch=" << p.first_launch << "\n";
    return 0;
}

BuildTimes run_build_time(const Options& opt, const std::string& self_exe) {
    std::string dir;
    // The smoke run shares its process with other tests: it leaves PoCL's cache where it is.
    if (!opt.smoke) {
        dir = (std::filesystem::temp_directory_path() / "microshadow-pocl-XXXXXX").string();
        if (!mkdtemp(dir.data())) throw std::runtime_error("cannot create a temporary PoCL cache directory");
        setenv("POCL_CACHE_DIR", dir.c_str(), 1);
    }
    const auto info = ocl::select_devices(opt.device).front();
    BuildTimes bt;
    const Probe cold = probe(info);
    bt.cold_build = cold.build, bt.cold_first_launch = cold.first_launch;
    bt.steady_launch = cold.steady_launch, bt.in_process_lookup = cold.lookup;
    std::string how;
    if (!self_exe.empty()) {
        // A new process over the same (now filled) cache directory: what a second CLI run pays.
        const std::string cmd = "'" + self_exe + "' --build-time-probe --device '" + opt.device + "'";
        FILE* pipe = popen(cmd.c_str(), "r");
        if (!pipe) throw std::runtime_error("cannot run " + cmd);
        char buf[256] = {0};
        const bool got = std::fgets(buf, sizeof buf, pipe) != nullptr;
        const int rc = pclose(pipe);
        if (!got || rc != 0 || std::sscanf(buf, "build=%lf launch=%lf", &bt.cached_build, &bt.cached_first_launch) != 2)
            throw std::runtime_error("build-time probe failed: " + cmd);
        how = "new process";
    } else {
        const Probe cached = probe(info);
        bt.cached_build = cached.build, bt.cached_first_launch = cached.first_launch;
        how = "new context";
    }
    bt.table.name = "kernel build time (generic_term.cl, " + info.label() + ")";
    bt.table.columns = {"phase", "cold_s", "cached_s"};
    bt.table.rows = {{"clBuildProgram (OpenCL C -> IR)", fmt(bt.cold_build), fmt(bt.cached_build)},
                     {"first launch (work-group function), minus steady launch", fmt(bt.cold_first_launch - bt.steady_launch),
                      fmt(bt.cached_first_launch - bt.steady_launch)},
                     {"total to first result", fmt(bt.cold_build + bt.cold_first_launch),
                      fmt(bt.cached_build + bt.cached_first_launch)},
                     {"ms::ocl::Device program cache lookup (in process)", "", fmt(bt.in_process_lookup)},
                     {"steady tiny launch (for scale)", fmt(bt.steady_launch), ""}};
    *opt.log << "build time: cached figures from a " << how << " over the PoCL cache " << dir << "\n";
    // Leave the directory for the rest of this process's builds; it is removed at exit by main.
    bt.cache_dir = dir;
    return bt;
}

}  // namespace ms::bench
