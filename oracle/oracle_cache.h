// The oracle's answer depends only on the scene, camera, lights, image size and oracle
// settings, so it is computed once and reused: validate, tune and sweep with another technique
// pay for the raster pass and the metrics only (docs/design.md, "Data flow").
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/frames.h"
#include "common/scenario.h"
#include "oracle/oracle.h"

namespace penumbra {

// 32 hex digits: a fingerprint of everything the oracle's result depends on (the loaded
// geometry, so external buffers count too; camera; lights; image size; settings that change
// results; the oracle's algorithm version). Thread count and progress do not count.
std::string oracle_cache_key(const Scenario& scenario, const OracleSettings& settings);

// What a run's verdict is about, as report.json's "fingerprint" records it: 32 hex digits each
// for "scene" (the loaded geometry), "camera" and "lights" (their types and placement), so that
// `penumbra diff` can tell two runs of one scenario from runs of different ones and name what
// differs. The image size is report.json's "image".
nlohmann::json scenario_fingerprint(const Scenario& scenario);

// The default size cap of the cache, 2 GiB.
inline constexpr std::uint64_t kDefaultCacheMaxBytes = 2ull << 30;

// A size as --cache-max and PENUMBRA_CACHE_MAX take it: bytes, or a number with a binary K, M, G
// or T suffix ("512M"); 0 is no cap. Throws InputError naming `what`.
std::uint64_t parse_cache_size(const std::string& text, const std::string& what);

struct CachedOracle {
    OracleFrame frame;    // A, prim and every light channel; P, N and depth are not kept
    nlohmann::json info;  // the oracle.json of the run that produced it
};

// What the run asks the cache for, beyond the key: a cached frame must be of this shape.
struct CacheRequest {
    int width = 0, height = 0;
    std::vector<std::string> light_types;  // to_string(Light::type), in the scenario's order
    std::uint64_t triangles = 0;           // the scene's triangle count: every prim is below it
};

// One entry of the cache: a file `oracle-<32 hex>.bin` that starts with the cache's magic.
struct CacheEntry {
    std::string key;
    std::filesystem::path file;
    std::uint64_t bytes = 0;
    std::filesystem::file_time_type last_use;  // the file's mtime: set by every store and load
};

class OracleCache {
  public:
    // `dir` empty: a cache that never hits and stores nothing. `max_bytes` caps the entries'
    // total size (0: no cap).
    explicit OracleCache(std::filesystem::path dir, std::uint64_t max_bytes = kDefaultCacheMaxBytes);

    // Default folder: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else ~/.cache/penumbra.
    static std::filesystem::path default_dir();
    // Default cap: $PENUMBRA_CACHE_MAX (InputError when it is not a size), else 2 GiB.
    static std::uint64_t default_max_bytes();

    // A damaged or foreign entry is a miss, never an error; `damaged`, when given, is set to a
    // warning naming it. The entry is opened without following a symbolic link or waiting on a
    // FIFO, must be a regular file whose size its header accounts for (checked before anything
    // is allocated), end with the checksum of its bytes and, given `request`, hold a frame of
    // that size, light count and light types whose every value is one the oracle writes (no
    // NaN). A bad entry of penumbra's (one that starts with the format's magic) is removed;
    // anything else at that name is left as it is.
    std::optional<CachedOracle> load(const std::string& key, std::string* damaged = nullptr,
                                     const CacheRequest* request = nullptr) const;
    // Written to an exclusive temporary (create_exclusive_temporary) and renamed, so readers
    // never see half an entry (the temporary is removed on an interrupt, and one left by a
    // killed run is swept later); a name held by anything but one of penumbra's entries is not
    // replaced (a warning says so). Then
    // the cap is applied (prune). Failures to write only cost the reuse: they return a warning,
    // as does an entry larger than the cap by itself (it is not kept).
    std::optional<std::string> store(const std::string& key, const OracleFrame& frame,
                                     const nlohmann::json& info) const;

    // The cache's own entries, most recently used first; any other file in the folder is not one.
    std::vector<CacheEntry> entries() const;
    // Removes the least recently used entries until the rest fit under the cap; returns them.
    std::vector<CacheEntry> prune() const;
    // Removes every entry (and the temporaries of stores that no longer run); returns the entries.
    std::vector<CacheEntry> clear() const;

    const std::filesystem::path& dir() const { return dir_; }
    std::uint64_t max_bytes() const { return max_bytes_; }
    std::filesystem::path entry(const std::string& key) const;

  private:
    void sweep_temporaries() const;
    std::filesystem::path dir_;
    std::uint64_t max_bytes_;
};

}  // namespace penumbra
