// libFuzzer target: the command-line parser. The input is split at NUL and newline bytes into argv;
// the CLI11 app is built exactly as host/cli/main.cpp builds it, and each subcommand gets a
// parse-complete callback that throws ParsedOnly: CLI11 calls it after the subcommand's options were
// converted, checked (ranges, membership, files) and its requirements validated, and before the
// final callback that would run the command. The final callbacks must stay in place: they own the
// option storage (a shared_ptr captured by the lambda), so removing them would free it mid-parse.
// Contract: parse() returns or throws CLI::ParseError (main.cpp's exit code 2 with a message) or
// ParsedOnly; anything else is a finding.
#include <cstdint>
#include <string>
#include <vector>

#include "cli/common.hpp"
#include "fuzz_common.hpp"

namespace {

// Must mirror main.cpp's registration list (see the report to the lead: a shared
// ms::cli::build_app(CLI::App&) would remove this duplication).
void build_app(CLI::App& app) {
    app.require_subcommand(1);
    app.set_version_flag("--version", "microshadow " MICROSHADOW_VERSION);
    ms::cli::add_devices_command(app);
    ms::cli::add_eval_command(app);
    ms::cli::add_bake_command(app);
    ms::cli::add_sweep_command(app);
    ms::cli::add_merge_command(app);
    ms::cli::add_shader_command(app);
    ms::cli::add_scene_command(app);
    ms::cli::add_ibl_command(app);
    ms::cli::add_help_command(app);
}

struct ParsedOnly {};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<std::string> args{"microshadow"};
    std::string current;
    for (std::size_t i = 0; i < size; ++i) {
        const char c = char(data[i]);
        if (c == '\0' || c == '\n') {
            args.push_back(current);
            current.clear();
        } else {
            current += c;
        }
    }
    if (!current.empty()) args.push_back(current);
    if (args.size() > 64) return 0;  // long argv only repeats what short ones already exercise

    CLI::App app{"microshadow (fuzz)"};
    build_app(app);
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        sub->parse_complete_callback([] { throw ParsedOnly{}; });
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    try {
        app.parse(int(argv.size()), argv.data());
    } catch (const CLI::ParseError&) {
    } catch (const ParsedOnly&) {
    }
    return 0;
}
