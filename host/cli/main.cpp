// microshadow: the generic VNDF-based micro-shadowing term on OpenCL.
// Exit status: 0 success, 1 failure while running, 2 bad command line or bad input, 130 interrupted by SIGINT, 143 by SIGTERM.
#include <iostream>

#include "cli/common.hpp"
#include "cli/progress.hpp"
#include "core/cancel.hpp"
#include "io/csv.hpp"
#include "device/error.hpp"

int main(int argc, char** argv) {
    using namespace ms;
    cli::set_command_line(argc, argv);
    CLI::App app{"microshadow " MICROSHADOW_VERSION
                 " - the generic VNDF-based micro-shadowing term (GGX), exact (deterministic quadrature) or by OpenCL VNDF sampling"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "microshadow " MICROSHADOW_VERSION);
    cli::add_devices_command(app);
    cli::add_eval_command(app);
    cli::add_bake_command(app);
    cli::add_sweep_command(app);
    cli::add_merge_command(app);
    cli::add_lut_command(app);
    cli::add_shader_command(app);
    cli::add_scene_command(app);
    cli::add_ibl_command(app);
    cli::add_design_command(app);
    cli::add_repr_command(app);
    cli::add_area_command(app);
    cli::add_help_command(app);
    cli::install_interrupt_handlers();
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
            const std::string s = cli::suggestion(app, arg.substr(0, arg.find('=')));
            if (!s.empty()) std::cerr << "microshadow: '" << arg << "' is not " << (arg[0] == '-' ? "an option" : "a command") << s << "\n";
        }
        return 2;
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        // "microshadow bkae": no subcommand was recognised; name the closest one.
        if (argc > 1 && argv[1][0] != '-' && app.get_subcommands().empty()) {
            const std::string s = cli::suggestion(app, argv[1]);
            if (!s.empty()) std::cerr << "microshadow: '" << argv[1] << "' is not a command" << s << "\n";
        }
        return 2;
    } catch (const Cancelled& e) {
        std::cerr << "microshadow: " << e.what() << "\n";
        return cli::interrupted_exit_status();
    } catch (const CsvError& e) {
        std::cerr << "microshadow: error: " << e.what() << "\n";
        return 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << "microshadow: error: " << e.what() << "\n";
        return 2;
    } catch (const cli::ExitError& e) {
        std::cerr << "microshadow: error: " << e.what() << "\n";
        return e.code();
    } catch (const ocl::NoDeviceError& e) {
        std::cerr << "microshadow: error: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "microshadow: error: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
