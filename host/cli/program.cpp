// The program: every command on one CLI11 app, and the exit status of a run.
// Exit status: 0 success, 1 failure while running, 2 bad command line or bad input, 3 written but some value
// less accurate than the tolerance asked (common.hpp), 130 interrupted by SIGINT, 143 by SIGTERM.
#include <cctype>
#include <iostream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "io/input_guard.hpp"
#include "device/build_log.hpp"

namespace ms::cli {

void build_app(CLI::App& app) {
    app.description("microshadow " MICROSHADOW_VERSION
                    " - the generic VNDF-based micro-shadowing term (GGX), exact (deterministic quadrature) or by OpenCL VNDF sampling");
    app.require_subcommand(1);
    app.set_version_flag("--version", "microshadow " MICROSHADOW_VERSION);
    app.add_flag_callback("-v,--verbose", [] { ocl::set_show_build_logs(true); },
                          "print each OpenCL kernel build's compiler log on stderr (by default a log is shown only when "
                          "a build fails); before or after the command");
    // Unknown options of a command are looked up here too, so that -v may follow the command.
    app.fallthrough();
    add_devices_command(app);
    add_eval_command(app);
    add_bake_command(app);
    add_sweep_command(app);
    add_merge_command(app);
    add_lut_command(app);
    add_shader_command(app);
    add_scene_command(app);
    add_ibl_command(app);
    add_design_command(app);
    add_repr_command(app);
    add_area_command(app);
    add_help_command(app);
}

namespace {

// The command that was being parsed when the parse failed: the deepest subcommand recognised.
CLI::App* parsed_command(CLI::App& app, std::string& path) {
    CLI::App* at = &app;
    for (;;) {
        const auto subs = at->get_subcommands();
        if (subs.empty()) return at;
        at = subs.front();
        path += (path.empty() ? "" : " ") + at->get_name();
    }
}

}  // namespace

std::string parse_error_line(CLI::App& app, int argc, char** argv, const CLI::ParseError& error) {
    std::string path;
    CLI::App* command = parsed_command(app, path);
    const std::string help = path.empty() ? "microshadow help" : "microshadow help " + path;
    // "microshadow bkae ...": no command was recognised.
    if (path.empty() && argc > 1 && argv[1][0] != '-' && argv[1][0] != '\0') {
        const std::string word = argv[1];
        // "microshadow version": the program's own option without its dashes.
        const std::string hint = app.get_option_no_throw("--" + word) ? "; did you mean --" + word + "?" : suggestion(app, word, false);
        return "'" + word + "' is not a command" + hint + " ('microshadow help' lists them)";
    }
    // "microshadow lut infp FILE": the word after a command that takes subcommands is none of them.
    if (!path.empty() && !command->get_subcommands([](CLI::App*) { return true; }).empty()) {
        int at = 1;
        for (std::size_t from = 0; at < argc && from != std::string::npos; ++at) {
            const std::size_t end = path.find(' ', from);
            if (path.compare(from, end == std::string::npos ? std::string::npos : end - from, argv[at]) == 0) from = end == std::string::npos ? end : end + 1;
        }
        if (at < argc && argv[at][0] != '-')
            return "'" + std::string(argv[at]) + "' is not a subcommand of 'microshadow " + path + "'" +
                   suggestion(*command, argv[at], false) + " ('" + help + "' lists them)";
    }
    // A word that looks like an option but is none of the command's: the likeliest mistake, and
    // the one to name even when CLI11 first noticed a required option missing.
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--") break;
        if (arg.size() < 2 || arg[0] != '-' || (arg[1] != '-' && !std::isalpha(static_cast<unsigned char>(arg[1])))) continue;
        const std::string name = arg.substr(0, arg.find('='));
        if (arg[1] != '-' && name.size() > 2) continue;  // -q3 style: a short flag with its value
        if (command->get_option_no_throw(name) || app.get_option_no_throw(name)) continue;
        return "'" + name + "' is not an option of '" + (path.empty() ? "microshadow" : "microshadow " + path) + "'" +
               suggestion(*command, name, true) + " ('" + help + "' lists them)";
    }
    std::string what = error.what();
    if (path.empty() && what == "A subcommand is required") what = "a command is required";
    return (path.empty() ? "" : path + ": ") + what + " ('" + help + "' lists the options)";
}

int run_program(int argc, char** argv) {
    set_command_line(argc, argv);
    CLI::App app;
    build_app(app);
    install_interrupt_handlers();
    // No output of the command may replace one of its inputs (io/input_guard.hpp).
    const InputGuard inputs;
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // One line: what is wrong and, for a mistyped word, the closest spelling (CLI11's own
        // report is two or three lines and names a missing option before a misspelt one).
        std::cerr << "microshadow: " << parse_error_line(app, argc, argv, e) << "\n";
        return 2;
    } catch (...) {
        return report_error(std::current_exception());
    }
    return 0;
}

}  // namespace ms::cli
