// The progress line's estimate of what is left, and its silence off a terminal (the tests' stderr
// is a pipe or a file: nothing may be written there).
#include "common/progress.h"

#include <gtest/gtest.h>

namespace penumbra {
namespace {

TEST(Progress, EstimatesWhatIsLeftFromThePaceSoFar) {
    EXPECT_EQ(time_left(10.0, 0, 40), "");   // nothing done: no pace yet
    EXPECT_EQ(time_left(10.0, 40, 40), "");  // all done
    EXPECT_EQ(time_left(10.0, 10, 40), "about 30 s left");
    EXPECT_EQ(time_left(60.0, 10, 40), "about 3 min left");
    EXPECT_EQ(time_left(3600.0, 10, 40), "about 3.0 h left");
    EXPECT_EQ(time_left(0.1, 10, 20), "under a second left");
}

TEST(Progress, WritesNothingWhereStderrIsNoTerminal) {
    testing::internal::CaptureStderr();
    {
        ProgressLine line("validate", true);
        EXPECT_FALSE(line.shown());
        line.phase("drawing");
        line.step(1, 4, "frames judged");
    }
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

}  // namespace
}  // namespace penumbra
