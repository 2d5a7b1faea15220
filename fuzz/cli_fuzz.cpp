// libFuzzer target: the command-line parser. The input is split at NUL and newline bytes into argv;
// the CLI11 app is the program's own (ms::cli::build_app), and each subcommand gets a
// parse-complete callback that throws ParsedOnly: CLI11 calls it after the subcommand's options were
// converted, checked (ranges, membership, files) and its requirements validated, and before the
// final callback that would run the command. The final callbacks must stay in place: they own the
// option storage (a shared_ptr captured by the lambda), so removing them would free it mid-parse.
// Contract: parse() returns or throws CLI::ParseError (the program's exit status 2 with a message) or
// ParsedOnly; anything else is a finding.
#include <cstdint>
#include <string>
#include <vector>

#include "cli/common.hpp"
#include "fuzz_common.hpp"

namespace {

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

    CLI::App app;
    ms::cli::build_app(app);
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        sub->parse_complete_callback([] { throw ParsedOnly{}; });
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    try {
        app.parse(int(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
        // The one line the program prints for it (the suggestion walks argv and the parsed commands).
        (void)ms::cli::parse_error_line(app, int(argv.size()), argv.data(), e);
    } catch (const ParsedOnly&) {
    }
    return 0;
}
