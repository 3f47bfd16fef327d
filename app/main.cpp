// penumbra: where shadow maps are wrong, pixel by pixel, and why. The command-line front end:
// registers the subcommands (app/*_command.cpp) and maps failures to the exit codes of
// docs/design.md.
#include <fmt/format.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "app/cli.h"
#include "common/errors.h"
#include "common/output_files.h"
#include "common/version.h"

namespace {

// What a command printed on stdout (camera's JSON, devices, --help) must arrive: a write error
// (a full disk, /dev/full) is the environment's failure, not a success with an empty file.
int check_stdout(int code) {
    errno = 0;
    const bool failed = std::fflush(stdout) != 0 || std::ferror(stdout);
    if (!failed) return code;
    fmt::print(stderr, "error: cannot write to standard output: {}\n",
               errno != 0 ? std::strerror(errno) : "write error");
    return penumbra::kExitEnvironment;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace penumbra;
    CLI::App app{"penumbra: tells, pixel by pixel, where shadows are wrong and why"};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("penumbra ") + version_string());

    const std::vector<cli::Subcommand> commands = {
        cli::add_oracle_command(app),  cli::add_raster_command(app), cli::add_validate_command(app),
        cli::add_devices_command(app), cli::add_tune_command(app),   cli::add_compare_command(app),
        cli::add_camera_command(app),  cli::add_sweep_command(app),  cli::add_merge_command(app),
        cli::add_stress_command(app),  cli::add_init_command(app),   cli::add_diff_command(app),
        cli::add_cache_command(app),   cli::add_units_command(app),
    };

    set_command_line(argc, argv);  // shown in the reports a run writes
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        int code = app.exit(e);
        return check_stdout(code == 0 ? kExitSuccess : kExitBadInput);
    }
    install_interrupt_cleanup();  // Ctrl-C leaves no temporary file and no folder it made
    try {
        for (const auto& c : commands)
            if (*c.app) return check_stdout(c.run());
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
