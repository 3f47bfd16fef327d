// libFuzzer target: sweep's configurations as the command builds them, for a scene with a
// directional, a spot and a rect light. Input that is JSON is a --configs list; else each line
// is one --vary argument (the first may be a --shard K/N). Products beyond 256 configurations
// are only counted against the limit (expanding them is slow, not different).
#include <vector>

#include "common/json_reader.h"
#include "fuzz_support.h"
#include "sweep/sweep_table.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace penumbra;
    static const std::vector<Light> lights = [] {
        std::vector<Light> l(3);
        l[0].type = LightType::directional;
        l[1].type = LightType::spot;
        l[2].type = LightType::rect;
        return l;
    }();
    static const nlohmann::json base = {{"preset", "d3d12-textbook"}, {"resolution", 512}};
    const std::string text(reinterpret_cast<const char*>(data), size);
    fuzz::expect_input_errors_only([&] {
        std::optional<nlohmann::json> list;
        try {
            list = parse_json_strict(text, "configs.json");
        } catch (const InputError&) {
        }
        if (list) {
            if (list->is_array() && list->size() > 256 && list->size() <= sweep::kMaxConfigurations) return;
            sweep::configs_from_json(*list, "configs.json", base, lights);
            return;
        }
        std::vector<sweep::Axis> axes;
        sweep::Shard shard;
        std::size_t start = 0;
        for (bool first = true;; first = false) {
            const std::size_t end = text.find('\n', start);
            const std::string line = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
            if (first && line.rfind("shard ", 0) == 0)
                shard = sweep::parse_shard(line.substr(6));
            else
                axes.push_back(sweep::parse_axis(line));
            if (end == std::string::npos) break;
            start = end + 1;
        }
        sweep::check_axes(axes);
        const std::size_t n = sweep::product_size(axes);
        sweep::check_configuration_count(n, "--vary");
        if (n > 256) return;
        const auto configs = sweep::expand(base, axes, lights);
        const std::size_t in_run = sweep::shard_size(configs.size(), shard);
        sweep::check_work(configs.size(), in_run, 3, lights.size(), 1ull << 30, "--vary");
    });
    return 0;
}
