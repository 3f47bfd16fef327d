// `penumbra sweep`: error against GPU time over technique configurations; `penumbra merge`:
// shard outputs back into what one run writes (docs/sweep.md).
#include <fmt/format.h>

#include <memory>
#include <optional>

#include "app/cli.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/memory_estimate.h"
#include "common/output_files.h"
#include "common/progress.h"
#include "oracle/oracle_cache.h"
#include "raster/vulkan_context.h"
#include "sweep/sweep_files.h"

namespace penumbra::cli {
namespace {

struct SweepArgs {
    std::filesystem::path scenario;
    Common common;
    TechniqueArgs technique;
    std::vector<std::string> vary;
    std::filesystem::path configs;
    std::string shard = "1/1";
    int repeat = 3;
    VerdictArgs verdict;
};

int run_sweep_command(const SweepArgs& a) {
    const Common& c = a.common;
    const ThreadLimit limit(c);
    // Everything the user wrote is checked before any work starts: the limits on the work, then
    // every configuration is parsed.
    if (a.vary.empty() == a.configs.empty())
        throw InputError("sweep: give --vary KEY=V1,V2,... (one or more) or --configs FILE, not both");
    if (a.repeat < 1 || a.repeat > sweep::kMaxRepeat)
        throw InputError(fmt::format("--repeat: {}; expected 1 to {}", a.repeat, sweep::kMaxRepeat));
    const sweep::Shard shard = sweep::parse_shard(a.shard);
    std::vector<sweep::Axis> axes;
    std::vector<std::string> keys;
    std::string product;  // names the work in a refusal
    if (!a.configs.empty()) {
        keys = {"configuration"};
        product = "--configs " + escape_non_utf8(a.configs.string());
    } else {
        for (const auto& v : a.vary) {
            axes.push_back(sweep::parse_axis(v));
            keys.push_back(axes.back().key);
            product += fmt::format("{}{} ({} values)", product.empty() ? "--vary " : " x ", axes.back().key,
                                   axes.back().values.size());
        }
        sweep::check_axes(axes);
        sweep::check_configuration_count(sweep::product_size(axes), product);
    }
    const Scenario scenario = load_for_command(a.scenario, c);
    std::string label;
    const nlohmann::json base = technique_json(scenario, a.technique, label);
    std::vector<sweep::Config> all = a.configs.empty() ? sweep::expand(base, axes, scenario.lights)
                                                       : sweep::configs_from_file(a.configs, base, scenario.lights);
    const std::size_t in_run = sweep::shard_size(all.size(), shard);
    sweep::check_work(all.size(), in_run, a.repeat, scenario.lights.size(), memory_budget(c.max_memory), product);
    for (const auto& cfg : all) check_run_memory(scenario, c, true, &cfg.technique, true);
    std::vector<sweep::Config> mine;
    for (const auto& cfg : all)
        if (static_cast<int>(cfg.index % static_cast<std::size_t>(shard.n)) == shard.k - 1) mine.push_back(cfg);

    sweep::SweepOptions options;
    options.validate = validate_options(c, a.verdict);
    options.validate.oracle.progress = false;
    options.repeat = a.repeat;
    const auto sweep_start = SteadyClock::now();
    if (!c.quiet)
        options.progress = [&](const sweep::Row& r, std::size_t done, std::size_t of) {
            std::string what;
            for (std::size_t k = 0; k < r.values.size(); ++k) what += fmt::format(" {}={}", keys[k], r.values[k]);
            const std::string left = time_left(seconds_since(sweep_start), done, of);
            fmt::print(stderr, "sweep: [{}/{}]{}: wrong {:.5f}, production {:.3f} ms, diagnostic {:.3f} ms{}\n", done,
                       of, what, r.verdict[0], sweep::median(r.production_ms), sweep::median(r.diagnostic_ms),
                       left.empty() ? "" : "; " + left);
        };
    raster::ContextOptions co;
    co.device = a.technique.device;
    raster::VulkanContext ctx(co);
    const nlohmann::json device = {{"name", ctx.info().name}, {"type", ctx.info().type}, {"driver", ctx.info().driver}};
    const std::string fingerprint =
        sweep::definition_fingerprint(oracle_cache_key(scenario, options.validate.oracle), base, keys, all,
                                      options.validate.tolerance, a.repeat, device);
    const sweep::Table t =
        sweep::run_sweep(scenario, a.scenario.string(), keys, mine, all.size(), shard, options, ctx, fingerprint);
    OutputTransaction out(c.out);
    sweep::write_sweep_outputs(out, t);
    out.commit();
    if (!c.quiet)
        fmt::print("sweep: {} of {} configurations on {}; results: {}/sweep.csv, sweep.json, pareto.svg, report.html\n",
                   t.rows.size(), t.total, ctx.info().name, c.out.string());
    return kExitSuccess;
}

int run_merge_command(const std::vector<std::filesystem::path>& dirs, const std::filesystem::path& out_dir,
                      bool quiet) {
    namespace fs = std::filesystem;
    std::vector<sweep::Table> tables;
    std::vector<std::string> labels;
    for (const auto& d : dirs) {
        labels.push_back(escape_non_utf8(d.string()));
        // The output would replace a shard's files while other shards are read: never a shard.
        std::error_code ec;
        if (fs::equivalent(d, out_dir, ec))
            throw InputError(fmt::format("merge: --out {} is one of the shard folders", labels.back()));
        std::optional<std::string> csv;
        if (fs::exists(d / "sweep.csv", ec)) csv = read_regular_file(d / "sweep.csv", sweep::kMaxShardFileBytes);
        tables.push_back(
            sweep::read_shard(read_regular_file(d / "sweep.json", sweep::kMaxShardFileBytes), csv, labels.back()));
    }
    const sweep::Table t = sweep::merge(std::move(tables), labels);
    OutputTransaction out(out_dir);
    sweep::write_sweep_outputs(out, t);
    out.commit();
    if (!quiet)
        fmt::print("merge: {} configurations from {} shards into {}\n", t.rows.size(), dirs.size(), out_dir.string());
    return kExitSuccess;
}

}  // namespace

Subcommand add_sweep_command(CLI::App& parent) {
    auto a = std::make_shared<SweepArgs>();
    CLI::App* cmd = parent.add_subcommand("sweep", "Error against GPU time over technique configurations");
    cmd->add_option("SCENARIO", a->scenario, "Scenario JSON file")->required();
    add_common(cmd, a->common);
    add_size(cmd, a->common);
    add_technique(cmd, a->technique);
    cmd->add_option("--vary", a->vary, "KEY=V1,V2,...: a technique key and its values (repeatable: the product)");
    cmd->add_option("--configs", a->configs, "JSON array of presets or technique objects, instead of --vary");
    cmd->add_option("--shard", a->shard, "K/N: run the K-th of N slices of the configurations (default 1/1)");
    cmd->add_option("--repeat", a->repeat, "GPU timings per configuration, median and min reported (default 3)");
    add_verdict_options(cmd, a->verdict);
    describe_outputs(cmd,
                     "Outputs (in --out): sweep.csv and sweep.json (a row per configuration: the varied keys, the "
                     "verdict,\nproduction and diagnostic GPU ms), pareto.svg/.png and report.html.",
                     "penumbra sweep data/default/scenario.json --out sweep-out --vary resolution=1024,2048 --vary "
                     "filter.type=none,pcf");
    return {cmd, [a] { return run_sweep_command(*a); }};
}

Subcommand add_merge_command(CLI::App& parent) {
    struct Args {
        std::vector<std::filesystem::path> dirs;
        std::filesystem::path out;
        bool quiet = false;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = parent.add_subcommand("merge", "Combine sweep shard folders into the files one run writes");
    cmd->add_option("DIR", a->dirs, "Shard output folders (each with sweep.json)")->required();
    cmd->add_option("--out", a->out, "Output folder (created if missing)")
        ->required()
        ->check(kUserPath)
        ->check(output_folder_problem);
    cmd->add_flag("-q,--quiet", a->quiet, "Print nothing but errors");
    describe_outputs(cmd,
                     "Outputs (in --out): the files one sweep run writes (sweep.csv, sweep.json, pareto.svg/.png, "
                     "report.html),\nfrom shards of one sweep definition (else exit 2 naming what differs).",
                     "penumbra merge shard-1 shard-2 --out sweep-out");
    return {cmd, [a] { return run_merge_command(a->dirs, a->out, a->quiet); }};
}

}  // namespace penumbra::cli
