// Sanitizer builds of the tests only (tests/CMakeLists.txt): LeakSanitizer and the Vulkan driver.
//
// lavapipe keeps some of its compiler's state (LLVM's, per thread) for the life of the process:
// pipelines made on more than one thread (raster/depth_map.cpp makes a render's lookup pipelines
// side by side) leave ~46 KB that LeakSanitizer reports at exit. It can name, and so suppress, a
// leak's module only while it is mapped, and the Vulkan loader unloads the driver when the
// instance goes. So the driver is kept loaded (RTLD_NODELETE: the loader's dlclose then leaves it
// mapped), and its and LLVM's allocations are suppressed by module; leak checks stay on for
// penumbra's own code in every test binary that links this.
#include <dlfcn.h>

namespace {

const bool kDriverKeptLoaded = [] {
    // Absent (no lavapipe on this machine) is fine: the tests then use no such driver.
    return dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_NODELETE) != nullptr;
}();

}  // namespace

extern "C" const char* __lsan_default_suppressions() {
    return "leak:libvulkan_lvp.so\n"
           "leak:libLLVM-15.so\n";
}
