// libFuzzer target: a shard folder as `penumbra merge` reads it (sweep::read_shard): sweep.json's
// text and, after a line "%%sweep.csv%%", sweep.csv's (none when the line is absent). A shard
// that is read must hold what the files are written from (one value per key, one verdict per
// column, indices in [0, total)); it is then merged alone and written back as JSON and CSV.
#include <cstdlib>
#include <optional>

#include "fuzz_support.h"
#include "sweep/sweep_table.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    const std::string text(reinterpret_cast<const char*>(data), size);
    static const std::string kSeparator = "\n%%sweep.csv%%\n";
    const std::size_t at = text.find(kSeparator);
    const std::string json_text = text.substr(0, at);
    std::optional<std::string> csv;
    if (at != std::string::npos) csv = text.substr(at + kSeparator.size());
    fuzz::expect_input_errors_only([&] {
        const sweep::Table t = sweep::read_shard(json_text, csv, "shard");
        if (t.columns.empty() || t.keys.empty()) std::abort();
        for (const sweep::Row& r : t.rows)
            if (r.index >= t.total || r.values.size() != t.keys.size() || r.verdict.size() != t.columns.size() ||
                r.production_ms.size() != static_cast<std::size_t>(t.repeat))
                std::abort();
        (void)sweep::to_json(t).dump();
        (void)sweep::sweep_csv(t);
        const std::string label = "shard";
        const sweep::Table merged = sweep::merge({t}, std::span<const std::string>(&label, 1));
        (void)sweep::sweep_csv(merged);
    });
    return 0;
}
