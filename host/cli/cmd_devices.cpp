// microshadow devices: the OpenCL platforms and devices, numbered as --device takes them.
#include <iostream>

#include "cli/common.hpp"
#include "device/runtime.hpp"

namespace ms::cli {

void add_devices_command(CLI::App& app) {
    auto* cmd = app.add_subcommand("devices", "list OpenCL platforms and devices");
    cmd->callback([] {
        const auto devices = ocl::enumerate_devices();
        const auto chosen = ocl::select_devices("default");
        std::string platform;
        for (const auto& d : devices) {
            if (d.platform != platform) {
                platform = d.platform;
                std::cout << "platform: " << platform << "\n";
            }
            std::cout << "  " << d.index << ": " << d.name << (d.index == chosen.front().index ? "  (default)" : "") << "\n"
                      << "     type " << d.type << ", " << d.compute_units << " compute units, "
                      << d.global_memory / (1024 * 1024) << " MiB, " << d.version << ", driver " << d.driver
                      << (d.fp64 ? ", fp64" : "") << "\n";
        }
        // Where PoCL keeps compiled kernels: the directory to remove if a damaged entry breaks runs.
        std::cout << "PoCL kernel cache: " << ocl::pocl_cache_dir() << "\n";
        for (const auto& entry : ocl::damaged_kernel_cache_entries())
            std::cout << "  damaged entry (remove it; PoCL aborts on it): " << entry << "\n";
    });
}

}  // namespace ms::cli
