// libFuzzer target: the runs `penumbra diff` reads (report.json or stress.json). One run is
// parsed and diffed against itself (never worse than itself); an input holding the separator
// line "=====" is two runs, A before it and B after, diffed both ways: their lights are paired
// by index, so mismatched, repeated or swapped indices and light types must be refused (#50).
// diff.json and the terminal's table are made from every result.
#include <string_view>

#include "common/json_reader.h"
#include "fuzz_support.h"
#include "pipeline/diff.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    const std::string text(reinterpret_cast<const char*>(data), size);
    constexpr std::string_view kSeparator = "\n=====\n";
    fuzz::expect_input_errors_only([&] {
        const std::size_t cut = text.find(kSeparator);
        if (cut == std::string::npos) {
            const diff::Run run = diff::parse_run(parse_json_strict(text, "report.json"), "run/report.json");
            const diff::DiffResult d = diff::diff_runs(run, run, diff::kDefaultWorseTolerance);
            if (d.worse()) std::abort();  // a run is never worse than itself
            (void)diff::diff_json(run, run, d).dump();
            (void)diff::diff_table(run, run, d);
            return;
        }
        const diff::Run a = diff::parse_run(parse_json_strict(text.substr(0, cut), "a.json"), "a/report.json");
        const diff::Run b =
            diff::parse_run(parse_json_strict(text.substr(cut + kSeparator.size()), "b.json"), "b/report.json");
        for (const auto& [x, y] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
            const diff::DiffResult d = diff::diff_runs(*x, *y, diff::kDefaultWorseTolerance);
            (void)diff::diff_json(*x, *y, d).dump();
            (void)diff::diff_table(*x, *y, d);
        }
    });
    return 0;
}
