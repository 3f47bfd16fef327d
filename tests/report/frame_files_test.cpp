// The oracle's image files: oracle.exr written during the boundary phase and completed in place
// afterwards is the file written in one go from the finished frame (#39).
#include "report/frame_files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <vector>

#include "common/output_files.h"
#include "oracle/oracle.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

std::vector<char> file_bytes(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Two lights, a sun and a point light, on boxes over a plane: both have boundaries, so U and
// boundary_m, the channels filled in after the boundary phase, are far from the placeholders.
// The early write (--threads 2 and up) gives, byte for byte, what write_oracle_images writes from
// the frame.
TEST(OracleFiles, ExrWrittenDuringTheBoundaryPhaseIsTheDirectlyWrittenFile) {
    test::SceneBuilder b;
    b.quad({-10, 0, 10}, {10, 0, 10}, {10, 0, -10}, {-10, 0, -10}, false);
    b.box({-1.5, 0, -1.0}, {-0.5, 1.2, 0.0});
    b.box({0.6, 0, 0.2}, {1.4, 0.7, 1.1});
    b.sphere({0.2, 1.6, -1.2}, 0.5, 16, 8);
    const Scenario sc =
        test::make_scenario(b.build(), test::look_at({0, 6, 6}, {0, 0, 0}, 55),
                            {test::directional({0.3, -1.0, 0.2}), test::point({1.5, 4.0, -1.0})}, 203, 150);
    const test::TempDir tmp;
    OutputTransaction early(tmp / "early");
    std::shared_future<void> started;
    double early_s = -1;
    OracleSettings settings;
    settings.threads = 2;
    const OracleResult r = run_oracle(sc, settings, [&](const OracleFrame& f) {
        started = report::start_oracle_exr(early, f, early_s);
        return started;
    });
    ASSERT_TRUE(started.valid());
    started.get();
    EXPECT_GE(early_s, 0.0);
    const std::vector<char> before_patch = file_bytes(early.stage("oracle.exr"));
    report::write_oracle_images(early, r.frame, nullptr, started);
    early.commit();

    OutputTransaction direct(tmp / "direct");
    report::write_oracle_images(direct, r.frame);
    direct.commit();

    // The channels patched hold something: shadow boundaries of both lights, pixels near them.
    for (const OracleLightImage& img : r.frame.lights) {
        std::size_t finite = 0;
        for (const float d : img.boundary_m) finite += std::isfinite(d);
        EXPECT_GT(finite, 1000u);
    }
    const std::vector<char> want = file_bytes(tmp / "direct" / "oracle.exr");
    ASSERT_GT(want.size(), 203u * 150u * 4u);
    EXPECT_NE(before_patch, want);  // the placeholders were there before the patch
    EXPECT_TRUE(file_bytes(tmp / "early" / "oracle.exr") == want);
}

}  // namespace
}  // namespace penumbra
