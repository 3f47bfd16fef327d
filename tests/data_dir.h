// The data/ folder the tests and benches read: $PENUMBRA_DATA_DIR when set (the self-contained
// folder scripts/gpu-bundle.sh makes for a machine without the source tree), else the source
// tree's. Header-only: the including target defines PENUMBRA_SOURCE_DIR.
#pragma once

#include <cstdlib>
#include <filesystem>

namespace penumbra::test {

inline std::filesystem::path data_dir() {
    if (const char* d = std::getenv("PENUMBRA_DATA_DIR"); d && *d) return d;
    return std::filesystem::path(PENUMBRA_SOURCE_DIR) / "data";
}

}  // namespace penumbra::test
