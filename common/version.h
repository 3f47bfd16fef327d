// penumbra's version, as `penumbra --version` prints it and report.json records it, and the
// command line that made a run, as the reports show it.
#pragma once

#include <string>

namespace penumbra {

const char* version_string();

// The command line of this process as a shell would take it back (each argument quoted where it
// needs it), set once by main; empty in a library user's process that never sets it.
void set_command_line(int argc, const char* const* argv);
const std::string& command_line();

}  // namespace penumbra
