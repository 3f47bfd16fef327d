// Embree's 16-wide packets on CPUs without native 16-wide kernels: inactive lanes must be
// neither traced nor written (oracle/tracer.h, intersect_active_lanes). max_isa selects those
// kernels (8 wide with AVX2, 4 with SSE) on any x86 CPU, so the test means the same on an
// AVX-512 machine.
#include <embree3/rtcore.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "oracle/embree_handles.h"
#include "oracle/tracer.h"

namespace penumbra::oracle_detail {
namespace {

constexpr unsigned kUntouched = 12345;

// One ray straight down at (x, y) from z = 1, onto the ground triangle.
void aim_down(RTCRayHit16& rh, int k, float x, float y) {
    rh.ray.org_x[k] = x;
    rh.ray.org_y[k] = y;
    rh.ray.org_z[k] = 1.0f;
    rh.ray.dir_x[k] = 0.0f;
    rh.ray.dir_y[k] = 0.0f;
    rh.ray.dir_z[k] = -1.0f;
    rh.ray.tnear[k] = 0.0f;
    rh.ray.tfar[k] = std::numeric_limits<float>::infinity();
    rh.ray.time[k] = 0.0f;
    rh.ray.mask[k] = ~0u;
    rh.ray.id[k] = static_cast<unsigned>(k);
    rh.ray.flags[k] = 0;
    rh.hit.geomID[k] = kUntouched;
    rh.hit.primID[k] = kUntouched;
}

class PacketLanes : public testing::TestWithParam<const char*> {};

TEST_P(PacketLanes, InactiveLanesAreNeitherTracedNorWrittenByTheStreamFallback) {
    EmbreeDevice device(std::string("verbose=0,threads=1,max_isa=") + GetParam());
    if (rtcGetDeviceProperty(device.get(), RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0)
        GTEST_SKIP() << "this Embree has native 16-wide kernels even at max_isa=" << GetParam();
    EmbreeScene scene(device);
    RTCGeometry g = rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, 3));
    auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, 1));
    const float ground[9] = {-10, -10, 0, 10, -10, 0, 0, 10, 0};
    for (int i = 0; i < 9; ++i) vb[i] = ground[i];
    ib[0] = 0, ib[1] = 1, ib[2] = 2;
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene.get(), g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene.get());
    device.check("test scene");

    // One 16-wide packet, or two 8-wide halves (native with AVX2, the fallback again with SSE),
    // with the second half's lanes all inactive but one, then none.
    for (int variant = 0; variant < 4; ++variant) {
        const bool as_halves = variant >= 2;
        const int flags =
            variant % 2 == 0 ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        alignas(64) RTCRayHit16 rh;
        alignas(64) int valid[16];
        for (int k = 0; k < 16; ++k) {
            aim_down(rh, k, 0.1f * k - 0.8f, 0.0f);  // every lane would hit the ground
            valid[k] = (k < 8 ? k % 2 == 0 : k == 12 && flags == RTC_INTERSECT_CONTEXT_FLAG_COHERENT) ? -1 : 0;
        }
        // A lane left holding garbage: non-finite, Embree asserts on it if it is traced.
        rh.ray.org_x[5] = std::numeric_limits<float>::quiet_NaN();
        rh.ray.dir_y[7] = std::numeric_limits<float>::infinity();
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = static_cast<RTCIntersectContextFlags>(flags);
        intersect_active_lanes(valid, scene.get(), &ctx, rh, as_halves);
        for (int k = 0; k < 16; ++k) {
            SCOPED_TRACE(testing::Message() << "lane " << k << ", context flags " << flags << ", halves " << as_halves);
            if (valid[k]) {
                EXPECT_EQ(rh.hit.geomID[k], 0u);
                EXPECT_FLOAT_EQ(rh.ray.tfar[k], 1.0f);
            } else {
                EXPECT_EQ(rh.hit.geomID[k], kUntouched);
                EXPECT_EQ(rh.hit.primID[k], kUntouched);
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Kernels, PacketLanes, testing::Values("avx2", "sse4.2"), [](const auto& param_info) {
    return std::string(param_info.param[0] == 'a' ? "avx2" : "sse42");
});

}  // namespace
}  // namespace penumbra::oracle_detail
