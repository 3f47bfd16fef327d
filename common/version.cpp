#include "common/version.h"

#include <filesystem>

namespace penumbra {

namespace {

std::string& stored_command_line() {
    static std::string line;
    return line;
}

// POSIX shell quoting: bare when every character is safe, else in single quotes.
std::string shell_quoted(const std::string& arg) {
    if (!arg.empty() && arg.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789"
                                              "@%_+=:,./-") == std::string::npos)
        return arg;
    std::string q = "'";
    for (char c : arg) {
        if (c == '\'')
            q.append("'\\''");
        else
            q.push_back(c);
    }
    q.push_back('\'');
    return q;
}

}  // namespace

const char* version_string() {
    return PENUMBRA_VERSION;
}

void set_command_line(int argc, const char* const* argv) {
    std::string line;
    for (int i = 0; i < argc; ++i) {
        // The program by its name alone: the build folder it ran from says nothing to a reader.
        const std::string arg = i == 0 ? std::filesystem::path(argv[0]).filename().string() : std::string(argv[i]);
        if (i) line.push_back(' ');
        line.append(shell_quoted(arg));
    }
    stored_command_line() = line;
}

const std::string& command_line() {
    return stored_command_line();
}

}  // namespace penumbra
