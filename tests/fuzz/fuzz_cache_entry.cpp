// libFuzzer target: whatever bytes lie at an oracle cache entry's path (#50). Loading them is a
// hit only for a frame of the requested shape whose every value the oracle could have written;
// anything else is a miss with a warning, never a crash, a huge allocation or an exception.
#include <cmath>
#include <fstream>

#include "fuzz_support.h"
#include "oracle/oracle_cache.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    static const std::string key(32, 'a');
    const OracleCache cache(fuzz::scratch() / "cache", 0);
    std::filesystem::create_directories(cache.dir());
    {
        std::ofstream out(cache.entry(key), std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    }
    const CacheRequest request{4, 2, {"directional"}, 1};
    std::string warning;
    if (const auto hit = cache.load(key, &warning, &request)) {
        const OracleFrame& f = hit->frame;
        if (f.width != 4 || f.height != 2 || f.lights.size() != 1) std::abort();
        for (float v : f.lights[0].V)
            if (!(v >= 0.0f && v <= 1.0f)) std::abort();
    }
    return 0;
}
