// libFuzzer target: a gate file (--gate) for a scenario with three lights.
#include "common/json_reader.h"
#include "fuzz_support.h"
#include "metrics/gate.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    const std::string text(reinterpret_cast<const char*>(data), size);
    fuzz::expect_input_errors_only([&] { metrics::parse_gate(parse_json_strict(text, "gate.json"), "gate.json", 3); });
    return 0;
}
