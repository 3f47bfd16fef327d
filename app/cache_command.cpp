// `penumbra cache`: what the oracle cache holds, and keeping it within its cap (docs/oracle.md,
// "The cache"). Only the cache's own entries are touched, never other files in its folder.
#include <fmt/chrono.h>
#include <fmt/format.h>

#include <chrono>
#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "oracle/oracle_cache.h"

namespace penumbra::cli {
namespace {

struct CacheArgs {
    std::string action = "list";
    std::filesystem::path dir;
    std::string max;
};

std::string when(std::filesystem::file_time_type t) {
    const auto sys = std::chrono::file_clock::to_sys(t);
    return fmt::format(
        "{:%Y-%m-%d %H:%M:%S} UTC",
        fmt::gmtime(std::chrono::system_clock::to_time_t(std::chrono::time_point_cast<std::chrono::seconds>(sys))));
}

std::uint64_t total_of(const std::vector<CacheEntry>& entries) {
    std::uint64_t total = 0;
    for (const auto& e : entries) total += e.bytes;
    return total;
}

std::string holds(const OracleCache& cache) {
    const std::vector<CacheEntry> entries = cache.entries();
    return fmt::format("{}: {} {}, {} (cap {})", path_text(cache.dir()), entries.size(),
                       entries.size() == 1 ? "entry" : "entries", format_bytes(total_of(entries)),
                       cache.max_bytes() == 0 ? "none" : format_bytes(cache.max_bytes()));
}

int run_cache_command(const CacheArgs& a) {
    const std::filesystem::path dir = a.dir.empty() ? OracleCache::default_dir() : a.dir;
    if (dir.empty())
        throw InputError(
            "no cache folder: neither PENUMBRA_CACHE_DIR, XDG_CACHE_HOME nor HOME is set; give --cache DIR");
    std::error_code ec;
    if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
        throw InputError(fmt::format("--cache {}: not a folder", path_text(dir)));
    const OracleCache cache(dir,
                            a.max.empty() ? OracleCache::default_max_bytes() : parse_cache_size(a.max, "--cache-max"));
    if (a.action == "list") {
        for (const CacheEntry& e : cache.entries())
            fmt::print("{}  {:>10}  last used {}\n", path_text(e.file.filename()), format_bytes(e.bytes),
                       when(e.last_use));
    } else {
        const std::vector<CacheEntry> removed = a.action == "clear" ? cache.clear() : cache.prune();
        for (const CacheEntry& e : removed) fmt::print("removed {}\n", path_text(e.file.filename()));
        fmt::print("removed {} {} ({})\n", removed.size(), removed.size() == 1 ? "entry" : "entries",
                   format_bytes(total_of(removed)));
    }
    fmt::print("{}\n", holds(cache));
    return kExitSuccess;
}

}  // namespace

Subcommand add_cache_command(CLI::App& parent) {
    auto a = std::make_shared<CacheArgs>();
    CLI::App* cmd = parent.add_subcommand("cache", "List the oracle cache, apply its size cap, or clear it");
    cmd->add_option("ACTION", a->action,
                    "list (default): every entry, its size and last use, and the total; prune: remove the least "
                    "recently used entries beyond the cap; clear: remove every entry")
        ->check(CLI::IsMember({"list", "prune", "clear"}));
    cmd->add_option("--cache", a->dir,
                    "Oracle cache folder (default: $PENUMBRA_CACHE_DIR, $XDG_CACHE_HOME/penumbra, ~/.cache/penumbra)")
        ->check(kUserPath);
    cmd->add_option("--cache-max", a->max,
                    "Size cap for prune, e.g. 2G (0: no cap; default: $PENUMBRA_CACHE_MAX, else 2G)")
        ->check(cache_size_problem);
    cmd->footer(
        "Outputs: none; prints one line per entry (list) or per removed entry (prune, clear), then the cache's\n"
        "folder, entry count, total size and cap. Entries are the files oracle-<32 hex digits>.bin that start with\n"
        "the cache's magic bytes; other files in the folder are never touched. Last use is the entry's modification\n"
        "time, which every store and every cache hit sets.\n"
        "Example:\n"
        "  penumbra cache prune --cache-max 500M");
    return {cmd, [a] { return run_cache_command(*a); }};
}

}  // namespace penumbra::cli
