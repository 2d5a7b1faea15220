#include "cli/plot_runner.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <system_error>

#include "cli/common.hpp"
#include "core/cancel.hpp"
#include "io/text.hpp"
#include "platform/process.hpp"

namespace ms::cli {

namespace fs = std::filesystem;

std::string find_plot_script(const std::string& name) {
    std::error_code ec;
    const fs::path exe = fs::u8path(platform::executable_path(ec));
    if (ec) throw std::runtime_error("--plot: cannot find the executable's path (" + ec.message() + ")");
    const fs::path bin = exe.parent_path();
    std::vector<fs::path> candidates = {bin / ".." / "share" / "microshadow" / name, bin / ".." / "scripts" / name};
    std::ifstream cache(bin / "CMakeCache.txt");
    for (std::string line; std::getline(cache, line);)
        if (line.rfind("CMAKE_HOME_DIRECTORY:INTERNAL=", 0) == 0)
            candidates.push_back(fs::u8path(line.substr(line.find('=') + 1)) / "scripts" / name);
    std::string looked;
    for (const auto& c : candidates) {
        if (fs::is_regular_file(c, ec)) return c.lexically_normal().u8string();
        looked += "\n  " + c.lexically_normal().u8string();
    }
    throw std::runtime_error("--plot: " + name + " not found; looked in:" + looked);
}

namespace {

// Whether `python` (with its leading arguments) can import matplotlib: asked quietly, without loading it.
bool has_matplotlib(std::vector<std::string> python) {
    python.insert(python.end(), {"-c", "import importlib.util, sys; sys.exit(importlib.util.find_spec('matplotlib') is None)"});
    try {
        const platform::ProcessEnd end = platform::run_program(python);
        return end.exited && end.code == 0;
    } catch (const std::system_error&) {
        return false;
    }
}

}  // namespace

std::vector<std::string> python_command() {
    if (const char* chosen = std::getenv("MICROSHADOW_PYTHON"); chosen && *chosen) {
        if (platform::find_on_path(chosen).empty())
            throw std::runtime_error(std::string("--plot: MICROSHADOW_PYTHON=") + chosen + " is not a program that can be run");
        return {chosen};
    }
    // Every python3 on PATH, then Windows' launcher `py -3`; the first that has matplotlib (a virtual
    // environment's python3 earlier on PATH may lack it, while the system's has it).
    std::vector<std::vector<std::string>> found;
    for (const auto& p : platform::find_on_path("python3")) found.push_back({p});
    for (const auto& p : platform::find_on_path("py")) found.push_back({p, "-3"});
    if (found.empty())
        throw std::runtime_error(
            "--plot needs Python 3 with matplotlib, and no python3 (or py, on Windows) is on PATH: install Python 3 and "
            "matplotlib, or name the interpreter with MICROSHADOW_PYTHON=/path/to/python");
    for (const auto& python : found)
        if (has_matplotlib(python)) return python;
    return found.front();  // its own error then says what is missing
}

void run_plotter(const std::vector<std::string>& args, const std::string& what_is_done) {
    std::string shown;
    for (const auto& a : args) shown += (shown.empty() ? "" : " ") + shell_quote(a);
    // Not echoed: the plotter prints the figures it wrote; a failure names the command line.
    std::cout.flush();
    platform::ProcessEnd end;
    try {
        // SIGINT/SIGTERM sent to this process alone reach the plotter through this question: it is ended,
        // and the command stops as interrupted (a terminal's Ctrl-C reaches both anyway).
        end = platform::run_program(args, [] { return cancel_requested().load(); });
    } catch (const std::system_error& e) {
        throw std::runtime_error("--plot: " + std::string(e.what()));
    }
    if (cancel_requested().load()) throw Cancelled("interrupted: the plotter was stopped; " + what_is_done);
    if (end.exited && end.code == 0) return;
    // The plotter's own status is named, not passed through: 3 from a plotter would read as "tolerance
    // not met", 2 as bad input of ours.
    throw ExitError(kExitPlotFailed, "plotting failed (" +
                                         (end.exited ? "exit status " + std::to_string(end.code) : "killed by signal " + std::to_string(end.code)) +
                                         "): " + shown + "; " + what_is_done);
}

void run_plot_script(const std::string& script, const std::vector<std::string>& script_args, const std::string& what_is_done) {
    std::vector<std::string> command;
    try {
        command = python_command();
        command.push_back(find_plot_script(script));
    } catch (const std::runtime_error& e) {
        throw ExitError(kExitPlotFailed, std::string(e.what()) + "; " + what_is_done);
    }
    command.insert(command.end(), script_args.begin(), script_args.end());
    try {
        run_plotter(command, what_is_done);
    } catch (const ExitError&) {
        throw;
    } catch (const Cancelled&) {
        throw;
    } catch (const std::runtime_error& e) {  // the plotter could not be started
        throw ExitError(kExitPlotFailed, std::string(e.what()) + "; " + what_is_done);
    }
}

}  // namespace ms::cli
