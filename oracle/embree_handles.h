// Thin RAII owners for Embree 3 objects. Errors reported through rtcSetDeviceErrorFunction are
// kept (the callback must not throw through Embree) and raised by check() as EnvironmentError.
#pragma once

#include <embree3/rtcore.h>

#include <mutex>
#include <string>

namespace penumbra {

class EmbreeDevice {
  public:
    explicit EmbreeDevice(const std::string& config = "");
    ~EmbreeDevice();
    EmbreeDevice(const EmbreeDevice&) = delete;
    EmbreeDevice& operator=(const EmbreeDevice&) = delete;

    RTCDevice get() const { return device_; }
    // Throws EnvironmentError("Embree error during <what>: <message>") if Embree reported one.
    void check(const char* what) const;
    std::string version() const;

  private:
    static void on_error(void* self, RTCError code, const char* message);
    RTCDevice device_ = nullptr;
    mutable std::mutex mutex_;
    std::string first_error_;
};

class EmbreeScene {
  public:
    explicit EmbreeScene(const EmbreeDevice& device);
    ~EmbreeScene();
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;
    RTCScene get() const { return scene_; }

  private:
    RTCScene scene_ = nullptr;
};

}  // namespace penumbra
