// The oracle cache's size cap: least recently used entries go after a store, a hit counts as a
// use, only the cache's own files are ever removed (docs/oracle.md, "The cache").
#include "oracle/oracle_cache.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <limits>

#include "common/errors.h"
#include "tests/test_support.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

OracleFrame small_frame() {
    OracleFrame f;
    f.width = 8;
    f.height = 8;
    const std::size_t n = f.pixel_count();
    f.A.assign(n, 1.0f);
    f.prim.assign(n, 0u);
    OracleLightImage l;
    for (auto* c : {&l.V, &l.E, &l.U, &l.lightable, &l.occluder_m, &l.boundary_m}) c->assign(n, 0.5f);
    f.lights.push_back(l);
    return f;
}

// 32 hex digits, as oracle_cache_key gives.
std::string key(int i) {
    return fmt::format("{:032x}", i);
}

// Entries used `minutes_ago`, so that their order does not hang on the clock's resolution.
void used(const OracleCache& cache, int i, int minutes_ago) {
    fs::last_write_time(cache.entry(key(i)), fs::file_time_type::clock::now() - std::chrono::minutes(minutes_ago));
}

std::uint64_t entry_bytes(const fs::path& dir) {
    OracleCache probe(dir / "probe", 0);
    EXPECT_FALSE(probe.store(key(0), small_frame(), {}));
    return probe.entries().at(0).bytes;
}

TEST(OracleCache, FillingPastTheCapRemovesTheLeastRecentlyUsed) {
    test::TempDir tmp;
    const std::uint64_t bytes = entry_bytes(tmp.path());
    const OracleCache cache(tmp.path() / "cache", 3 * bytes);  // room for three entries
    for (int i = 1; i <= 3; ++i) {
        ASSERT_FALSE(cache.store(key(i), small_frame(), {}));
        used(cache, i, 10 - i);  // 1 the oldest
    }
    ASSERT_EQ(cache.entries().size(), 3u);
    ASSERT_FALSE(cache.store(key(4), small_frame(), {}));
    const auto entries = cache.entries();
    ASSERT_EQ(entries.size(), 3u);
    EXPECT_FALSE(fs::exists(cache.entry(key(1)))) << "the oldest entry stays past the cap";
    for (int i = 2; i <= 4; ++i) EXPECT_TRUE(fs::exists(cache.entry(key(i)))) << i;
    EXPECT_EQ(entries.front().key, key(4)) << "most recently used first";
}

TEST(OracleCache, AHitCountsAsAUse) {
    test::TempDir tmp;
    const std::uint64_t bytes = entry_bytes(tmp.path());
    const OracleCache cache(tmp.path() / "cache", 2 * bytes);
    ASSERT_FALSE(cache.store(key(1), small_frame(), {}));
    used(cache, 1, 20);
    ASSERT_FALSE(cache.store(key(2), small_frame(), {}));
    used(cache, 2, 10);
    ASSERT_TRUE(cache.load(key(1)));  // 1 is now the most recently used
    ASSERT_FALSE(cache.store(key(3), small_frame(), {}));
    EXPECT_TRUE(fs::exists(cache.entry(key(1))));
    EXPECT_FALSE(fs::exists(cache.entry(key(2))));
    EXPECT_TRUE(fs::exists(cache.entry(key(3))));
}

TEST(OracleCache, PruneAndClearTouchOnlyTheCachesOwnFiles) {
    test::TempDir tmp;
    const fs::path dir = tmp.path() / "cache";
    const OracleCache cache(dir, 0);  // no cap
    for (int i = 1; i <= 3; ++i) ASSERT_FALSE(cache.store(key(i), small_frame(), {}));
    std::ofstream(dir / "notes.txt") << "mine";
    std::ofstream(dir / ("oracle-" + key(9) + ".bin")) << "an entry's name, not its magic";
    EXPECT_EQ(cache.entries().size(), 3u);
    EXPECT_TRUE(cache.prune().empty()) << "no cap: nothing to prune";
    const OracleCache capped(dir, 1);  // smaller than any entry
    EXPECT_EQ(capped.prune().size(), 3u);
    for (int i = 1; i <= 2; ++i) ASSERT_FALSE(cache.store(key(i), small_frame(), {}));
    EXPECT_EQ(cache.clear().size(), 2u);
    EXPECT_TRUE(cache.entries().empty());
    EXPECT_TRUE(fs::exists(dir / "notes.txt"));
    EXPECT_TRUE(fs::exists(dir / ("oracle-" + key(9) + ".bin")));
}

TEST(OracleCache, AnEntryLargerThanTheCapIsNotKeptAndSparesTheOthers) {
    test::TempDir tmp;
    const std::uint64_t bytes = entry_bytes(tmp.path());
    const OracleCache roomy(tmp.path() / "cache", 0);
    ASSERT_FALSE(roomy.store(key(1), small_frame(), {}));
    OracleFrame big = small_frame();
    big.width = 64;
    big.height = 64;
    for (auto* c : {&big.A}) c->assign(big.pixel_count(), 1.0f);
    big.prim.assign(big.pixel_count(), 0u);
    for (auto* c : {&big.lights[0].V, &big.lights[0].E, &big.lights[0].U, &big.lights[0].lightable,
                    &big.lights[0].occluder_m, &big.lights[0].boundary_m})
        c->assign(big.pixel_count(), 0.5f);
    const OracleCache cache(tmp.path() / "cache", 2 * bytes);
    const auto warning = cache.store(key(2), big, {});
    ASSERT_TRUE(warning);
    EXPECT_NE(warning->find("larger than the cache's cap"), std::string::npos) << *warning;
    EXPECT_FALSE(fs::exists(cache.entry(key(2))));
    EXPECT_TRUE(fs::exists(cache.entry(key(1))));
}

TEST(OracleCache, SizesTakeBinarySuffixes) {
    EXPECT_EQ(parse_cache_size("2G", "x"), 2ull << 30);
    EXPECT_EQ(parse_cache_size("512M", "x"), 512ull << 20);
    EXPECT_EQ(parse_cache_size("1.5K", "x"), 1536u);
    EXPECT_EQ(parse_cache_size("1000", "x"), 1000u);
    EXPECT_EQ(parse_cache_size("0", "x"), 0u);
    for (const char* bad : {"", "G", ".", "2X", "-1", "1..2", "2 G"})
        EXPECT_THROW(parse_cache_size(bad, "PENUMBRA_CACHE_MAX"), InputError) << bad;
}

// An entry the oracle could have written: 0/1 masks, V in [0, 1], prims below `triangles`.
OracleFrame valid_frame(std::size_t lights) {
    OracleFrame f;
    f.width = 4;
    f.height = 2;
    const std::size_t n = f.pixel_count();
    f.A.assign(n, 1.0f);
    f.prim.assign(n, 0u);
    for (std::size_t li = 0; li < lights; ++li) {
        OracleLightImage l;
        for (auto* c : {&l.V, &l.E, &l.U, &l.lightable, &l.occluder_m, &l.boundary_m}) c->assign(n, 0.0f);
        f.lights.push_back(l);
    }
    return f;
}

nlohmann::json info_of(std::size_t lights) {
    nlohmann::json l = nlohmann::json::array();
    for (std::size_t i = 0; i < lights; ++i) l.push_back({{"index", i}, {"type", "directional"}});
    return {{"lights", l}};
}

CacheRequest request_of(std::size_t lights) {
    return {4, 2, std::vector<std::string>(lights, "directional"), 1};
}

// #50: an entry with a valid checksum is still checked against what the run asks for.
TEST(OracleCache, AnEntryOfAnotherShapeIsAMissAndIsRemoved) {
    test::TempDir tmp;
    OracleCache cache(tmp.path() / "c", 0);
    ASSERT_FALSE(cache.store(key(1), valid_frame(1), info_of(1)));
    const CacheRequest one = request_of(1), two = request_of(2);
    std::string warning;
    EXPECT_TRUE(cache.load(key(1), &warning, &one));
    EXPECT_TRUE(warning.empty());
    EXPECT_FALSE(cache.load(key(1), &warning, &two));
    EXPECT_NE(warning.find("does not match"), std::string::npos) << warning;
    EXPECT_FALSE(fs::exists(cache.entry(key(1))));
}

TEST(OracleCache, NaNTruthIsRefused) {
    test::TempDir tmp;
    OracleCache cache(tmp.path() / "c", 0);
    OracleFrame f = valid_frame(1);
    f.lights[0].V[3] = std::numeric_limits<float>::quiet_NaN();
    ASSERT_FALSE(cache.store(key(2), f, info_of(1)));
    const CacheRequest one = request_of(1);
    std::string warning;
    EXPECT_FALSE(cache.load(key(2), &warning, &one));
    EXPECT_NE(warning.find("NaN"), std::string::npos) << warning;
}

TEST(OracleCache, AFileThatIsNotAnEntryIsLeftAndNotReplaced) {
    test::TempDir tmp;
    OracleCache cache(tmp.path() / "c", 0);
    fs::create_directories(cache.dir());
    { std::ofstream(cache.entry(key(3))) << "the user's"; }
    std::string warning;
    EXPECT_FALSE(cache.load(key(3), &warning));
    EXPECT_NE(warning.find("not one of penumbra's"), std::string::npos) << warning;
    EXPECT_TRUE(cache.store(key(3), valid_frame(1), info_of(1)));  // a warning: not cached
    std::ifstream in(cache.entry(key(3)));
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text, "the user's");
}

// Every triangle index a cached frame holds lies below the scene's count (the last one is
// count - 1): one at the count itself is a damaged entry.
TEST(OracleCache, ATriangleIndexAtTheScenesCountIsRefused) {
    test::TempDir tmp;
    OracleCache cache(tmp.path() / "c", 0);
    OracleFrame f = valid_frame(1);
    f.prim[5] = 1;  // the request's scene has 1 triangle: index 0 only
    ASSERT_FALSE(cache.store(key(4), f, info_of(1)));
    const CacheRequest one = request_of(1);
    std::string warning;
    EXPECT_FALSE(cache.load(key(4), &warning, &one));
    EXPECT_NE(warning.find("triangle index"), std::string::npos) << warning;
    f.prim[5] = 0;
    ASSERT_FALSE(cache.store(key(5), f, info_of(1)));
    EXPECT_TRUE(cache.load(key(5), &warning, &one));
}

// A cut entry is refused from its size alone, before anything is allocated for what its header
// claims (#50: an 86-byte entry made validate allocate 8 GiB).
TEST(OracleCache, ACutEntryIsRefusedByItsSizeBeforeItsPixelsAreRead) {
    test::TempDir tmp;
    OracleCache cache(tmp.path() / "c", 0);
    ASSERT_FALSE(cache.store(key(6), valid_frame(1), info_of(1)));
    const auto full = fs::file_size(cache.entry(key(6)));
    fs::resize_file(cache.entry(key(6)), full - 20);
    const CacheRequest one = request_of(1);
    std::string warning;
    EXPECT_FALSE(cache.load(key(6), &warning, &one));
    EXPECT_NE(warning.find(fmt::format("{} bytes where its header makes {}", full - 20, full)), std::string::npos)
        << warning;
}

// The clean-up of temporaries removes a store's own, of a process that is gone: one holding the
// entry's magic, and an empty one (a store killed before it wrote its header); a file of the
// same name holding anything else is the user's and stays.
TEST(OracleCache, ClearRemovesOnlyTheTemporariesOfDeadStores) {
    test::TempDir tmp;
    const OracleCache cache(tmp.path() / "c", 0);
    ASSERT_FALSE(cache.store(key(7), valid_frame(1), info_of(1)));
    const int dead = 4194000;  // no such process (beyond the default pid_max of 4194304 less a margin)
    auto temporary = [&](int i) {
        return cache.dir() / fmt::format(".oracle-{}.bin.tmp-{}-{:016x}", key(i), dead, 0xabcdef0123456789ull);
    };
    fs::copy_file(cache.entry(key(7)), temporary(1));
    { std::ofstream(temporary(2)); }
    { std::ofstream(temporary(3)) << "the user's own"; }
    cache.clear();
    EXPECT_FALSE(fs::exists(temporary(1))) << "a dead store's temporary";
    EXPECT_FALSE(fs::exists(temporary(2))) << "an empty temporary of a store killed before its header";
    EXPECT_TRUE(fs::exists(temporary(3))) << "a file without the entry's magic is not penumbra's";
}

TEST(OracleCache, SizesAreWholeBytesWithRealSuffixes) {
    EXPECT_EQ(parse_cache_size("1.5G", "x"), 3ull << 29);
    EXPECT_EQ(parse_cache_size("512MiB", "x"), 512ull << 20);
    EXPECT_EQ(parse_cache_size("0", "x"), 0u);
    for (const char* bad : {"0.5", "1iB", "1.5", "KB", "1KK", "2X"})
        EXPECT_THROW(parse_cache_size(bad, "x"), InputError) << bad;
}

}  // namespace
}  // namespace penumbra
