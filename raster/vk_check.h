// Checked Vulkan calls and RAII owners for Vulkan objects.
#pragma once

#include <vulkan/vulkan.h>

#include <string>
#include <utility>

namespace penumbra::raster {

const char* vk_result_name(VkResult result);

// Throws EnvironmentError naming the call, the VkResult, file and line. Out-of-memory and
// device-lost results are environment failures (exit 3) like every other Vulkan failure.
[[noreturn]] void vk_fail(VkResult result, const char* call, const char* file, int line);

#define VK_CHECK(call)                                                                                                \
    do {                                                                                                              \
        VkResult vk_check_result_ = (call);                                                                           \
        if (vk_check_result_ != VK_SUCCESS) ::penumbra::raster::vk_fail(vk_check_result_, #call, __FILE__, __LINE__); \
    } while (0)

// Owns one device-level handle; Destroy is the matching vkDestroy*/vkFree* function.
template <typename Handle, void (*Destroy)(VkDevice, Handle, const VkAllocationCallbacks*)>
class DeviceObject {
  public:
    DeviceObject() = default;
    DeviceObject(VkDevice device, Handle handle) : device_(device), handle_(handle) {}
    ~DeviceObject() { reset(); }
    DeviceObject(DeviceObject&& o) noexcept
        : device_(o.device_), handle_(std::exchange(o.handle_, static_cast<Handle>(VK_NULL_HANDLE))) {}
    DeviceObject& operator=(DeviceObject&& o) noexcept {
        if (this != &o) {
            reset();
            device_ = o.device_;
            handle_ = std::exchange(o.handle_, static_cast<Handle>(VK_NULL_HANDLE));
        }
        return *this;
    }
    DeviceObject(const DeviceObject&) = delete;
    DeviceObject& operator=(const DeviceObject&) = delete;

    void reset() {
        if (handle_ != VK_NULL_HANDLE) Destroy(device_, handle_, nullptr);
        handle_ = VK_NULL_HANDLE;
    }
    Handle get() const { return handle_; }
    const Handle* ptr() const { return &handle_; }
    explicit operator bool() const { return handle_ != VK_NULL_HANDLE; }

  private:
    VkDevice device_ = VK_NULL_HANDLE;
    Handle handle_ = VK_NULL_HANDLE;
};

using UniqueBuffer = DeviceObject<VkBuffer, vkDestroyBuffer>;
using UniqueImage = DeviceObject<VkImage, vkDestroyImage>;
using UniqueImageView = DeviceObject<VkImageView, vkDestroyImageView>;
using UniqueMemory = DeviceObject<VkDeviceMemory, vkFreeMemory>;
using UniqueSampler = DeviceObject<VkSampler, vkDestroySampler>;
using UniqueShaderModule = DeviceObject<VkShaderModule, vkDestroyShaderModule>;
using UniquePipeline = DeviceObject<VkPipeline, vkDestroyPipeline>;
using UniquePipelineLayout = DeviceObject<VkPipelineLayout, vkDestroyPipelineLayout>;
using UniqueDescriptorSetLayout = DeviceObject<VkDescriptorSetLayout, vkDestroyDescriptorSetLayout>;
using UniqueDescriptorPool = DeviceObject<VkDescriptorPool, vkDestroyDescriptorPool>;
using UniqueCommandPool = DeviceObject<VkCommandPool, vkDestroyCommandPool>;
using UniqueQueryPool = DeviceObject<VkQueryPool, vkDestroyQueryPool>;
using UniqueFence = DeviceObject<VkFence, vkDestroyFence>;

}  // namespace penumbra::raster
