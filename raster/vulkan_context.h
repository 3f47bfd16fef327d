// A headless Vulkan 1.3 device: instance, the chosen physical device, one queue, memory
// helpers and, when asked, the Khronos validation layer with every message recorded.
#pragma once

#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "raster/vk_check.h"

namespace penumbra::raster {

struct DeviceInfo {
    std::uint32_t index = 0;
    std::string name;
    std::string type;  // "cpu", "discrete-gpu", ...
    std::string driver;
    std::string api_version;
    bool lavapipe = false;
    // The clocks behind GPU times (docs/raster.md, "Timings"): nanoseconds per timestamp tick,
    // and where the device offers VK_EXT_calibrated_timestamps (else the KHR one) its name, the
    // time domains it calibrates ("device", "clock_monotonic", ...) and, once a context is made,
    // the deviation of one device/host calibration (ns; negative: none made). No extension:
    // `calibration` empty, the GPU times rest on timestampPeriod alone.
    double timestamp_period_ns = 0;
    std::string calibration;
    std::vector<std::string> time_domains;
    double calibration_deviation_ns = -1;
};

// Every Vulkan device the loader reports. Throws EnvironmentError when there is none.
std::vector<DeviceInfo> list_devices();

struct ContextOptions {
    // Device index or a case-insensitive part of its name; empty: $PENUMBRA_VK_DEVICE, else
    // lavapipe when present, else device 0.
    std::string device;
    // Khronos validation layer; also on when $PENUMBRA_VK_VALIDATION=1.
    bool validation = false;
};

class VulkanContext {
  public:
    explicit VulkanContext(const ContextOptions& options = {});
    ~VulkanContext();
    VulkanContext(const VulkanContext&) = delete;
    VulkanContext& operator=(const VulkanContext&) = delete;

    VkDevice device() const { return device_; }
    VkPhysicalDevice physical() const { return physical_; }
    VkQueue queue() const { return queue_; }
    std::uint32_t queue_family() const { return queue_family_; }
    const DeviceInfo& info() const { return info_; }
    const VkPhysicalDeviceLimits& limits() const { return limits_; }
    bool validation_enabled() const { return validation_; }
    // shaderFloat64 is on (the device offers it): the GPU scorer needs it.
    bool shader_float64() const { return shader_float64_; }
    // Validation messages (errors and warnings) since the context was made.
    const std::vector<std::string>& validation_messages() const { return messages_; }

    std::uint32_t memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags wanted) const;
    bool has_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags wanted) const;
    bool supports_linear_depth_compare(VkFormat format) const;
    bool supports_depth_attachment(VkFormat format) const;
    // Every bit of `features` among the format's optimal-tiling features.
    bool supports_format_features(VkFormat format, VkFormatFeatureFlags features) const;
    // shaderStorageImageWriteWithoutFormat is on (the device offers it): the moment families'
    // passes write one shader into R32F, RG32F, RGBA32F or RGBA16 images.
    bool storage_write_without_format() const { return storage_write_without_format_; }

    // Records with `record` into a one-time command buffer, submits and waits.
    void submit_and_wait(const std::function<void(VkCommandBuffer)>& record) const;

    // vkAllocateMemory calls made through this context so far (Vulkan guarantees only
    // maxMemoryAllocationCount, 4096, live at once).
    std::uint64_t memory_allocations() const { return allocations_; }
    // Every vkAllocateMemory of the raster path goes through here.
    UniqueMemory allocate_memory(VkDeviceSize bytes, std::uint32_t memory_type) const;

  private:
    void release();    // destroys what the constructor made; safe on a half-made context
    void calibrate();  // DeviceInfo::calibration_deviation_ns
    static VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                     VkDebugUtilsMessageTypeFlagsEXT,
                                                     const VkDebugUtilsMessengerCallbackDataEXT*, void*);

    VkInstance instance_ = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    VkPhysicalDevice physical_ = VK_NULL_HANDLE;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    std::uint32_t queue_family_ = 0;
    DeviceInfo info_;
    VkPhysicalDeviceLimits limits_{};
    VkPhysicalDeviceMemoryProperties memory_{};
    bool validation_ = false;
    bool shader_float64_ = false;
    bool storage_write_without_format_ = false;
    std::vector<std::string> messages_;
    UniqueCommandPool command_pool_;
    mutable std::atomic<std::uint64_t> allocations_{0};
};

// A buffer with its own memory, persistently mapped when host-visible.
struct GpuBuffer {
    UniqueBuffer buffer;
    UniqueMemory memory;
    void* mapped = nullptr;
    VkDeviceSize size = 0;
};
GpuBuffer create_buffer(const VulkanContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage, bool host_visible);

// An image with its own memory and one view over all layers (a 2D-array view when `array`).
struct GpuImage {
    UniqueImage image;
    UniqueMemory memory;
    UniqueImageView view;
    VkFormat format = VK_FORMAT_UNDEFINED;
    std::uint32_t width = 0, height = 0, layers = 1;
    std::uint32_t levels = 1;  // mip levels; `view` covers them all
};
GpuImage create_image(const VulkanContext& ctx, VkFormat format, std::uint32_t width, std::uint32_t height,
                      std::uint32_t layers, VkImageUsageFlags usage, VkImageAspectFlags aspect, bool array);
// Sub-allocation: the buffers and images declared with `add` share one vkAllocateMemory per
// memory type (blocks of up to kBlockBytes; a larger resource has a block of its own), bound
// at offsets aligned for both kinds, when `commit` runs. Declared resources must stay where
// they are until then; the arena owns the memory and must outlive them.
class MemoryArena {
  public:
    static constexpr VkDeviceSize kBlockBytes = VkDeviceSize{256} << 20;
    MemoryArena() = default;
    explicit MemoryArena(const VulkanContext& ctx) : ctx_(&ctx) {}
    // As create_buffer, unbound until commit (`mapped` is set then).
    void add(GpuBuffer& buffer, VkDeviceSize size, VkBufferUsageFlags usage, bool host_visible);
    // As create_image, unbound and without its view until commit; `levels` mip levels.
    void add(GpuImage& image, VkFormat format, std::uint32_t width, std::uint32_t height, std::uint32_t layers,
             VkImageUsageFlags usage, VkImageAspectFlags aspect, bool array, std::uint32_t levels = 1);
    void commit();

  private:
    struct Pending {
        GpuBuffer* buffer = nullptr;
        GpuImage* image = nullptr;
        VkImageAspectFlags aspect = 0;
        bool array = false;
        VkMemoryRequirements req{};
        std::uint32_t memory_type = 0;
        bool host_visible = false;
    };
    const VulkanContext* ctx_ = nullptr;
    std::vector<Pending> pending_;
    std::vector<UniqueMemory> blocks_;
};

// A view of one layer, for rendering into it.
UniqueImageView create_layer_view(const VulkanContext& ctx, const GpuImage& image, std::uint32_t layer,
                                  VkImageAspectFlags aspect);
// A 2D-array view of every layer of one mip level (a storage image's view has one level).
UniqueImageView create_level_view(const VulkanContext& ctx, const GpuImage& image, std::uint32_t level,
                                  VkImageAspectFlags aspect);

}  // namespace penumbra::raster
