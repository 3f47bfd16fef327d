// libFuzzer target: whatever bytes lie at an oracle cache entry's path (#50). Loading them is a
// hit only for a frame of the requested shape whose every value the oracle could have written;
// anything else is a miss with a warning, never a crash, a huge allocation or an exception.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>

#include "fuzz_support.h"
#include "oracle/oracle_cache.h"

// libFuzzer calls this before it reads the corpus: with $PENUMBRA_FUZZ_SEEDS set (run.sh sets
// it), a valid entry for the request below is stored there as a seed, so mutations start from
// bytes that pass every check (a checksum is out of a mutator's reach otherwise).
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    using namespace penumbra;
    const char* seeds = std::getenv("PENUMBRA_FUZZ_SEEDS");
    if (!seeds || !*seeds) return 0;
    const OracleCache cache(seeds, 0);
    std::filesystem::create_directories(cache.dir());
    OracleFrame f;
    f.width = 4;
    f.height = 2;
    const std::size_t n = f.pixel_count();
    f.A.assign(n, 1.0f);
    f.prim.assign(n, 0u);
    f.depth.assign(n, 2.0f);
    f.P.assign(n, glm::vec3(0.0f, 0.0f, -2.0f));
    f.N.assign(n, glm::vec3(0.0f, 1.0f, 0.0f));
    OracleLightImage l;
    l.V = {0, 0, 1, 1, 0.5f, 1, 0, 1};
    l.E.assign(n, 0.0f);
    l.U.assign(n, 0.0f);
    l.lightable.assign(n, 1.0f);
    l.occluder_m.assign(n, std::numeric_limits<float>::infinity());
    l.boundary_m.assign(n, 0.25f);
    f.lights = {l};
    (void)cache.store(std::string(32, 'a'), f, nlohmann::json::object());
    return 0;
}

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
