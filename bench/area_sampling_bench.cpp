// Adaptive against uniform sampling of area lights, at the same error bound.
//
// For each area light of the scenario (default: data/soft, at --width x --height), the oracle
// runs once adaptively and then uniformly (every lightable pixel the same number of rays,
// 128, 256, ... up to the cap). "The same bound" means: the uniform run must bring at least
// the same share of lightable pixels to E <= target as the adaptive run did. Prints rays,
// seconds and the share for each run, and the ratio of rays. A measurement, not a test.
#include <cstdio>
#include <string>

#include "common/scenario.h"
#include "common/stopwatch.h"
#include "oracle/oracle.h"

namespace {

using namespace penumbra;

struct Run {
    double share = 0;  // lightable pixels with E <= target
    std::uint64_t rays = 0, lightable = 0;
    double seconds = 0;
};

Run run(const Scenario& s, const OracleSettings& settings) {
    auto t0 = SteadyClock::now();
    OracleResult r = run_oracle(s, settings);
    Run out;
    out.seconds = seconds_since(t0);
    const OracleLightImage& img = r.frame.lights[0];
    std::uint64_t met = 0;
    for (std::size_t i = 0; i < img.E.size(); ++i) {
        if (img.lightable[i] == 0) continue;
        ++out.lightable;
        met += img.E[i] <= settings.area_target;
    }
    out.share = out.lightable ? static_cast<double>(met) / out.lightable : 1.0;
    out.rays = r.stats.lights[0].sampling.rays;
    return out;
}

std::string fmt_ratio(std::uint64_t uniform, std::uint64_t adaptive) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "  -> adaptive traces %.1fx fewer rays", static_cast<double>(uniform) / adaptive);
    return buf;
}

}  // namespace

int main(int argc, char** argv) {
    std::string file = std::string(PENUMBRA_SOURCE_DIR) + "/data/soft/scenario.json";
    int width = 320, height = 180, max_rays = 4096;
    for (int i = 1; i + 1 < argc; i += 2) {
        std::string a = argv[i];
        if (a == "--scenario") file = argv[i + 1];
        if (a == "--width") width = std::stoi(argv[i + 1]);
        if (a == "--height") height = std::stoi(argv[i + 1]);
        if (a == "--max-rays") max_rays = std::stoi(argv[i + 1]);
    }
    Scenario all = load_scenario(file);
    all.width = width;
    all.height = height;
    std::printf("%s at %dx%d, target E %.5f, cap %d rays/px\n", file.c_str(), width, height, 1.0 / 255, max_rays);
    for (std::size_t li = 0; li < all.lights.size(); ++li) {
        if (!is_area_light(all.lights[li].type)) continue;
        Scenario s = all;
        s.lights = {all.lights[li]};
        OracleSettings settings;
        settings.area_max_rays = max_rays;
        Run adaptive = run(s, settings);
        std::printf("light %zu (%s): adaptive  %12llu rays (%7.1f /px) %7.2f s, E <= target at %.4f of %llu px\n", li,
                    to_string(s.lights[0].type), static_cast<unsigned long long>(adaptive.rays),
                    static_cast<double>(adaptive.rays) / adaptive.lightable, adaptive.seconds, adaptive.share,
                    static_cast<unsigned long long>(adaptive.lightable));
        bool reached = false;
        for (int n = 128; n <= max_rays && !reached; n *= 2) {
            settings.area_uniform_rays = n;
            Run u = run(s, settings);
            reached = u.share >= adaptive.share;
            std::printf("  uniform %5d/px %12llu rays %7.2f s, E <= target at %.4f%s\n", n,
                        static_cast<unsigned long long>(u.rays), u.seconds, u.share,
                        reached ? fmt_ratio(u.rays, adaptive.rays).c_str() : "");
        }
        if (!reached) std::printf("  uniform sampling never matched the adaptive share within the cap\n");
    }
    return 0;
}
