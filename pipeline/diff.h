// `penumbra diff`: what changed between two runs of one scenario, light by light and class by
// class, and whether the second run is worse (docs/design.md, "penumbra diff"). The runs are the
// report.json of validate or compare, or the stress.json of stress. Reading and comparing are
// here, pure JSON in and out; diff_files.h writes diff.json and diff.html.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::diff {

// --gate-worse's default: a class's rate may rise by 0.1 percentage points of the scored pixels
// (tune's --max-acne default) before B counts as worse, so a trade of much acne for a little
// peter-panning is not a regression.
inline constexpr double kDefaultWorseTolerance = 0.001;

// The classes of a wrong pixel, in report.json's order.
// The error classes as report.json names them; a run without one (light_bleeding is newer
// than the others) reads it as 0.
inline constexpr std::array<const char*, 6> kClasses = {"acne",         "peter_panning", "aliasing",
                                                        "false_shadow", "false_lit",     "light_bleeding"};

// One light's numbers in a run; for stress, one light of one case.
struct LightNumbers {
    std::string case_name;  // stress only
    int index = 0;
    std::string type;
    std::uint64_t scored = 0;
    std::array<std::uint64_t, kClasses.size()> counts{}, counts_visible{};
    std::array<double, kClasses.size()> rates{}, rates_visible{};
    bool has_visible = false;  // counts_visible and rates_visible were in the run (not in stress.json)
    double wrong_fraction = 0;
    std::optional<double> perceptual_mean, perceptual_max;
    nlohmann::json object;            // the light's object as the run wrote it: equal objects are identical
    std::filesystem::path class_map;  // its class map beside the run's file (it may be missing)
    std::string label() const;        // "light 0 (directional)", "far_1e7 light 0 (directional)"
};

struct Run {
    std::filesystem::path file;  // report.json or stress.json
    std::string kind;            // "validate", "compare" or "stress"
    std::string scenario;        // the scenario file (stress: "the stress suite")
    nlohmann::json image;        // {"width", "height"}
    nlohmann::json fingerprint;  // report.json's (scene, camera, lights); null when the run has none
    nlohmann::json cases;        // stress: per case name, what makes it that case (triangles, lights' types)
    nlohmann::json technique;    // resolved, as the run wrote it (compare: {"engine": ...})
    nlohmann::json scoring;      // tolerance and visible threshold of the first light, when recorded
    std::vector<LightNumbers> lights;
};

// A run from a report.json or stress.json, or a folder holding one (report.json first).
// A missing, unreadable or malformed file is an InputError naming the file and what is wrong.
Run read_run(const std::filesystem::path& path);
// The same from parsed JSON; `file` names it in errors and locates the class maps.
Run parse_run(const nlohmann::json& doc, const std::filesystem::path& file);

struct ClassChange {
    std::uint64_t count_a = 0, count_b = 0;
    double rate_a = 0, rate_b = 0;  // of the basis: visible rates when both runs have them, else rates
    double change = 0;              // rate_b - rate_a
    bool worse = false;             // change > tolerance
};

struct LightChange {
    LightNumbers a, b;
    bool visible_basis = false;  // rates_visible compared (else rates)
    std::array<ClassChange, kClasses.size()> classes;
    bool identical = false;  // the light's objects are equal
    bool worse() const;
};

struct DiffResult {
    double tolerance = 0;
    std::vector<LightChange> lights;
    std::vector<std::string> worse_lines;  // one per light and class that got worse, naming both
    std::vector<std::string> warnings;     // e.g. the runs were scored with different tolerances
    bool identical() const;
    bool worse() const { return !worse_lines.empty(); }
};

// B against A. Runs of different scenarios (scene, camera, lights, image size; stress: cases)
// are an InputError naming what differs. B is worse when, for some light and class, the rate of
// wrong pixels (the visible ones when both runs counted them) rose by more than `tolerance`,
// an absolute fraction of scored pixels.
DiffResult diff_runs(const Run& a, const Run& b, double tolerance);

// diff.json.
nlohmann::json diff_json(const Run& a, const Run& b, const DiffResult& d);
// The terminal's table: per light, each class's counts and rates in A and B and the change.
std::string diff_table(const Run& a, const Run& b, const DiffResult& d);

}  // namespace penumbra::diff
