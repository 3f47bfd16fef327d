#include "raster/vulkan_context.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <thread>

#include "common/errors.h"

namespace penumbra::raster {

const char* vk_result_name(VkResult result) {
    switch (result) {
#define PENUMBRA_VK_NAME(r) \
    case r: return #r;
        PENUMBRA_VK_NAME(VK_SUCCESS)
        PENUMBRA_VK_NAME(VK_NOT_READY)
        PENUMBRA_VK_NAME(VK_TIMEOUT)
        PENUMBRA_VK_NAME(VK_INCOMPLETE)
        PENUMBRA_VK_NAME(VK_ERROR_OUT_OF_HOST_MEMORY)
        PENUMBRA_VK_NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        PENUMBRA_VK_NAME(VK_ERROR_INITIALIZATION_FAILED)
        PENUMBRA_VK_NAME(VK_ERROR_DEVICE_LOST)
        PENUMBRA_VK_NAME(VK_ERROR_MEMORY_MAP_FAILED)
        PENUMBRA_VK_NAME(VK_ERROR_LAYER_NOT_PRESENT)
        PENUMBRA_VK_NAME(VK_ERROR_EXTENSION_NOT_PRESENT)
        PENUMBRA_VK_NAME(VK_ERROR_FEATURE_NOT_PRESENT)
        PENUMBRA_VK_NAME(VK_ERROR_INCOMPATIBLE_DRIVER)
        PENUMBRA_VK_NAME(VK_ERROR_TOO_MANY_OBJECTS)
        PENUMBRA_VK_NAME(VK_ERROR_FORMAT_NOT_SUPPORTED)
        PENUMBRA_VK_NAME(VK_ERROR_FRAGMENTED_POOL)
        PENUMBRA_VK_NAME(VK_ERROR_OUT_OF_POOL_MEMORY)
        PENUMBRA_VK_NAME(VK_ERROR_UNKNOWN)
#undef PENUMBRA_VK_NAME
        default: return "VkResult(unknown)";
    }
}

void vk_fail(VkResult result, const char* call, const char* file, int line) {
    std::string hint;
    if (result == VK_ERROR_INCOMPATIBLE_DRIVER || result == VK_ERROR_INITIALIZATION_FAILED)
        hint = " (is a Vulkan driver installed? on Debian: apt-get install mesa-vulkan-drivers)";
    throw EnvironmentError(
        fmt::format("Vulkan: {} returned {} at {}:{}{}", call, vk_result_name(result), file, line, hint));
}

namespace {

const char* type_name(VkPhysicalDeviceType t) {
    switch (t) {
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated-gpu";
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete-gpu";
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual-gpu";
        case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
        default: return "other";
    }
}

std::string version_string(std::uint32_t v) {
    return fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v), VK_API_VERSION_PATCH(v));
}

bool env_flag(const char* name) {
    const char* v = std::getenv(name);
    return v && *v && std::strcmp(v, "0") != 0;
}

const char* kNoDevice =
    "no Vulkan device found; install a driver (on Debian: apt-get install mesa-vulkan-drivers for the "
    "lavapipe CPU device) or check VK_ICD_FILENAMES";

// The Vulkan loader loads the driver's library on vkCreateInstance and unloads it with the
// last instance. NVIDIA's driver (libnvidia-tls) takes static TLS on every load, which glibc
// never gives back on unload: after 29 load/unload cycles in one process (raster_tests on an
// H100, driver 580) the next load fails with "cannot allocate memory in static TLS block" and
// vkCreateInstance finds no driver. One bare instance kept for the life of the process keeps
// the driver loaded, so later instances reuse it. Failures here are left to the real instance.
void keep_driver_loaded() {
    struct Anchor {
        VkInstance instance = VK_NULL_HANDLE;
        Anchor() {
            VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
            app.pApplicationName = "penumbra";
            app.apiVersion = VK_API_VERSION_1_3;
            VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
            ci.pApplicationInfo = &app;
            if (vkCreateInstance(&ci, nullptr, &instance) != VK_SUCCESS) instance = VK_NULL_HANDLE;
        }
        ~Anchor() {
            if (instance) vkDestroyInstance(instance, nullptr);
        }
    };
    static const Anchor anchor;
}

VkInstance make_instance(bool validation, bool with_messenger) {
    keep_driver_loaded();
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "penumbra";
    app.apiVersion = VK_API_VERSION_1_3;
    VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ci.pApplicationInfo = &app;
    const char* layer = "VK_LAYER_KHRONOS_validation";
    const char* ext = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
    if (validation) {
        std::uint32_t n = 0;
        vkEnumerateInstanceLayerProperties(&n, nullptr);
        std::vector<VkLayerProperties> layers(n);
        vkEnumerateInstanceLayerProperties(&n, layers.data());
        bool found = std::any_of(layers.begin(), layers.end(),
                                 [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, layer) == 0; });
        if (!found)
            throw EnvironmentError(
                "Vulkan validation was requested but VK_LAYER_KHRONOS_validation is not installed "
                "(on Debian: apt-get install vulkan-validationlayers)");
        ci.enabledLayerCount = 1;
        ci.ppEnabledLayerNames = &layer;
    }
    if (with_messenger) {
        ci.enabledExtensionCount = 1;
        ci.ppEnabledExtensionNames = &ext;
    }
    VkInstance instance = VK_NULL_HANDLE;
    VkResult r = vkCreateInstance(&ci, nullptr, &instance);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER)
        throw EnvironmentError(
            fmt::format("{} (the loader found no driver it could load; VK_LOADER_DEBUG=error,driver "
                        "says why)",
                        kNoDevice));
    VK_CHECK(r);
    return instance;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance instance) {
    std::uint32_t n = 0;
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &n, nullptr));
    std::vector<VkPhysicalDevice> devices(n);
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &n, devices.data()));
    return devices;
}

// EXT first: the same entry points as KHR's, and the Khronos validation layer of Debian 12
// (1.3.239) warns of a device made with the KHR one, which it does not know.
constexpr const char* kCalibrationExtensions[] = {"VK_EXT_calibrated_timestamps", "VK_KHR_calibrated_timestamps"};

std::string time_domain_name(VkTimeDomainEXT d) {
    switch (d) {
        case VK_TIME_DOMAIN_DEVICE_EXT: return "device";
        case VK_TIME_DOMAIN_CLOCK_MONOTONIC_EXT: return "clock_monotonic";
        case VK_TIME_DOMAIN_CLOCK_MONOTONIC_RAW_EXT: return "clock_monotonic_raw";
        case VK_TIME_DOMAIN_QUERY_PERFORMANCE_COUNTER_EXT: return "query_performance_counter";
        default: return fmt::format("time_domain_{}", static_cast<int>(d));
    }
}

// The KHR and EXT calibration entry points share their signatures (the KHR ones are the EXT
// ones promoted); `suffix` picks the extension's.
std::string calibration_suffix(const std::string& extension) {
    return extension.find("_KHR_") != std::string::npos ? "KHR" : "EXT";
}

// The calibration extension the device offers and its time domains.
void describe_clocks(VkInstance instance, VkPhysicalDevice pd, DeviceInfo& info) {
    std::uint32_t n = 0;
    if (vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr) != VK_SUCCESS) return;
    std::vector<VkExtensionProperties> extensions(n);
    if (vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, extensions.data()) != VK_SUCCESS) return;
    for (const char* wanted : kCalibrationExtensions)
        for (const auto& e : extensions)
            if (info.calibration.empty() && std::string(e.extensionName) == wanted) info.calibration = wanted;
    if (info.calibration.empty()) return;
    const std::string fn = "vkGetPhysicalDeviceCalibrateableTimeDomains" + calibration_suffix(info.calibration);
    auto get = reinterpret_cast<PFN_vkGetPhysicalDeviceCalibrateableTimeDomainsEXT>(
        vkGetInstanceProcAddr(instance, fn.c_str()));
    std::uint32_t count = 0;
    if (!get || get(pd, &count, nullptr) != VK_SUCCESS) return;
    std::vector<VkTimeDomainEXT> domains(count);
    if (get(pd, &count, domains.data()) != VK_SUCCESS) return;
    domains.resize(count);
    for (VkTimeDomainEXT d : domains) info.time_domains.push_back(time_domain_name(d));
}

DeviceInfo describe(VkInstance instance, VkPhysicalDevice pd, std::uint32_t index) {
    VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props.pNext = &driver;
    vkGetPhysicalDeviceProperties2(pd, &props);
    DeviceInfo info;
    info.index = index;
    info.name = props.properties.deviceName;
    info.type = type_name(props.properties.deviceType);
    info.driver = fmt::format("{} {}", driver.driverName, driver.driverInfo);
    info.api_version = version_string(props.properties.apiVersion);
    info.lavapipe = driver.driverID == VK_DRIVER_ID_MESA_LLVMPIPE;
    info.timestamp_period_ns = props.properties.limits.timestampPeriod;
    describe_clocks(instance, pd, info);
    return info;
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

// Index, or name substring; empty picks lavapipe first so results match CI by default.
std::uint32_t choose_device(const std::vector<DeviceInfo>& infos, const std::string& wanted) {
    if (wanted.empty()) {
        for (const auto& d : infos)
            if (d.lavapipe) return d.index;
        return 0;
    }
    if (std::all_of(wanted.begin(), wanted.end(), [](unsigned char c) { return std::isdigit(c); })) {
        unsigned long i = std::strtoul(wanted.c_str(), nullptr, 10);
        if (i < infos.size()) return static_cast<std::uint32_t>(i);
    } else {
        for (const auto& d : infos)
            if (lower(d.name).find(lower(wanted)) != std::string::npos) return d.index;
    }
    std::string list;
    for (const auto& d : infos) list += fmt::format("{}{}: {}", list.empty() ? "" : ", ", d.index, d.name);
    throw InputError(fmt::format("--device {}: no such Vulkan device (have: {})", wanted, list));
}

}  // namespace

std::vector<DeviceInfo> list_devices() {
    VkInstance instance = make_instance(false, false);
    std::vector<DeviceInfo> infos;
    try {
        auto devices = physical_devices(instance);
        for (std::uint32_t i = 0; i < devices.size(); ++i) infos.push_back(describe(instance, devices[i], i));
    } catch (...) {
        vkDestroyInstance(instance, nullptr);
        throw;
    }
    vkDestroyInstance(instance, nullptr);
    if (infos.empty()) throw EnvironmentError(kNoDevice);
    return infos;
}

VKAPI_ATTR VkBool32 VKAPI_CALL VulkanContext::on_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                         VkDebugUtilsMessageTypeFlagsEXT,
                                                         const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    auto* self = static_cast<VulkanContext*>(user);
    const char* level = severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? "error" : "warning";
    std::string msg = fmt::format("vulkan validation {}: {}", level, data->pMessage ? data->pMessage : "");
    fmt::print(stderr, "{}\n", msg);
    self->messages_.push_back(std::move(msg));
    return VK_FALSE;
}

VulkanContext::VulkanContext(const ContextOptions& options) {
    validation_ = options.validation || env_flag("PENUMBRA_VK_VALIDATION");
    instance_ = make_instance(validation_, validation_);
    try {
        if (validation_) {
            auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
                vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
            VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
            mi.messageSeverity =
                VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
            mi.messageType =
                VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT;
            mi.pfnUserCallback = &VulkanContext::on_message;
            mi.pUserData = this;
            if (!create) throw EnvironmentError("Vulkan: vkCreateDebugUtilsMessengerEXT is missing");
            VK_CHECK(create(instance_, &mi, nullptr, &messenger_));
        }
        auto devices = physical_devices(instance_);
        if (devices.empty()) throw EnvironmentError(kNoDevice);
        std::vector<DeviceInfo> infos;
        for (std::uint32_t i = 0; i < devices.size(); ++i) infos.push_back(describe(instance_, devices[i], i));
        std::string wanted = options.device;
        if (wanted.empty() && std::getenv("PENUMBRA_VK_DEVICE")) wanted = std::getenv("PENUMBRA_VK_DEVICE");
        std::uint32_t chosen = choose_device(infos, wanted);
        physical_ = devices[chosen];
        info_ = infos[chosen];

        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(physical_, &props);
        if (props.apiVersion < VK_API_VERSION_1_3)
            throw EnvironmentError(
                fmt::format("Vulkan device '{}' offers Vulkan {}; penumbra needs 1.3", info_.name, info_.api_version));
        limits_ = props.limits;
        vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);

        std::uint32_t nq = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(physical_, &nq, nullptr);
        std::vector<VkQueueFamilyProperties> families(nq);
        vkGetPhysicalDeviceQueueFamilyProperties(physical_, &nq, families.data());
        bool found = false;
        for (std::uint32_t i = 0; i < nq && !found; ++i) {
            VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
            if ((families[i].queueFlags & need) == need && families[i].timestampValidBits > 0) {
                queue_family_ = i;
                found = true;
            }
        }
        if (!found)
            throw EnvironmentError(
                fmt::format("Vulkan device '{}' has no graphics+compute queue with timestamps", info_.name));

        VkPhysicalDeviceFeatures supported;
        vkGetPhysicalDeviceFeatures(physical_, &supported);
        if (!supported.geometryShader || !supported.depthClamp || !supported.depthBiasClamp)
            throw EnvironmentError(fmt::format(
                "Vulkan device '{}' lacks a feature penumbra needs (geometryShader for gl_PrimitiveID, depthClamp, "
                "depthBiasClamp)",
                info_.name));
        VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
        f13.dynamicRendering = VK_TRUE;
        f13.synchronization2 = VK_TRUE;
        VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
        features.pNext = &f13;
        features.features.geometryShader = VK_TRUE;
        features.features.depthClamp = VK_TRUE;
        features.features.depthBiasClamp = VK_TRUE;
        // Optional: the GPU scorer sums errors in double, in the CPU's order (metrics/gpu_classification.h).
        features.features.shaderFloat64 = supported.shaderFloat64;
        shader_float64_ = supported.shaderFloat64 == VK_TRUE;
        // Optional: the moment families' passes need it (raster/depth_map.cpp refuses them without).
        features.features.shaderStorageImageWriteWithoutFormat = supported.shaderStorageImageWriteWithoutFormat;
        storage_write_without_format_ = supported.shaderStorageImageWriteWithoutFormat == VK_TRUE;

        float priority = 1.0f;
        VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
        qi.queueFamilyIndex = queue_family_;
        qi.queueCount = 1;
        qi.pQueuePriorities = &priority;
        VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
        di.pNext = &features;
        di.queueCreateInfoCount = 1;
        di.pQueueCreateInfos = &qi;
        const char* calibration = info_.calibration.c_str();
        if (!info_.calibration.empty()) {
            di.enabledExtensionCount = 1;
            di.ppEnabledExtensionNames = &calibration;
        }
        VK_CHECK(vkCreateDevice(physical_, &di, nullptr, &device_));
        vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
        calibrate();

        VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
        pi.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
        pi.queueFamilyIndex = queue_family_;
        VkCommandPool pool;
        VK_CHECK(vkCreateCommandPool(device_, &pi, nullptr, &pool));
        command_pool_ = UniqueCommandPool(device_, pool);
    } catch (...) {
        release();
        throw;
    }
}

// One calibration of the device's timestamps against CLOCK_MONOTONIC, where both domains are
// offered: its deviation says how closely GPU and host times can be lined up.
void VulkanContext::calibrate() {
    auto has = [&](const char* d) {
        return std::find(info_.time_domains.begin(), info_.time_domains.end(), d) != info_.time_domains.end();
    };
    if (info_.calibration.empty() || !has("device") || !has("clock_monotonic")) return;
    const std::string fn = "vkGetCalibratedTimestamps" + calibration_suffix(info_.calibration);
    auto get = reinterpret_cast<PFN_vkGetCalibratedTimestampsEXT>(vkGetDeviceProcAddr(device_, fn.c_str()));
    if (!get) return;
    std::array<VkCalibratedTimestampInfoEXT, 2> which{};
    which[0] = {VK_STRUCTURE_TYPE_CALIBRATED_TIMESTAMP_INFO_EXT, nullptr, VK_TIME_DOMAIN_DEVICE_EXT};
    which[1] = {VK_STRUCTURE_TYPE_CALIBRATED_TIMESTAMP_INFO_EXT, nullptr, VK_TIME_DOMAIN_CLOCK_MONOTONIC_EXT};
    std::array<std::uint64_t, 2> stamps{};
    std::uint64_t deviation = 0;
    if (get(device_, 2, which.data(), stamps.data(), &deviation) == VK_SUCCESS)
        info_.calibration_deviation_ns = static_cast<double>(deviation);
}

VulkanContext::~VulkanContext() {
    release();
}

void VulkanContext::release() {
    command_pool_.reset();
    if (device_) vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
    if (messenger_) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
        if (destroy) destroy(instance_, messenger_, nullptr);
        messenger_ = VK_NULL_HANDLE;
    }
    if (instance_) vkDestroyInstance(instance_, nullptr);
    instance_ = VK_NULL_HANDLE;
}

bool VulkanContext::has_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags wanted) const {
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
        if ((type_bits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & wanted) == wanted) return true;
    return false;
}

std::uint32_t VulkanContext::memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags wanted) const {
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i)
        if ((type_bits & (1u << i)) && (memory_.memoryTypes[i].propertyFlags & wanted) == wanted) return i;
    throw EnvironmentError(fmt::format("Vulkan device '{}' has no memory type with flags {:#x}", info_.name, wanted));
}

bool VulkanContext::supports_linear_depth_compare(VkFormat format) const {
    VkFormatProperties p;
    vkGetPhysicalDeviceFormatProperties(physical_, format, &p);
    return (p.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) != 0;
}

bool VulkanContext::supports_depth_attachment(VkFormat format) const {
    VkFormatProperties p;
    vkGetPhysicalDeviceFormatProperties(physical_, format, &p);
    VkFormatFeatureFlags need = VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT;
    return (p.optimalTilingFeatures & need) == need;
}

bool VulkanContext::supports_format_features(VkFormat format, VkFormatFeatureFlags features) const {
    VkFormatProperties p;
    vkGetPhysicalDeviceFormatProperties(physical_, format, &p);
    return (p.optimalTilingFeatures & features) == features;
}

void VulkanContext::submit_and_wait(const std::function<void(VkCommandBuffer)>& record) const {
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = command_pool_.get();
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    VkCommandBuffer cmd;
    VK_CHECK(vkAllocateCommandBuffers(device_, &ai, &cmd));
    struct Free {
        VkDevice d;
        VkCommandPool p;
        VkCommandBuffer c;
        ~Free() { vkFreeCommandBuffers(d, p, 1, &c); }
    } free_on_exit{device_, command_pool_.get(), cmd};

    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(cmd, &bi));
    record(cmd);
    VK_CHECK(vkEndCommandBuffer(cmd));

    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence_handle;
    VK_CHECK(vkCreateFence(device_, &fi, nullptr, &fence_handle));
    UniqueFence fence(device_, fence_handle);
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    VK_CHECK(vkQueueSubmit(queue_, 1, &si, fence.get()));
    // A GPU's short passes (a sweep's renders take a few ms) are answered sooner by polling the
    // fence than by a blocking wait, which wakes up late; past kSpinWait it blocks. A CPU device
    // blocks at once: its work runs on the cores a poll would take. $PENUMBRA_FENCE_WAIT=block or
    // spin overrides (docs/raster.md, "Timings").
    static const char* const mode = std::getenv("PENUMBRA_FENCE_WAIT");
    const bool spin = mode ? std::string_view(mode) == "spin" : info_.type != "cpu";
    if (spin) {
        constexpr auto kSpinWait = std::chrono::milliseconds(50);
        const auto until = std::chrono::steady_clock::now() + kSpinWait;
        while (std::chrono::steady_clock::now() < until) {
            const VkResult r = vkGetFenceStatus(device_, fence.get());
            if (r == VK_SUCCESS) return;
            if (r != VK_NOT_READY) VK_CHECK(r);
            std::this_thread::yield();
        }
    }
    VK_CHECK(vkWaitForFences(device_, 1, fence.ptr(), VK_TRUE, UINT64_MAX));
}

UniqueMemory VulkanContext::allocate_memory(VkDeviceSize bytes, std::uint32_t memory_type) const {
    VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    ai.allocationSize = bytes;
    ai.memoryTypeIndex = memory_type;
    VkDeviceMemory mem;
    VK_CHECK(vkAllocateMemory(device_, &ai, nullptr, &mem));
    ++allocations_;
    return UniqueMemory(device_, mem);
}

namespace {
UniqueMemory allocate(const VulkanContext& ctx, const VkMemoryRequirements& req, VkMemoryPropertyFlags flags) {
    return ctx.allocate_memory(req.size, ctx.memory_type(req.memoryTypeBits, flags));
}

// Host-visible buffers are read back (lookups, the camera pass): cached memory where the device
// has it, since reading uncached, write-combined memory is many times slower.
VkMemoryPropertyFlags buffer_memory_flags(const VulkanContext& ctx, std::uint32_t type_bits, bool host_visible) {
    if (!host_visible) return VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
    VkMemoryPropertyFlags flags = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    if (ctx.has_memory_type(type_bits, flags | VK_MEMORY_PROPERTY_HOST_CACHED_BIT))
        flags |= VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
    return flags;
}

UniqueBuffer make_buffer(const VulkanContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage) {
    VkBufferCreateInfo ci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    ci.size = size;
    ci.usage = usage;
    ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VkBuffer buf;
    VK_CHECK(vkCreateBuffer(ctx.device(), &ci, nullptr, &buf));
    return UniqueBuffer(ctx.device(), buf);
}

UniqueImage make_image(const VulkanContext& ctx, VkFormat format, std::uint32_t width, std::uint32_t height,
                       std::uint32_t layers, VkImageUsageFlags usage, std::uint32_t levels = 1) {
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = format;
    ci.extent = {width, height, 1};
    ci.mipLevels = levels;
    ci.arrayLayers = layers;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.tiling = VK_IMAGE_TILING_OPTIMAL;
    ci.usage = usage;
    ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImage image;
    VK_CHECK(vkCreateImage(ctx.device(), &ci, nullptr, &image));
    return UniqueImage(ctx.device(), image);
}

UniqueImageView create_view(const VulkanContext& ctx, VkImage image, VkFormat format, VkImageViewType type,
                            const VkImageSubresourceRange& range) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = image;
    vi.viewType = type;
    vi.format = format;
    vi.subresourceRange = range;
    VkImageView view;
    VK_CHECK(vkCreateImageView(ctx.device(), &vi, nullptr, &view));
    return UniqueImageView(ctx.device(), view);
}
}  // namespace

GpuBuffer create_buffer(const VulkanContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage, bool host_visible) {
    GpuBuffer b;
    b.size = std::max<VkDeviceSize>(size, 4);
    b.buffer = make_buffer(ctx, b.size, usage);
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(ctx.device(), b.buffer.get(), &req);
    b.memory = allocate(ctx, req, buffer_memory_flags(ctx, req.memoryTypeBits, host_visible));
    VK_CHECK(vkBindBufferMemory(ctx.device(), b.buffer.get(), b.memory.get(), 0));
    if (host_visible) VK_CHECK(vkMapMemory(ctx.device(), b.memory.get(), 0, VK_WHOLE_SIZE, 0, &b.mapped));
    return b;
}

GpuImage create_image(const VulkanContext& ctx, VkFormat format, std::uint32_t width, std::uint32_t height,
                      std::uint32_t layers, VkImageUsageFlags usage, VkImageAspectFlags aspect, bool array) {
    GpuImage img;
    img.format = format;
    img.width = width;
    img.height = height;
    img.layers = layers;
    img.image = make_image(ctx, format, width, height, layers, usage);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(ctx.device(), img.image.get(), &req);
    img.memory = allocate(ctx, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    VK_CHECK(vkBindImageMemory(ctx.device(), img.image.get(), img.memory.get(), 0));
    img.view = create_view(ctx, img.image.get(), format, array ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D,
                           {aspect, 0, 1, 0, layers});
    return img;
}

void MemoryArena::add(GpuBuffer& buffer, VkDeviceSize size, VkBufferUsageFlags usage, bool host_visible) {
    buffer.size = std::max<VkDeviceSize>(size, 4);
    buffer.buffer = make_buffer(*ctx_, buffer.size, usage);
    Pending p;
    p.buffer = &buffer;
    p.host_visible = host_visible;
    vkGetBufferMemoryRequirements(ctx_->device(), buffer.buffer.get(), &p.req);
    p.memory_type =
        ctx_->memory_type(p.req.memoryTypeBits, buffer_memory_flags(*ctx_, p.req.memoryTypeBits, host_visible));
    pending_.push_back(p);
}

void MemoryArena::add(GpuImage& image, VkFormat format, std::uint32_t width, std::uint32_t height, std::uint32_t layers,
                      VkImageUsageFlags usage, VkImageAspectFlags aspect, bool array, std::uint32_t levels) {
    image.format = format;
    image.width = width;
    image.height = height;
    image.layers = layers;
    image.levels = levels;
    image.image = make_image(*ctx_, format, width, height, layers, usage, levels);
    Pending p;
    p.image = &image;
    p.aspect = aspect;
    p.array = array;
    vkGetImageMemoryRequirements(ctx_->device(), image.image.get(), &p.req);
    p.memory_type = ctx_->memory_type(p.req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    pending_.push_back(p);
}

void MemoryArena::commit() {
    // Buffers and optimal images may share a block: every offset is aligned to
    // bufferImageGranularity as well as to the resource's own alignment.
    const VkDeviceSize granularity = std::max<VkDeviceSize>(ctx_->limits().bufferImageGranularity, 1);
    auto align = [](VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; };
    struct Block {
        std::uint32_t memory_type;
        VkDeviceSize size = 0;
        bool host_visible = false;
        std::vector<std::pair<std::size_t, VkDeviceSize>> placed;  // pending index, offset
    };
    std::vector<Block> blocks;
    std::vector<std::size_t> open(VK_MAX_MEMORY_TYPES, SIZE_MAX);  // per memory type: the block being filled
    for (std::size_t i = 0; i < pending_.size(); ++i) {
        const Pending& p = pending_[i];
        std::size_t& b = open[p.memory_type];
        const VkDeviceSize a = std::max(p.req.alignment, granularity);
        if (b == SIZE_MAX || (blocks[b].size > 0 && align(blocks[b].size, a) + p.req.size > kBlockBytes)) {
            b = blocks.size();
            blocks.push_back({p.memory_type});
        }
        Block& block = blocks[b];
        const VkDeviceSize offset = align(block.size, a);
        block.placed.emplace_back(i, offset);
        block.size = offset + p.req.size;
        block.host_visible = block.host_visible || p.host_visible;
    }
    for (Block& block : blocks) {
        UniqueMemory memory = ctx_->allocate_memory(block.size, block.memory_type);
        char* mapped = nullptr;
        if (block.host_visible) {
            void* m = nullptr;
            VK_CHECK(vkMapMemory(ctx_->device(), memory.get(), 0, VK_WHOLE_SIZE, 0, &m));
            mapped = static_cast<char*>(m);
        }
        for (const auto& [i, offset] : block.placed) {
            const Pending& p = pending_[i];
            if (p.buffer) {
                VK_CHECK(vkBindBufferMemory(ctx_->device(), p.buffer->buffer.get(), memory.get(), offset));
                if (p.host_visible) p.buffer->mapped = mapped + offset;
            } else {
                GpuImage& img = *p.image;
                VK_CHECK(vkBindImageMemory(ctx_->device(), img.image.get(), memory.get(), offset));
                img.view = create_view(*ctx_, img.image.get(), img.format,
                                       p.array ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D,
                                       {p.aspect, 0, img.levels, 0, img.layers});
            }
        }
        blocks_.push_back(std::move(memory));
    }
    pending_.clear();
}

UniqueImageView create_layer_view(const VulkanContext& ctx, const GpuImage& image, std::uint32_t layer,
                                  VkImageAspectFlags aspect) {
    return create_view(ctx, image.image.get(), image.format, VK_IMAGE_VIEW_TYPE_2D, {aspect, 0, 1, layer, 1});
}

UniqueImageView create_level_view(const VulkanContext& ctx, const GpuImage& image, std::uint32_t level,
                                  VkImageAspectFlags aspect) {
    return create_view(ctx, image.image.get(), image.format, VK_IMAGE_VIEW_TYPE_2D_ARRAY,
                       {aspect, level, 1, 0, image.layers});
}

}  // namespace penumbra::raster
