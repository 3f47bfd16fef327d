#include "oracle/embree_handles.h"

#include <fmt/format.h>

#include "common/errors.h"

namespace penumbra {

EmbreeDevice::EmbreeDevice(const std::string& config) {
    device_ = rtcNewDevice(config.empty() ? nullptr : config.c_str());
    if (!device_)
        throw EnvironmentError(
            fmt::format("Embree: cannot create a device ({})", static_cast<int>(rtcGetDeviceError(nullptr))));
    // Registered first thing so that no error goes unseen (Embree tutorials do the same).
    rtcSetDeviceErrorFunction(device_, &EmbreeDevice::on_error, this);
}

EmbreeDevice::~EmbreeDevice() {
    rtcReleaseDevice(device_);
}

void EmbreeDevice::on_error(void* self, RTCError code, const char* message) {
    auto* d = static_cast<EmbreeDevice*>(self);
    std::lock_guard lock(d->mutex_);
    if (d->first_error_.empty())
        d->first_error_ = fmt::format("{} (code {})", message ? message : "unknown", static_cast<int>(code));
}

void EmbreeDevice::check(const char* what) const {
    std::lock_guard lock(mutex_);
    if (!first_error_.empty()) throw EnvironmentError(fmt::format("Embree error during {}: {}", what, first_error_));
}

std::string EmbreeDevice::version() const {
    long v = static_cast<long>(rtcGetDeviceProperty(device_, RTC_DEVICE_PROPERTY_VERSION));
    return fmt::format("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100);
}

EmbreeScene::EmbreeScene(const EmbreeDevice& device) : scene_(rtcNewScene(device.get())) {
    device.check("scene creation");
}

EmbreeScene::~EmbreeScene() {
    if (scene_) rtcReleaseScene(scene_);
}

}  // namespace penumbra
