#include "oracle/oracle_cache.h"

#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "common/errors.h"
#include "common/output_files.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {

// Bump when the oracle's results change for the same input, so old entries stop matching
// (5: boundary_m from the occluder-edge walk and the search in the light's charts; 6: crowded
// cells' pixels search a k-d tree of the chart's points, not the 48 candidates and a walk).
constexpr const char* kOracleAlgorithm = "penumbra-oracle-6";
// 2: an XXH3-64 checksum of every byte after the magic ends the entry.
constexpr char kMagic[8] = {'P', 'N', 'B', 'O', 'R', 'C', 'L', '2'};
// Every version of the entry format starts with these: what `cache clear` recognises as ours.
constexpr std::string_view kMagicFamily = "PNBORCL";
// A temporary of a store that was killed is removed by a later store once it is this old, or
// at once when the process that wrote it is gone.
constexpr auto kStaleTemporary = std::chrono::hours(1);

class KeyBytes {
  public:
    template <class T>
    void add(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    template <class T>
    void add_all(const std::vector<T>& v) {
        add(v.size());
        if (!v.empty()) bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
    void add_text(std::string_view s) {
        add(s.size());
        bytes_.append(s);
    }
    const std::string& bytes() const { return bytes_; }

  private:
    std::string bytes_;
};

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// Every per-pixel channel of a cached frame, in file order.
template <class Frame, class Fn>
void for_each_channel(Frame& f, Fn&& fn) {
    fn(f.A);
    fn(f.prim);
    for (auto& l : f.lights) {
        fn(l.V);
        fn(l.E);
        fn(l.U);
        fn(l.lightable);
        fn(l.occluder_m);
        fn(l.boundary_m);
    }
}

// `.oracle-KEY.tmp-PID` of a store that no longer runs: its process is gone, or it is older
// than any store takes (the PID may have been reused since).
bool is_stale_temporary(const std::string& name, fs::file_time_type written, fs::file_time_type now) {
    const auto dash = name.rfind(".tmp-");
    if (dash == std::string::npos) return false;
    const std::string digits = name.substr(dash + 5);
    if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos)
        return false;
    const auto pid = static_cast<pid_t>(std::stol(digits));
    const bool gone = pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH;
    return gone || now - written > kStaleTemporary;
}

// `oracle-<32 lowercase hex>.bin`: the key, or empty when the name is not an entry's.
std::string key_of_entry_name(const std::string& name) {
    constexpr std::size_t kKeyDigits = 32;
    if (name.size() != 7 + kKeyDigits + 4 || !name.starts_with("oracle-") || !name.ends_with(".bin")) return {};
    const std::string key = name.substr(7, kKeyDigits);
    return key.find_first_not_of("0123456789abcdef") == std::string::npos ? key : std::string();
}

bool starts_with_magic(const fs::path& file) {
    File f(std::fopen(file.c_str(), "rb"));
    char head[7];
    return f && std::fread(head, 1, sizeof head, f.get()) == sizeof head &&
           std::string_view(head, sizeof head) == kMagicFamily;
}

void add_camera(KeyBytes& k, const Camera& c) {
    k.add(c.type);
    for (const glm::dvec3& v : {c.eye, c.forward, c.right, c.up}) k.add(v);
    for (double v : {c.yfov_rad, c.xmag, c.ymag, c.znear, c.zfar}) k.add(v);
}

void add_lights(KeyBytes& k, const std::vector<Light>& lights) {
    k.add(lights.size());
    for (const Light& l : lights) {
        k.add(l.type);
        for (const glm::dvec3& v : {l.position, l.direction, l.u, l.v, l.normal}) k.add(v);
        for (double v : {l.outer_cone_rad, l.radius}) k.add(v);
        // Only a sun with a size adds its diameter: a punctual light's key stays what it was.
        if (l.angular_diameter_rad > 0) k.add(l.angular_diameter_rad);
    }
}

void add_scene(KeyBytes& k, const Scene& scene) {
    k.add_all(scene.positions);
    k.add_all(scene.triangles);
    k.add_all(scene.double_sided);
}

}  // namespace

nlohmann::json scenario_fingerprint(const Scenario& s) {
    KeyBytes scene, camera, lights;
    add_scene(scene, s.scene);
    add_camera(camera, s.camera);
    if (s.camera_path) {  // a path is part of what was judged (absent: the fingerprint of before paths)
        camera.add(s.camera_path->frames);
        for (const CameraKey& k : s.camera_path->keys) {
            add_camera(camera, k.camera);
            camera.add(k.target);
        }
    }
    add_lights(lights, s.lights);
    return {{"scene", content_fingerprint(scene.bytes())},
            {"camera", content_fingerprint(camera.bytes())},
            {"lights", content_fingerprint(lights.bytes())}};
}

std::uint64_t parse_cache_size(const std::string& text, const std::string& what) {
    auto bad = [&]() -> std::uint64_t {
        throw InputError(
            fmt::format("{} {}: expected a size in bytes, or with a K, M, G or T suffix such as 512M or "
                        "2G (0: no cap)",
                        what, text));
    };
    std::size_t digits = 0;
    while (digits < text.size() && (std::isdigit(static_cast<unsigned char>(text[digits])) || text[digits] == '.'))
        ++digits;
    const std::string number = text.substr(0, digits);
    if (number.find_first_of("0123456789") == std::string::npos || number.find('.') != number.rfind('.')) return bad();
    const double value = std::strtod(number.c_str(), nullptr);
    std::string suffix = text.substr(digits);
    if (!suffix.empty() && (suffix.back() == 'B' || suffix.back() == 'b')) suffix.pop_back();
    if (!suffix.empty() && suffix.back() == 'i') suffix.pop_back();
    double scale = 1;
    if (suffix.size() > 1) return bad();
    if (suffix.size() == 1) {
        const auto k =
            std::string_view("KMGT").find(static_cast<char>(std::toupper(static_cast<unsigned char>(suffix[0]))));
        if (k == std::string_view::npos) return bad();
        scale = std::ldexp(1.0, 10 * static_cast<int>(k + 1));
    }
    const double bytes = value * scale;
    if (!std::isfinite(bytes) || bytes >= 1.8e19) return bad();
    return static_cast<std::uint64_t>(bytes);
}

std::string oracle_cache_key(const Scenario& s, const OracleSettings& settings) {
    KeyBytes k;
    k.add_text(kOracleAlgorithm);
    add_scene(k, s.scene);
    add_camera(k, s.camera);
    k.add(s.width);
    k.add(s.height);
    add_lights(k, s.lights);
    k.add(settings.boundary_bisection_steps);
    k.add(settings.seed);
    k.add(settings.area_target);
    k.add(settings.area_max_rays);
    k.add(settings.area_uniform_rays);
    return content_fingerprint(k.bytes());
}

OracleCache::OracleCache(fs::path dir, std::uint64_t max_bytes) : dir_(std::move(dir)), max_bytes_(max_bytes) {}

std::uint64_t OracleCache::default_max_bytes() {
    if (const char* m = std::getenv("PENUMBRA_CACHE_MAX"); m && *m) return parse_cache_size(m, "PENUMBRA_CACHE_MAX");
    return kDefaultCacheMaxBytes;
}

fs::path OracleCache::default_dir() {
    if (const char* d = std::getenv("PENUMBRA_CACHE_DIR"); d && *d) return d;
    if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return fs::path(d) / "penumbra";
    if (const char* d = std::getenv("HOME"); d && *d) return fs::path(d) / ".cache" / "penumbra";
    return {};
}

fs::path OracleCache::entry(const std::string& key) const {
    return dir_ / ("oracle-" + key + ".bin");
}

std::optional<CachedOracle> OracleCache::load(const std::string& key, std::string* damaged) const {
    if (dir_.empty()) return std::nullopt;
    const fs::path file = entry(key);
    File f(std::fopen(file.c_str(), "rb"));
    if (!f) return std::nullopt;
    XXH3_state_t* sum = XXH3_createState();
    XXH3_64bits_reset(sum);
    auto read = [&](void* dst, std::size_t n) {
        if (std::fread(dst, 1, n, f.get()) != n) return false;
        XXH3_64bits_update(sum, dst, n);
        return true;
    };
    char magic[8];
    char stored_key[32];
    std::int32_t size[2];
    std::uint32_t lights = 0;
    std::uint64_t info_len = 0;
    CachedOracle c;
    bool ok = std::fread(magic, 1, 8, f.get()) == 8 && std::memcmp(magic, kMagic, 8) == 0 && read(stored_key, 32) &&
              std::string_view(stored_key, 32) == key && read(size, sizeof size) && size[0] > 0 && size[1] > 0 &&
              size[0] <= kMaxImageSide && size[1] <= kMaxImageSide && read(&lights, 4) && lights < 4096 &&
              read(&c.frame.frame_origin, sizeof c.frame.frame_origin) && read(&info_len, 8) && info_len < (1u << 26);
    std::string info(ok ? info_len : 0, '\0');
    ok = ok && read(info.data(), info.size());
    if (ok) {
        c.frame.width = size[0];
        c.frame.height = size[1];
        c.frame.lights.resize(lights);
        const std::size_t n = c.frame.pixel_count();
        for_each_channel(c.frame, [&](auto& channel) {
            channel.resize(n);
            ok = ok && read(channel.data(), n * sizeof channel[0]);
        });
        const XXH64_hash_t expected = XXH3_64bits_digest(sum);
        XXH64_hash_t stored = 0;
        ok = ok && std::fread(&stored, 1, sizeof stored, f.get()) == sizeof stored && stored == expected &&
             std::fgetc(f.get()) == EOF;
        if (ok) {
            c.info = nlohmann::json::parse(info, nullptr, false);
            ok = !c.info.is_discarded();
        }
    }
    XXH3_freeState(sum);
    if (!ok) {
        f.reset();
        std::error_code ec;
        fs::remove(file, ec);
        if (damaged)
            *damaged = fmt::format(
                "{}: the cached oracle was damaged (its checksum or layout did not match) and was "
                "removed; traced again",
                file.string());
        return std::nullopt;
    }
    std::error_code ec;
    fs::last_write_time(file, fs::file_time_type::clock::now(), ec);  // recently used: kept longest
    return c;
}

std::optional<std::string> OracleCache::store(const std::string& key, const OracleFrame& frame,
                                              const nlohmann::json& info) const {
    if (dir_.empty()) return std::nullopt;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    const fs::path final_path = entry(key);
    const fs::path tmp = dir_ / fmt::format(".oracle-{}.tmp-{}", key, ::getpid());
    bool ok = false;
    const int tracked = track_for_interrupt(tmp, false);
    {
        File f(std::fopen(tmp.c_str(), "wb"));
        if (f) {
            XXH3_state_t* sum = XXH3_createState();
            XXH3_64bits_reset(sum);
            auto write = [&](const void* src, std::size_t n) {
                XXH3_64bits_update(sum, src, n);
                return std::fwrite(src, 1, n, f.get()) == n;
            };
            const std::int32_t size[2] = {frame.width, frame.height};
            const auto lights = static_cast<std::uint32_t>(frame.lights.size());
            // Paths in `info` may hold bytes that are not UTF-8 (a Latin-1 folder): replaced, not thrown.
            const std::string text = info.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
            const std::uint64_t info_len = text.size();
            ok = std::fwrite(kMagic, 1, 8, f.get()) == 8 && write(key.data(), 32) && write(size, sizeof size) &&
                 write(&lights, 4) && write(&frame.frame_origin, sizeof frame.frame_origin) && write(&info_len, 8) &&
                 write(text.data(), text.size());
            for_each_channel(frame, [&](const auto& channel) {
                ok = ok && channel.size() == frame.pixel_count() &&
                     write(channel.data(), channel.size() * sizeof channel[0]);
            });
            const XXH64_hash_t checksum = XXH3_64bits_digest(sum);
            XXH3_freeState(sum);
            ok = ok && std::fwrite(&checksum, 1, sizeof checksum, f.get()) == sizeof checksum;
            ok = std::fclose(f.release()) == 0 && ok;
        }
    }
    if (ok) fs::rename(tmp, final_path, ec);
    if (!ok || ec) fs::remove(tmp, ec);
    untrack_for_interrupt(tracked);
    if (!ok || ec)
        return fmt::format("{}: could not store the oracle in the cache; the next run traces again", dir_.string());
    sweep_temporaries();
    for (const CacheEntry& gone : prune())
        if (gone.key == key)
            return fmt::format(
                "{}: the oracle ({} bytes) is larger than the cache's cap ({} bytes) and was not kept; "
                "raise it with --cache-max or PENUMBRA_CACHE_MAX",
                dir_.string(), gone.bytes, max_bytes_);
    return std::nullopt;
}

std::vector<CacheEntry> OracleCache::entries() const {
    std::vector<CacheEntry> list;
    if (dir_.empty()) return list;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
        std::error_code fec;
        CacheEntry c;
        c.key = key_of_entry_name(e.path().filename().string());
        if (c.key.empty() || !e.is_regular_file(fec) || !starts_with_magic(e.path())) continue;
        c.file = e.path();
        c.bytes = e.file_size(fec);
        c.last_use = fs::last_write_time(e.path(), fec);
        if (!fec) list.push_back(std::move(c));
    }
    // Most recently used first; equal times by key, so that the order never depends on the folder's.
    std::sort(list.begin(), list.end(), [](const CacheEntry& a, const CacheEntry& b) {
        return a.last_use != b.last_use ? a.last_use > b.last_use : a.key < b.key;
    });
    return list;
}

std::vector<CacheEntry> OracleCache::prune() const {
    std::vector<CacheEntry> removed;
    if (max_bytes_ == 0) return removed;
    std::uint64_t kept = 0;
    bool full = false;
    for (CacheEntry& e : entries()) {
        // An entry larger than the whole cap never fits and goes by itself; otherwise, once one
        // entry does not fit, no older one is kept either: the least recently used go first.
        const bool too_big = e.bytes > max_bytes_;
        if (!too_big && !full && kept + e.bytes <= max_bytes_) {
            kept += e.bytes;
            continue;
        }
        full = full || !too_big;
        std::error_code ec;
        if (fs::remove(e.file, ec)) removed.push_back(std::move(e));
    }
    return removed;
}

std::vector<CacheEntry> OracleCache::clear() const {
    std::vector<CacheEntry> removed;
    for (CacheEntry& e : entries()) {
        std::error_code ec;
        if (fs::remove(e.file, ec)) removed.push_back(std::move(e));
    }
    sweep_temporaries();
    return removed;
}

void OracleCache::sweep_temporaries() const {
    std::error_code ec;
    const auto now = fs::file_time_type::clock::now();
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
        const std::string name = e.path().filename().string();
        std::error_code fec;
        if (name.starts_with(".oracle-") && is_stale_temporary(name, fs::last_write_time(e.path(), fec), now))
            fs::remove(e.path(), fec);
    }
}

}  // namespace penumbra
