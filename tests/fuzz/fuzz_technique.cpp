// libFuzzer target: a technique as the raster command builds it: a JSON file (--technique), or,
// when the input is not JSON, one --set assignment applied to an empty technique.
#include "common/json_reader.h"
#include "fuzz_support.h"
#include "raster/technique.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    const std::string text(reinterpret_cast<const char*>(data), size);
    fuzz::expect_input_errors_only([&] {
        nlohmann::json j;
        try {
            j = parse_json_strict(text, "technique.json");
        } catch (const InputError&) {
            // The command line refuses these --set values before this (set_assignment_problem).
            if (!set_assignment_problem(text).empty()) return;
            j = nlohmann::json::object();
            raster::apply_override(j, text);
        }
        raster::parse_technique(j, "technique.json");
    });
    return 0;
}
