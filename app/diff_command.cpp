// `penumbra diff`: did run B make shadows worse than run A? Per light and class, what changed,
// and exit 1 when a class's rate of wrong pixels rose beyond the tolerance (docs/design.md).
#include <fmt/format.h>

#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "common/output_files.h"
#include "pipeline/diff.h"
#include "pipeline/diff_files.h"

namespace penumbra::cli {
namespace {

struct DiffArgs {
    std::filesystem::path run_a, run_b, out;
    double tolerance = diff::kDefaultWorseTolerance;
    bool quiet = false;
};

int run_diff_command(const DiffArgs& a) {
    const diff::Run run_a = diff::read_run(a.run_a);
    const diff::Run run_b = diff::read_run(a.run_b);
    const diff::DiffResult d = diff::diff_runs(run_a, run_b, a.tolerance);
    if (!a.out.empty()) {
        OutputTransaction out(a.out);
        diff::write_diff_outputs(out, run_a, run_b, d);
        out.commit();
    }
    if (!a.quiet) {
        for (const auto& w : d.warnings) fmt::print(stderr, "warning: {}\n", w);
        fmt::print("{}", diff::diff_table(run_a, run_b, d));
    }
    for (const auto& line : d.worse_lines) fmt::print(stderr, "worse: {}\n", line);
    if (!a.quiet) {
        if (d.worse())
            fmt::print("diff: B is WORSE than A ({} light and class pairs rose by more than {:.4f} points)\n",
                       d.worse_lines.size(), 100.0 * a.tolerance);
        else
            fmt::print("diff: B is {} A\n", d.identical() ? "identical to" : "not worse than");
        if (!a.out.empty()) fmt::print("results: {}/diff.html, diff.json\n", a.out.string());
    }
    return d.worse() ? kExitGateFailed : kExitSuccess;
}

}  // namespace

Subcommand add_diff_command(CLI::App& parent) {
    auto a = std::make_shared<DiffArgs>();
    CLI::App* cmd =
        parent.add_subcommand("diff", "What changed between two runs of one scenario; exit 1 when B is worse");
    cmd->add_option("RUN_A", a->run_a, "The reference run: report.json or stress.json, or the folder holding it")
        ->required()
        ->check(kUserPath);
    cmd->add_option("RUN_B", a->run_b, "The run judged against it, the same way")->required()->check(kUserPath);
    cmd->add_option(
           "--gate-worse", a->tolerance,
           "B is worse when a class's rate of wrong pixels (visible ones where both runs counted them) rose "
           "by more than this fraction of scored pixels, absolute (default 0.001: 0.1 percentage points; 0: any "
           "rise)")
        ->check(range(0.0, 1.0));
    cmd->add_option("--out", a->out, "Also write diff.json and diff.html here (created if missing)")
        ->check(kUserPath)
        ->check(output_folder_problem);
    cmd->add_flag("-q,--quiet", a->quiet, "Print nothing but errors and what got worse");
    cmd->footer(
        "Outputs (with --out): diff.json (per light and class: A, B, the change and whether it is worse) and "
        "diff.html\n"
        "(the tables and both runs' class maps side by side, copied into the page). The table is printed either way.\n"
        "Exit codes: 0 B is not worse, 1 B is worse (each light and class named on stderr), 2 the runs are of\n"
        "different scenarios or a file is missing or malformed.\n"
        "Example:\n"
        "  penumbra diff main-run/ branch-run/report.json --gate-worse 0.001 --out diff-out");
    return {cmd, [a] { return run_diff_command(*a); }};
}

}  // namespace penumbra::cli
