// What a long run is doing, on one line of a terminal rewritten in place: the command, its phase,
// and for counted steps (frames of a camera path) how many are done and about how long is left
// at the pace so far. Nothing where stderr is not a terminal or the run is quiet, so that logs
// and pipes see only the results.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "common/stopwatch.h"

namespace penumbra {

class ProgressLine {
  public:
    // Shown only when `enabled` and stderr is a terminal.
    ProgressLine(std::string command, bool enabled);
    ~ProgressLine();  // clears the line
    ProgressLine(const ProgressLine&) = delete;
    ProgressLine& operator=(const ProgressLine&) = delete;

    bool shown() const { return shown_; }
    // "validate: tracing the truth"
    void phase(std::string_view what);
    // "validate: 3/40 frames judged (about 12 s left)": the estimate from the steps done so far.
    void step(std::size_t done, std::size_t total, std::string_view what);
    void clear();

  private:
    void write(const std::string& text);
    std::string command_;
    bool shown_ = false;
    bool dirty_ = false;
    SteadyClock::time_point start_ = SteadyClock::now();
};

// "about 12 s left", "about 3 min left", "about 1.2 h left"; "" before anything is done.
std::string time_left(double elapsed_s, std::size_t done, std::size_t total);

}  // namespace penumbra
