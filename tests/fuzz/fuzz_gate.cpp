// libFuzzer target: a gate file (--gate) for a scenario with three lights: a directional, a
// point and a rect light, so that soft-only metrics are valid for one of them.
#include <vector>

#include "common/json_reader.h"
#include "fuzz_support.h"
#include "metrics/gate.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    static const std::vector<Light> lights = [] {
        std::vector<Light> l(3);
        l[0].type = LightType::directional;
        l[1].type = LightType::point;
        l[2].type = LightType::rect;
        return l;
    }();
    const std::string text(reinterpret_cast<const char*>(data), size);
    fuzz::expect_input_errors_only([&] {
        metrics::parse_gate(parse_json_strict(text, "gate.json"), "gate.json", lights, metrics::GateOrigin::file);
    });
    return 0;
}
