#include "oracle/oracle_cache.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/stat.h>
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
#include "common/json_reader.h"
#include "common/output_files.h"

namespace penumbra {

namespace fs = std::filesystem;

namespace {

// Bump when the oracle's results change for the same input, so old entries stop matching
// (5: boundary_m from the occluder-edge walk and the search in the light's charts; 6: crowded
// cells' pixels search a k-d tree of the chart's points, not the 48 candidates and a walk; 7:
// oracle.json's culled_by_node, which validate's facing diagnostics read from the entry).
constexpr const char* kOracleAlgorithm = "penumbra-oracle-7";
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

bool is_hex(std::string_view s) {
    return !s.empty() && s.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

// The process id in `.oracle-<32 hex>.tmp-<PID>-<16 hex>`, the only name a store gives its
// temporary (create_exclusive_temporary), or -1 for any other name.
pid_t pid_of_temporary_name(std::string_view name) {
    constexpr std::string_view kStart = ".oracle-", kMiddle = ".bin.tmp-";
    if (!name.starts_with(kStart) || name.size() < kStart.size() + 32 + kMiddle.size() + 3 + 16) return -1;
    if (!is_hex(name.substr(kStart.size(), 32))) return -1;
    name.remove_prefix(kStart.size() + 32);
    if (!name.starts_with(kMiddle)) return -1;
    name.remove_prefix(kMiddle.size());
    const auto dash = name.find('-');
    if (dash == std::string_view::npos || dash == 0 || dash > 9 || name.size() - dash - 1 != 16 ||
        !is_hex(name.substr(dash + 1)) ||
        name.substr(0, dash).find_first_not_of("0123456789") != std::string_view::npos)
        return -1;
    return static_cast<pid_t>(std::stol(std::string(name.substr(0, dash))));
}

// A temporary of a store that no longer runs: its process is gone, or it is older than any
// store takes (the PID may have been reused since).
bool is_stale_temporary(pid_t pid, fs::file_time_type written, fs::file_time_type now) {
    const bool gone = pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH;
    return gone || now - written > kStaleTemporary;
}

// `path` opened for reading without following a symbolic link or blocking on a FIFO, when it
// is a regular file (`st` its status); else -1 (errno ENOENT when nothing is there).
int open_regular(const fs::path& path, struct stat& st) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return -1;
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        errno = EINVAL;
        return -1;
    }
    return fd;
}

// What lies at `path`, for a message: "a symbolic link", "a folder", ...
std::string kind_of(const fs::path& path) {
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) return "nothing";
    return S_ISLNK(st.st_mode)    ? "a symbolic link"
           : S_ISDIR(st.st_mode)  ? "a folder"
           : S_ISFIFO(st.st_mode) ? "a FIFO"
           : S_ISREG(st.st_mode)  ? "a file"
                                  : "a device or socket";
}

// `oracle-<32 lowercase hex>.bin`: the key, or empty when the name is not an entry's.
std::string key_of_entry_name(const std::string& name) {
    constexpr std::size_t kKeyDigits = 32;
    if (name.size() != 7 + kKeyDigits + 4 || !name.starts_with("oracle-") || !name.ends_with(".bin")) return {};
    const std::string key = name.substr(7, kKeyDigits);
    return key.find_first_not_of("0123456789abcdef") == std::string::npos ? key : std::string();
}

// A regular file (not followed through a symbolic link) that starts with the entry format's
// magic: one of penumbra's entries, whatever its format version.
bool starts_with_magic(const fs::path& file) {
    struct stat st {};
    const int fd = open_regular(file, st);
    if (fd < 0) return false;
    char head[7];
    const bool ours = ::read(fd, head, sizeof head) == static_cast<ssize_t>(sizeof head) &&
                      std::string_view(head, sizeof head) == kMagicFamily;
    ::close(fd);
    return ours;
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
    if (!scene.has_cutouts()) return;  // an opaque scene's key stays what it was before cut-outs
    k.add_all(scene.triangle_cutout);
    k.add_all(scene.texcoords);
    k.add_all(scene.vertex_alpha);
    k.add(scene.cutout_materials.size());
    for (const CutoutMaterial& m : scene.cutout_materials) {
        k.add(m.mode);
        for (double v : {m.cutoff, m.factor_alpha}) k.add(v);
        k.add(m.texture);
        k.add(m.wrap_s);
        k.add(m.wrap_t);
        k.add(m.nearest);  // min_filter: not the truth's (its base level), not in the key
        k.add(m.uv_transform);
    }
    k.add(scene.alpha_textures.size());
    for (const AlphaTexture& t : scene.alpha_textures) {
        k.add(t.width);
        k.add(t.height);
        k.add_all(t.alpha);
    }
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
    // The suffix: none, B, or one of K M G T followed by nothing, B or iB ("1iB" is not a size).
    const std::string suffix = text.substr(digits);
    double scale = 1;
    if (!suffix.empty() && suffix != "B" && suffix != "b") {
        const auto k =
            std::string_view("KMGT").find(static_cast<char>(std::toupper(static_cast<unsigned char>(suffix[0]))));
        const std::string rest = suffix.substr(1);
        if (k == std::string_view::npos ||
            !(rest.empty() || rest == "B" || rest == "b" || rest == "iB" || rest == "ib"))
            return bad();
        scale = std::ldexp(1.0, 10 * static_cast<int>(k + 1));
    }
    const double bytes = value * scale;
    // A cap is a whole number of bytes: 0.5 would truncate to 0, which means no cap at all.
    if (!std::isfinite(bytes) || bytes >= 1.8e19 || bytes != std::floor(bytes)) return bad();
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

namespace {

// Why a cached frame cannot be the answer to `request` ("" when it can): every value the
// metrics read must be one the oracle could have written, whatever bytes the file held.
std::string cached_frame_problem(const CachedOracle& c, const CacheRequest& request) {
    const OracleFrame& f = c.frame;
    const std::size_t n = f.pixel_count();
    for (std::size_t i = 0; i < n; ++i) {
        if (!(f.A[i] == 0.0f || f.A[i] == 1.0f)) return "a coverage value that is not 0 or 1";
        if (f.prim[i] != kNoPrimitive && f.prim[i] >= request.triangles) return "a triangle index beyond the scene's";
    }
    for (const OracleLightImage& l : f.lights)
        for (std::size_t i = 0; i < n; ++i) {
            if (!(l.V[i] >= 0.0f && l.V[i] <= 1.0f)) return "a visibility outside [0, 1] (or NaN)";
            if (!(l.E[i] >= 0.0f && std::isfinite(l.E[i]))) return "a negative or non-finite error bound";
            if (!(l.U[i] == 0.0f || l.U[i] == 1.0f) || !(l.lightable[i] == 0.0f || l.lightable[i] == 1.0f))
                return "a mask value that is not 0 or 1";
            if (!(l.occluder_m[i] >= 0.0f) || !(l.boundary_m[i] >= 0.0f)) return "a negative or NaN distance";
        }
    if (!c.info.is_object()) return "oracle metadata that is not an object";
    const auto lights = c.info.find("lights");
    if (lights == c.info.end() || !lights->is_array() || lights->size() != request.light_types.size())
        return "oracle metadata for another number of lights";
    for (std::size_t i = 0; i < request.light_types.size(); ++i) {
        const nlohmann::json& l = (*lights)[i];
        if (!l.is_object() || !l.contains("type") || !l["type"].is_string() ||
            l["type"].get<std::string>() != request.light_types[i])
            return fmt::format("oracle metadata whose light {} is not a {} light", i, request.light_types[i]);
    }
    return {};
}

}  // namespace

std::optional<CachedOracle> OracleCache::load(const std::string& key, std::string* damaged,
                                              const CacheRequest* request) const {
    if (dir_.empty()) return std::nullopt;
    const fs::path file = entry(key);
    auto warn = [&](const std::string& what) {
        if (damaged) *damaged = what;
        return std::nullopt;
    };
    // O_NOFOLLOW and O_NONBLOCK: a symbolic link is never followed and a FIFO never waited on.
    struct stat st {};
    const int fd = open_regular(file, st);
    if (fd < 0) {
        if (errno == ENOENT) return std::nullopt;
        return warn(fmt::format("{}: is {}, not a cache entry; left as it is, and the oracle traced afresh",
                                file.string(), kind_of(file)));
    }
    File f(::fdopen(fd, "rb"));
    if (!f) {
        ::close(fd);
        return std::nullopt;
    }
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
    const bool ours = std::fread(magic, 1, 8, f.get()) == 8 && std::string_view(magic, 7) == kMagicFamily;
    std::string why;
    bool ok = ours && std::memcmp(magic, kMagic, 8) == 0 && read(stored_key, 32) &&
              std::string_view(stored_key, 32) == key && read(size, sizeof size) && size[0] > 0 && size[1] > 0 &&
              size[0] <= kMaxImageSide && size[1] <= kMaxImageSide && read(&lights, 4) && lights < 4096 &&
              read(&c.frame.frame_origin, sizeof c.frame.frame_origin) && read(&info_len, 8) &&
              info_len <= kReportJson.max_bytes;  // the info is oracle.json's facts: a report's size at most
    if (ok && request &&
        (size[0] != request->width || size[1] != request->height || lights != request->light_types.size())) {
        ok = false;
        why = fmt::format("it holds a {}x{} frame with {} lights, not {}x{} with {}", size[0], size[1], lights,
                          request->width, request->height, request->light_types.size());
    }
    // The whole size follows from the header: checked before anything is allocated for it.
    const std::uint64_t pixels = ok ? static_cast<std::uint64_t>(size[0]) * static_cast<std::uint64_t>(size[1]) : 0;
    const std::uint64_t header_bytes = 8 + 32 + sizeof size + 4 + sizeof c.frame.frame_origin + 8;
    const std::uint64_t expected_bytes =
        header_bytes + info_len + pixels * (sizeof(float) + sizeof(std::uint32_t) + lights * 6 * sizeof(float)) + 8;
    if (ok && expected_bytes != static_cast<std::uint64_t>(st.st_size)) {
        ok = false;
        why = fmt::format("{} bytes where its header makes {}", st.st_size, expected_bytes);
    }
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
            try {
                c.info = parse_json_strict(info, file.string());
            } catch (const InputError&) {
                ok = false;
            }
        }
        if (ok && request) {
            why = cached_frame_problem(c, *request);
            ok = why.empty();
        }
    }
    XXH3_freeState(sum);
    if (!ok) {
        f.reset();
        if (!ours)  // not penumbra's: never removed (docs/outputs.md)
            return warn(fmt::format(
                "{}: is named like a cache entry but is not one of penumbra's; left as it is, and the oracle "
                "traced afresh",
                file.string()));
        remove_if_same_file(file, st.st_dev, st.st_ino);
        return warn(fmt::format(
            "{}: the cached oracle was damaged or does not match this scenario ({}) and was removed; traced again",
            file.string(), why.empty() ? "its checksum or layout did not match" : why));
    }
    ::futimens(::fileno(f.get()), nullptr);  // recently used: kept longest
    return c;
}

std::optional<std::string> OracleCache::store(const std::string& key, const OracleFrame& frame,
                                              const nlohmann::json& info) const {
    if (dir_.empty()) return std::nullopt;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    const fs::path final_path = entry(key);
    // Only one of penumbra's own entries (or nothing) is replaced.
    auto foreign = [&] {
        struct stat st {};
        return ::lstat(final_path.c_str(), &st) == 0 && !starts_with_magic(final_path);
    };
    auto not_kept = [&] {
        return fmt::format(
            "{}: is {} that is not one of penumbra's cache entries; left as it is, and the oracle "
            "was not cached",
            final_path.string(), kind_of(final_path));
    };
    if (foreign()) return not_kept();
    ExclusiveTemporary t;
    try {
        t = create_exclusive_temporary(dir_, final_path.filename().string());
    } catch (const EnvironmentError&) {
        return fmt::format("{}: could not store the oracle in the cache; the next run traces again", dir_.string());
    }
    const fs::path tmp = t.path;
    bool ok = false;
    const int tracked = track_for_interrupt(tmp, false);
    {
        File f(::fdopen(t.fd, "wb"));
        if (!f) ::close(t.fd);
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
    if (ok && foreign()) {  // put there while the entry was written
        remove_if_same_file(tmp, t.device, t.inode);
        untrack_for_interrupt(tracked);
        return not_kept();
    }
    if (ok && ::rename(tmp.c_str(), final_path.c_str()) != 0) ec = std::error_code(errno, std::generic_category());
    if (!ok || ec) remove_if_same_file(tmp, t.device, t.inode);
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
        if (c.key.empty() || !fs::is_regular_file(e.symlink_status(fec)) || !starts_with_magic(e.path())) continue;
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
    // Only a store's own temporaries go: the exact name a store gives one, a regular file of
    // this user that starts with the entry format's magic (written first) or is empty, of a
    // process that is gone. Anything else of a similar name is the user's, and stays.
    std::error_code ec;
    const auto now = fs::file_time_type::clock::now();
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
        const pid_t pid = pid_of_temporary_name(e.path().filename().string());
        if (pid <= 0) continue;
        struct stat st {};
        const int fd = open_regular(e.path(), st);
        if (fd < 0) continue;
        // An empty file of the exact name is a store killed before it wrote its header: it holds
        // nothing of anyone's, and would otherwise stay forever.
        char head[7];
        const bool ours = st.st_uid == ::getuid() &&
                          (st.st_size == 0 || (::read(fd, head, sizeof head) == static_cast<ssize_t>(sizeof head) &&
                                               std::string_view(head, sizeof head) == kMagicFamily));
        ::close(fd);
        std::error_code fec;
        if (ours && is_stale_temporary(pid, fs::last_write_time(e.path(), fec), now) && !fec)
            remove_if_same_file(e.path(), st.st_dev, st.st_ino);
    }
}

}  // namespace penumbra
