// The oracle's answer depends only on the scene, camera, lights, image size and oracle
// settings, so it is computed once and reused: validate, tune and sweep with another technique
// pay for the raster pass and the metrics only (docs/design.md, "Data flow").
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "common/frames.h"
#include "common/scenario.h"
#include "oracle/oracle.h"

namespace penumbra {

// 32 hex digits: a fingerprint of everything the oracle's result depends on (the loaded
// geometry, so external buffers count too; camera; lights; image size; settings that change
// results; the oracle's algorithm version). Thread count and progress do not count.
std::string oracle_cache_key(const Scenario& scenario, const OracleSettings& settings);

struct CachedOracle {
    OracleFrame frame;    // A, prim and every light channel; P, N and depth are not kept
    nlohmann::json info;  // the oracle.json of the run that produced it
};

class OracleCache {
  public:
    // `dir` empty: a cache that never hits and stores nothing.
    explicit OracleCache(std::filesystem::path dir, int max_entries = 16);

    // Default folder: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else ~/.cache/penumbra.
    static std::filesystem::path default_dir();

    // A damaged or foreign entry is a miss (and is removed), never an error; every entry ends
    // with a checksum of its bytes, so flipped bytes are found. `damaged`, when given, is set
    // to a warning naming the entry when one was removed.
    std::optional<CachedOracle> load(const std::string& key, std::string* damaged = nullptr) const;
    // Written to a temporary name and renamed, so readers never see half an entry (the
    // temporary is removed on an interrupt, and one left by a killed run is swept later); the
    // oldest entries beyond max_entries are removed. Failures to write only cost the reuse: they
    // return a warning.
    std::optional<std::string> store(const std::string& key, const OracleFrame& frame,
                                     const nlohmann::json& info) const;

    const std::filesystem::path& dir() const { return dir_; }

  private:
    std::filesystem::path entry(const std::string& key) const;
    std::filesystem::path dir_;
    int max_entries_;
};

}  // namespace penumbra
