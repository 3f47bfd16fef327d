#include "image_io/oiio_plugin.h"

#include <dlfcn.h>
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <vector>

#include "common/errors.h"

namespace penumbra {
namespace fs = std::filesystem;

namespace {

// Where the plugin may be, first match wins: $PENUMBRA_OIIO_PLUGIN; beside the module that holds
// this code (an installed bin/penumbra finds ../lib/penumbra/, an installed libpenumbra.so finds
// penumbra/ next to it); the build tree; the install prefix.
std::vector<fs::path> candidates() {
    std::vector<fs::path> paths;
    if (const char* env = std::getenv("PENUMBRA_OIIO_PLUGIN"); env && *env) paths.emplace_back(env);
    // The module that holds this code: libpenumbra.so by its absolute path, or the program
    // itself, whose name dladdr reports as argv[0] (maybe relative, or a bare name found on
    // PATH), so /proc/self/exe is asked instead.
    std::vector<fs::path> dirs;
    std::error_code ec;
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&oiio_plugin), &info) && info.dli_fname &&
        fs::path(info.dli_fname).is_absolute()) {
        const fs::path self = fs::canonical(fs::path(info.dli_fname), ec);
        if (!ec) dirs.push_back(self.parent_path());
    }
    const fs::path exe = fs::canonical("/proc/self/exe", ec);
    if (!ec) dirs.push_back(exe.parent_path());
    for (const fs::path& dir : dirs) {
        paths.push_back(dir / "penumbra" / PENUMBRA_OIIO_PLUGIN_NAME);
        paths.push_back(dir / ".." / PENUMBRA_INSTALL_LIBDIR / "penumbra" / PENUMBRA_OIIO_PLUGIN_NAME);
    }
    paths.emplace_back(PENUMBRA_OIIO_PLUGIN_BUILD_PATH);
    paths.emplace_back(PENUMBRA_OIIO_PLUGIN_INSTALL_PATH);
    return paths;
}

OiioPlugin load() {
    std::string tried;
    for (const fs::path& p : candidates()) {
        std::error_code ec;
        if (!fs::is_regular_file(p, ec)) {
            tried += "\n  " + p.string() + " (absent)";
            continue;
        }
        // Never closed: OIIO keeps threads and caches for the life of the process.
        void* handle = dlopen(p.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            tried += fmt::format("\n  {} ({})", p.string(), dlerror());
            continue;
        }
        OiioPlugin plugin;
        plugin.read = reinterpret_cast<OiioReadFn>(dlsym(handle, "penumbra_oiio_read_sized"));
        plugin.read_alpha = reinterpret_cast<OiioReadAlphaFn>(dlsym(handle, "penumbra_oiio_read_alpha"));
        if (plugin.read && plugin.read_alpha) return plugin;
        tried += "\n  " + p.string() + " (no penumbra_oiio_read_sized or penumbra_oiio_read_alpha)";
    }
    throw EnvironmentError(
        fmt::format("cannot read images: OpenImageIO's plugin {} was not found or did not load; looked at:{}",
                    PENUMBRA_OIIO_PLUGIN_NAME, tried));
}

}  // namespace

const OiioPlugin& oiio_plugin() {
    // Not std::call_once's static: a failed load throws, and the next call tries again.
    static std::mutex mutex;
    static OiioPlugin plugin;
    std::lock_guard lock(mutex);
    if (!plugin.read) plugin = load();
    return plugin;
}

}  // namespace penumbra
