// The project's matplotlib scripts (scripts/plot_*.py) as the CLI runs them for --plot: found from the
// executable's own location, and run without a shell.
#pragma once

#include <string>
#include <vector>

namespace ms::cli {

// The script `name` (e.g. "plot_sweep.py"), found from the executable's own location (no path compiled
// in, so a moved or installed binary finds its own copy): <prefix>/bin/microshadow ->
// <prefix>/share/microshadow/; a build tree (build/microshadow) -> the source tree's scripts/, found
// beside the build directory or through the build directory's CMakeCache.txt (CMAKE_HOME_DIRECTORY) for
// out-of-tree builds. Throws std::runtime_error listing where it looked.
std::string find_plot_script(const std::string& name);

// The Python interpreter the plot scripts run with, as a command's first arguments: MICROSHADOW_PYTHON
// when set; else the first python3 on PATH that has matplotlib, then Windows' `py -3` launcher (or the
// first of them, whose error then says what is missing). Throws std::runtime_error, saying how to
// install or name one, when there is none.
std::vector<std::string> python_command();

// Runs args[0] (a path, or a program on PATH) with args as its argument vector: no shell, so no file name (a spec
// called x';touch PWNED;'.toml, an --out with quotes) is ever parsed as a command. The command line is
// not echoed (the plotter prints the figures it writes). A failing plotter becomes ExitError with
// kExitPlotFailed (cli/common.hpp) and the message "plotting failed (exit status N | killed by signal
// N): COMMAND; " + what_is_done: the plotter's own status is named, never passed through, so it cannot
// read as one of ours (3: tolerance not met). SIGINT or SIGTERM while it runs ends the plotter and
// throws Cancelled (exit status 130 / 143).
void run_plotter(const std::vector<std::string>& args, const std::string& what_is_done);

// --plot's whole step after a command has written its outputs: the interpreter (python_command), the
// script (find_plot_script) and run_plotter with `script_args` after the script's path. Every failure,
// a missing interpreter or script included, is ExitError with kExitPlotFailed and ends with
// "; " + what_is_done (the outputs are written); interruption stays Cancelled.
void run_plot_script(const std::string& script, const std::vector<std::string>& script_args, const std::string& what_is_done);

}  // namespace ms::cli
