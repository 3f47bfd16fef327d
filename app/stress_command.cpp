// `penumbra stress`: the built-in suite of stiff and extreme generated scenes (docs/stress.md):
// the oracle's invariance on every case and the technique's verdict, as files and a CI gate.
#include <fmt/format.h>
#include <unistd.h>

#include <cstdio>
#include <memory>

#include "app/cli.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/output_files.h"
#include "stress/stress_files.h"
#include "stress/suite.h"

namespace penumbra::cli {
namespace {

struct StressArgs {
    std::filesystem::path out;
    std::vector<std::string> cases;
    std::filesystem::path gate_file;
    std::filesystem::path junit_file;
    double tolerance = 1.0 / 255.0;
    double visible_threshold = 0.1;
    std::uint64_t seed = 20;
    int threads = 0;
    bool quiet = false;
};

int run_stress_command(const StressArgs& a, const TechniqueArgs& t) {
    const ThreadLimit limit(a.threads);
    if (!a.junit_file.empty()) check_output_file(a.junit_file, a.out, "--junit");
    // Everything the user wrote is checked before any work starts.
    stress::CaseOptions co;
    co.seed = a.seed;
    const std::vector<stress::StressCase> cases = stress::make_cases(a.cases, co);
    Scenario no_scenario;  // the technique comes from --technique, --preset and --set alone
    no_scenario.label = "stress";
    std::string label;
    const nlohmann::json tj = technique_json(no_scenario, t, label);
    const raster::Technique technique = raster::parse_technique(tj, label);
    stress::check_technique_cases(technique, cases, label);
    stress::StressGate gate;
    if (!a.gate_file.empty())
        gate =
            stress::parse_stress_gate(read_json_file(a.gate_file, kGateJson), a.gate_file.filename().string(), cases);

    stress::SuiteOptions options;
    options.validate.oracle.threads = a.threads;
    options.validate.tolerance = a.tolerance;
    options.validate.visible_threshold = a.visible_threshold;
    options.validate.device = t.device;
    options.validate.use_cache = false;
    const bool terminal = !a.quiet && ::isatty(::fileno(stderr));
    if (terminal)
        options.progress = [](std::size_t done, std::size_t total, const std::string& name) {
            if (done < total)
                fmt::print(stderr, "\rstress: case {}/{} {:<24}", done + 1, total, name);
            else
                fmt::print(stderr, "\r{:<60}\r", "");
            std::fflush(stderr);
        };
    OutputTransaction out(a.out);
    const stress::SuiteResult result = stress::run_suite(cases, technique, gate, options);
    const nlohmann::json stress_json = stress::stress_json(cases, result, technique, gate, co);
    stress::write_stress_outputs(out, cases, result, stress_json);
    out.commit();
    if (!a.junit_file.empty()) {
        std::filesystem::path dir = a.junit_file.parent_path();
        OutputTransaction junit(dir.empty() ? std::filesystem::path(".") : dir);
        junit.write_text(a.junit_file.filename().string(), stress::stress_junit(cases, result, gate));
        junit.commit();
    }

    const auto failures = stress::failure_lines(cases, result, gate);
    if (!a.quiet) {
        for (const auto& r : result.cases)
            for (const auto& w : r.judged.warnings) fmt::print(stderr, "warning: case {}: {}\n", r.name, w);
        std::size_t holds = 0;
        for (std::size_t k = 0; k < cases.size(); ++k) {
            const auto& r = result.cases[k];
            holds += r.invariant.holds();
            std::string rates;
            for (const auto& l : r.judged.score.lights) rates += fmt::format(" {:.2f}%", 100.0 * l.wrong_fraction);
            fmt::print("  {:<22} oracle {} ({} differ, {} uncertain)  wrong per light:{}  {:.2f} s\n", r.name,
                       r.invariant.holds() ? "holds" : "FAILS", r.invariant.differing, r.invariant.uncertain, rates,
                       r.seconds);
        }
        fmt::print("stress: {} cases on {} in {:.1f} s; the oracle invariant holds on {} of them; {}\n", cases.size(),
                   result.device, result.seconds, holds,
                   result.technique_gated() ? "the technique's gate is judged"
                                            : "no gate: the technique's verdicts are reported, not judged");
        fmt::print("results: {}/report.html, stress.json\n", a.out.string());
    }
    for (const auto& line : failures) fmt::print(stderr, "{}\n", line);
    if (!result.passed) {
        if (!a.quiet) fmt::print("stress: FAILED\n");
        return kExitGateFailed;
    }
    return kExitSuccess;
}

}  // namespace

Subcommand add_stress_command(CLI::App& parent) {
    struct Args {
        StressArgs stress;
        TechniqueArgs technique;
    };
    auto a = std::make_shared<Args>();
    StressArgs& s = a->stress;
    CLI::App* cmd = parent.add_subcommand(
        "stress", "Generated stiff and extreme scenes: the oracle's invariance and the technique's verdict on each");
    cmd->add_option("--out", s.out, "Output folder (created if missing)")
        ->required()
        ->check(kUserPath)
        ->check(output_folder_problem);
    add_technique(cmd, a->technique);
    std::string names;
    for (const auto& n : stress::case_names()) names += (names.empty() ? "" : ", ") + n;
    cmd->add_option("--cases", s.cases, "Comma-separated cases to run (default: all): " + names)->delimiter(',');
    cmd->add_option("--gate", s.gate_file,
                    "Gate JSON: validate's checks on every light of every case, and \"oracle_invariant\"")
        ->check(kUserPath);
    cmd->add_option("--junit", s.junit_file, "Write the suite's checks as JUnit XML to this file")->check(kUserPath);
    add_tolerance(cmd, s.tolerance);
    add_visible_threshold(cmd, s.visible_threshold);
    cmd->add_option("--seed", s.seed, "Seed of the generated scenes' random parts (default 20)");
    cmd->add_option("--threads", s.threads, "Worker threads (default: all)")->check(CLI::Range(0, 1024));
    cmd->add_flag("-q,--quiet", s.quiet, "Print nothing but errors");
    describe_outputs(cmd,
                     "Outputs (in --out): stress.json (per case the oracle invariant and the technique's rates per "
                     "light),\nreport.html and <case>.light<i>.classes.png; with --junit the JUnit file. Exit 1 when "
                     "the invariant or a\ngate fails.",
                     "penumbra stress --out stress-out --preset d3d12-textbook --cases grazing_89,far_1e7");
    return {cmd, [a] { return run_stress_command(a->stress, a->technique); }};
}

}  // namespace penumbra::cli
