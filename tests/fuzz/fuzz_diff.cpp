// libFuzzer target: a run `penumbra diff` reads (report.json or stress.json), parsed and diffed
// against itself, with diff.json and the terminal's table made from the result.
#include "common/json_reader.h"
#include "fuzz_support.h"
#include "pipeline/diff.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    const std::string text(reinterpret_cast<const char*>(data), size);
    fuzz::expect_input_errors_only([&] {
        const diff::Run run = diff::parse_run(parse_json_strict(text, "report.json"), "run/report.json");
        const diff::DiffResult d = diff::diff_runs(run, run, diff::kDefaultWorseTolerance);
        if (d.worse()) std::abort();  // a run is never worse than itself
        (void)diff::diff_json(run, run, d).dump();
        (void)diff::diff_table(run, run, d);
    });
    return 0;
}
