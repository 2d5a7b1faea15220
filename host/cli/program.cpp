// The program: every command on one CLI11 app, and the exit status of a run.
// Exit status: 0 success, 1 failure while running, 2 bad command line or bad input, 130 interrupted by SIGINT, 143 by SIGTERM.
#include <iostream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "io/input_guard.hpp"

namespace ms::cli {

void build_app(CLI::App& app) {
    app.description("microshadow " MICROSHADOW_VERSION
                    " - the generic VNDF-based micro-shadowing term (GGX), exact (deterministic quadrature) or by OpenCL VNDF sampling");
    app.require_subcommand(1);
    app.set_version_flag("--version", "microshadow " MICROSHADOW_VERSION);
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
    } catch (const CLI::ExtrasError& e) {
        // A mistyped option or command: name the closest spelling the command line accepts.
        app.exit(e);
        for (int i = 1; i < argc; ++i) {
            const std::string arg = argv[i];
            if (arg.empty() || std::string(e.what()).find(arg) == std::string::npos) continue;
            const std::string s = suggestion(app, arg.substr(0, arg.find('=')));
            if (!s.empty()) std::cerr << "microshadow: '" << arg << "' is not " << (arg[0] == '-' ? "an option" : "a command") << s << "\n";
        }
        return 2;
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        // "microshadow bkae": no subcommand was recognised; name the closest one.
        if (argc > 1 && argv[1][0] != '-' && app.get_subcommands().empty()) {
            const std::string s = suggestion(app, argv[1]);
            if (!s.empty()) std::cerr << "microshadow: '" << argv[1] << "' is not a command" << s << "\n";
        }
        return 2;
    } catch (...) {
        return report_error(std::current_exception());
    }
    return 0;
}

}  // namespace ms::cli
