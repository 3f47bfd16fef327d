// The stress suite's generated scenes (docs/stress.md): stiff and extreme cases, each with the
// canonical version the oracle's verdict is checked against. Generated in code, seeded, so every
// run judges the same triangles.
#pragma once

#include <cstdint>
#include <glm/mat3x3.hpp>
#include <string>
#include <vector>

#include "common/scenario.h"

namespace penumbra::stress {

struct CaseOptions {
    int width = 160, height = 120;  // image of every case; small images show every effect of the suite
    std::uint64_t seed = 20;        // random parts (needles, terrain)
};

// One case: the stiff scenario the technique is judged on, and its canonical version, the same
// scene in another frame (docs/stress.md, "The oracle invariant"): the camera sees the same image
// in both, so outside uncertain pixels the oracle must give the same visibility.
struct StressCase {
    std::string name;       // "far_1e7"
    std::string group;      // "far_from_origin"
    std::string stresses;   // one line: what it stresses
    std::string canonical;  // how the canonical version maps to the case ("at the origin, scale 1")
    Scenario scenario;      // the stiff case as a user meets it
    Scenario reference;     // its canonical version
    // The technique is also judged on the canonical version (far and scale cases: where the
    // technique's rates explode is the difference).
    bool judge_reference = false;
};

// Every case's name, in suite order.
std::vector<std::string> case_names();

// The cases named (all when `names` is empty), in suite order; InputError naming `label` and
// the valid names for an unknown one.
std::vector<StressCase> make_cases(const std::vector<std::string>& names, const CaseOptions& options,
                                   const std::string& label = "--cases");

// x -> s R x + t applied to everything positional in the scenario (camera, lights, triangles,
// depth range): the image the camera sees is unchanged.
Scenario transformed(Scenario scenario, double scale, const glm::dmat3& rotation, const glm::dvec3& translation);

}  // namespace penumbra::stress
