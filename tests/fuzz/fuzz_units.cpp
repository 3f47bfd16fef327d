// libFuzzer target: `penumbra units`' arguments (#50). The first two bytes pick the --from and
// --to engines, the next six the map the conversion is made for (texel, depth scale, depth range,
// the format's r, the reference angle and a cascade); the rest is one argument per line, a line
// starting with '@' an --assume. Bad arguments end as InputError; a conversion that succeeds
// with finite values (what the command prints; it refuses the others) gives back the clearance
// it was asked for: A -> B is exact at the reference angle (engines/engine_units.h).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "engines/engine_units.h"
#include "fuzz_support.h"

namespace {

using namespace penumbra;

// A value in [10^lo, 10^hi] from one byte, log-spaced: the contexts penumbra's fit makes.
double log_scale(std::uint8_t b, double lo, double hi) {
    return std::pow(10.0, lo + (hi - lo) * b / 255.0);
}

bool all_finite(const nlohmann::json& j) {
    if (j.is_number()) return std::isfinite(j.get<double>());
    if (j.is_object() || j.is_array()) {
        for (const auto& v : j)
            if (!all_finite(v)) return false;
    }
    return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::vector<std::string>& names = engines::engine_names();
    if (size < 8) return 0;
    const std::string from_engine = names[data[0] % names.size()], to_engine = names[data[1] % names.size()];
    engines::MapContext c;
    c.texel_m = log_scale(data[2], -6, 3);
    c.metres_per_depth = log_scale(data[3], -3, 6);
    c.depth_range_m = c.metres_per_depth;
    c.depth_r = log_scale(data[4], -10, -3);
    c.angle_rad = data[5] / 255.0 * 89.0 * 3.14159265358979323846 / 180.0;
    if (data[6] & 1) {
        c.cascade = data[6] >> 5;
        c.split_near = log_scale(data[7], -2, 2);
        c.split_far = c.split_near * (2 + (data[6] >> 1 & 15));
    }
    std::vector<std::string> values, assume;
    std::string line;
    for (std::size_t i = 8; i <= size; ++i) {
        if (i == size || data[i] == '\n') {
            if (!line.empty()) (line[0] == '@' ? assume : values).push_back(line[0] == '@' ? line.substr(1) : line);
            line.clear();
        } else {
            line += static_cast<char>(data[i]);
        }
    }
    fuzz::expect_input_errors_only([&] {
        const engines::EngineBias from = engines::parse_engine_bias(from_engine, values, "--from " + from_engine);
        const nlohmann::json to_assumptions =
            engines::parse_engine_bias(to_engine, assume, "--assume", true).assumptions;
        const engines::EngineBias to = engines::convert(from, to_engine, c, to_assumptions);
        const engines::Clearance asked = engines::clearance(from, c);
        if (!all_finite(to.values) || !std::isfinite(asked.total())) return;  // the command refuses these
        if (to_engine == "penumbra") return;  // technique keys, checked by the units tests
        const engines::Clearance got = engines::clearance(to, c);
        // The fixed terms of the --to engine (its free parameters at 0) are cancelled by them: the
        // rounding is relative to both.
        engines::EngineBias zero = to;
        for (auto& v : zero.values)
            if (v.is_number()) v = 0.0;
        const engines::Clearance fixed = engines::clearance(zero, c);
        const double scale = std::abs(asked.constant_m) + std::abs(asked.angular_m) + std::abs(fixed.constant_m) +
                             std::abs(fixed.angular_m);
        if (!(std::abs(got.total() - asked.total()) <= 1e-6 * scale + 1e-300)) {
            std::fprintf(stderr, "%s %s -> %s %s: clearance %.17g asked, %.17g given back\n", from_engine.c_str(),
                         from.values.dump().c_str(), to_engine.c_str(), to.values.dump().c_str(), asked.total(),
                         got.total());
            std::abort();
        }
    });
    return 0;
}
