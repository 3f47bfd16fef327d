// penumbra: where shadow maps are wrong, pixel by pixel, and why. The command-line front end:
// registers the subcommands (app/*_command.cpp) and maps failures to the exit codes of
// docs/design.md.
#include <fmt/format.h>

#include <new>
#include <string>
#include <vector>

#include "app/cli.h"
#include "common/errors.h"
#include "common/output_files.h"
#include "common/version.h"

int main(int argc, char** argv) {
    using namespace penumbra;
    CLI::App app{"penumbra: tells, pixel by pixel, where shadows are wrong and why"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("penumbra ") + version_string());

    const std::vector<cli::Subcommand> commands = {
        cli::add_oracle_command(app),  cli::add_raster_command(app), cli::add_validate_command(app),
        cli::add_devices_command(app), cli::add_tune_command(app),   cli::add_compare_command(app),
        cli::add_camera_command(app),  cli::add_sweep_command(app),  cli::add_merge_command(app),
        cli::add_stress_command(app),
    };

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int code = app.exit(e);
        return code == 0 ? kExitSuccess : kExitBadInput;
    }
    install_interrupt_cleanup();  // Ctrl-C leaves no temporary file and no folder it made
    try {
        for (const auto& c : commands)
            if (*c.app) return c.run();
    } catch (const InputError& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return kExitBadInput;
    } catch (const EnvironmentError& e) {
        fmt::print(stderr, "error: {}\n", e.what());
        return kExitEnvironment;
    } catch (const std::bad_alloc&) {
        fmt::print(stderr, "error: out of memory\n");
        return kExitEnvironment;
    } catch (const std::exception& e) {
        fmt::print(stderr, "internal error (a bug in penumbra, please report it): {}\n", e.what());
        return kExitInternal;
    }
    return kExitBadInput;
}
