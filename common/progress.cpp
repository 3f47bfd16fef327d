#include "common/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cstdio>

namespace penumbra {

ProgressLine::ProgressLine(std::string command, bool enabled)
    : command_(std::move(command)), shown_(enabled && ::isatty(STDERR_FILENO)) {}

ProgressLine::~ProgressLine() {
    clear();
}

void ProgressLine::write(const std::string& text) {
    if (!shown_) return;
    // Carriage return and erase-line (ECMA-48 EL): the line is rewritten, never scrolled.
    std::fprintf(stderr, "\r\033[K%s: %s", command_.c_str(), text.c_str());
    std::fflush(stderr);
    dirty_ = true;
}

void ProgressLine::phase(std::string_view what) {
    write(std::string(what));
}

void ProgressLine::step(std::size_t done, std::size_t total, std::string_view what) {
    const std::string left = time_left(seconds_since(start_), done, total);
    write(
        fmt::format("{}/{}{}{}{}", done, total, what.empty() ? "" : " ", what, left.empty() ? "" : " (" + left + ")"));
}

void ProgressLine::clear() {
    if (!dirty_) return;
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    dirty_ = false;
}

std::string time_left(double elapsed_s, std::size_t done, std::size_t total) {
    if (done == 0 || done >= total || !(elapsed_s > 0)) return "";
    const double left = elapsed_s / static_cast<double>(done) * static_cast<double>(total - done);
    if (left < 1) return "under a second left";
    if (left < 90) return fmt::format("about {:.0f} s left", left);
    if (left < 5400) return fmt::format("about {:.0f} min left", left / 60);
    return fmt::format("about {:.1f} h left", left / 3600);
}

}  // namespace penumbra
