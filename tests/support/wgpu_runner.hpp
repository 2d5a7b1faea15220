// WGSL compute shaders run through wgpu (the `wgpu` PyPI package, tests/gpu/wgpu_compute.py) on the
// machine's WebGPU adapter (Mesa lavapipe on a CPU-only machine), for the WGSL shader tests.
//
// The Python: $MICROSHADOW_WGPU_PYTHON when set; else the virtual environment <build>/wgpu-venv, made on
// first use (`python3 -m venv --system-site-packages`, then `pip install wgpu==0.32.0`: about 15 s once,
// a few MB of wheels). A machine where that fails (no network, no wheel for the platform) skips the tests
// with the reason.
#pragma once

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "vulkan_compute.hpp"

namespace ms::testing {

struct WgpuJob {
    std::string wgsl;                      // the whole compute shader (entry point main)
    std::vector<ComputeTexture> textures;  // vk_format 109 (RGBA32F) or 97 (RGBA16F)
    std::vector<float> inputs_vec4;
    std::size_t output_count = 0;
};

struct WgpuResult {
    std::string skip;    // non-empty: wgpu could not run here (the reason)
    std::string device;  // the adapter that ran the jobs
    std::vector<std::vector<float>> outputs;
};

inline std::string wgpu_python(std::string* why) {
    if (const char* p = std::getenv("MICROSHADOW_WGPU_PYTHON")) return p;
    const std::string venv = std::filesystem::path(MICROSHADOW_CLI).parent_path() / "wgpu-venv";
    const std::string python = venv + "/bin/python";
    if (run_shell(python + " -c 'import wgpu' 2>/dev/null").exit_code == 0) return python;
    // Under a lock: ctest runs the WGSL tests in parallel, and the first ones would make it together.
    const RunResult made = run_shell("flock " + venv + ".lock sh -c '" + python + " -c \"import wgpu\" 2>/dev/null || (python3 -m venv " +
                                     "--system-site-packages " + venv + " && " + python +
                                     " -m pip install -q --disable-pip-version-check wgpu==0.32.0)' 2>&1");
    if (made.exit_code != 0 || run_shell(python + " -c 'import wgpu' 2>/dev/null").exit_code != 0) {
        *why = "no Python with the wgpu package (set MICROSHADOW_WGPU_PYTHON, or let the test make " + venv + "): " +
               made.output.substr(0, 400);
        return "";
    }
    return python;
}

// Runs the jobs in one Python process; files go in `dir`.
inline WgpuResult run_wgpu(const std::vector<WgpuJob>& jobs, const std::string& dir) {
    WgpuResult result;
    const std::string python = wgpu_python(&result.skip);
    if (python.empty()) return result;
    auto write_bytes = [](const std::string& path, const void* data, std::size_t size) {
        std::ofstream(path, std::ios::binary).write(static_cast<const char*>(data), std::streamsize(size));
    };
    nlohmann::json spec;
    spec["jobs"] = nlohmann::json::array();
    for (std::size_t j = 0; j < jobs.size(); ++j) {
        const std::string base = dir + "/wgpu_job" + std::to_string(j);
        std::ofstream(base + ".wgsl") << jobs[j].wgsl;
        write_bytes(base + "_in.bin", jobs[j].inputs_vec4.data(), jobs[j].inputs_vec4.size() * sizeof(float));
        nlohmann::json job = {{"shader", base + ".wgsl"}, {"inputs", base + "_in.bin"}, {"outputs", base + "_out.bin"},
                              {"output_count", jobs[j].output_count}, {"textures", nlohmann::json::array()}};
        for (std::size_t t = 0; t < jobs[j].textures.size(); ++t) {
            const ComputeTexture& tex = jobs[j].textures[t];
            const std::string data = base + "_tex" + std::to_string(t) + ".bin";
            write_bytes(data, tex.texels.data(), tex.texels.size());
            job["textures"].push_back({{"data", data}, {"width", tex.width}, {"height", tex.height}, {"depth", tex.depth},
                                       {"dimension", tex.three_d ? "3d" : "2d"},
                                       {"format", tex.vk_format == 109 ? "rgba32float" : "rgba16float"}});
        }
        spec["jobs"].push_back(job);
    }
    std::ofstream(dir + "/wgpu_spec.json") << spec.dump(1);
    const RunResult r = run_shell("XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp} " + python + " " + MICROSHADOW_SOURCE_DIR +
                                  "/tests/gpu/wgpu_compute.py " + dir + "/wgpu_spec.json 2>&1");
    result.device = r.output.substr(0, r.output.find('\n'));
    if (r.exit_code == 3) {
        result.skip = r.output;
        return result;
    }
    EXPECT_EQ(r.exit_code, 0) << r.output;
    if (r.exit_code != 0) return result;
    for (std::size_t j = 0; j < jobs.size(); ++j) {
        std::ifstream in(dir + "/wgpu_job" + std::to_string(j) + "_out.bin", std::ios::binary);
        std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
        std::vector<float> values(bytes.size() / 4);
        if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * 4);
        result.outputs.push_back(std::move(values));
    }
    return result;
}

}  // namespace ms::testing
