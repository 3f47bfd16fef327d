// Adaptive sampling of area lights (docs/oracle.md, "Area lights").
//
// Each pixel runs kReplicates independent replicates of the Sobol (0,2)-sequence, each under
// its own random digital shift (randomized QMC: every replicate is an unbiased estimate and
// keeps the sequence's stratification, so the spread of the replicate means is an honest
// error estimate; Owen 1997, L'Ecuyer & Lemieux 2002). Rays are traced in rounds of
// kRoundRays consecutive points of one replicate, the replicates taking turns.
// 1. Every lightable pixel traces one round (the first 16 points of replicate 0, a (0,4,2)-net).
// 2. Pixels within kDilation pixels of a mixed one (some rays blocked, some not) are refined:
//    all replicates grow, doubling, until the 95% half-width E is at or under the target or
//    the ray cap is reached. Refined pixels that come out mixed refine their own neighbours in
//    turn, so the region grows until it is ringed by pixels whose 128+ rays all agree: the
//    faint outer edge of a penumbra is found even where the first 16 rays missed it.
// 3. E is Student's t over the replicate means (kReplicates - 1 degrees of freedom), but never
//    under half a point of one replicate (0.5 / n) for a mixed pixel: stratified replicates of
//    a straight, light-aligned edge can all return the same count, whose spread (0) says
//    nothing about where between two counts the truth lies.
// 4. Pixels whose rays all agree keep that answer with E = 0: a presumption, not a bound (an
//    occluder hiding less than one stratum from a pixel and from all of its neighbours is
//    not seen). docs/oracle.md states it.
// Every pixel's sample pattern depends only on (seed, light, pixel, replicate), so the image is
// the same whatever the thread count and the order of the work.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

#include "oracle/tracer.h"

namespace penumbra::oracle_detail {

namespace {

constexpr int kDilation = 2;
constexpr int kReplicates = 8;

// One pixel's visible-ray counts per replicate (exact, integers).
struct ReplicateSums {
    int rounds = 0;
    std::array<std::int32_t, kReplicates> visible{};

    // Round r extends replicate r % kReplicates by its next kRoundRays points.
    int replicate_of(int round) const { return round % kReplicates; }
    int first_point_of(int round) const { return (round / kReplicates) * kRoundRays; }
    void add(int visible_rays) { visible[static_cast<std::size_t>(replicate_of(rounds++))] += visible_rays; }

    double mean() const {
        std::int64_t sum = 0;
        for (auto v : visible) sum += v;
        return rounds > 0 ? static_cast<double>(sum) / (static_cast<double>(rounds) * kRoundRays) : 0.0;
    }
    // The replicates are compared only at equal lengths; before that nothing is known (1).
    bool balanced() const { return rounds >= kReplicates && rounds % kReplicates == 0; }
    double half_width() const {
        if (!balanced()) return 1.0;
        const double n = static_cast<double>(rounds / kReplicates) * kRoundRays;  // points per replicate
        double mean = 0, sq = 0;
        for (auto v : visible) mean += v / n;
        mean /= kReplicates;
        for (auto v : visible) sq += (v / n - mean) * (v / n - mean);
        double var_of_mean = sq / (kReplicates - 1) / kReplicates;
        double e = student_t975(kReplicates - 1) * std::sqrt(var_of_mean);
        if (mixed()) e = std::max(e, 0.5 / n);  // the replicates' resolution (top of file, 3.)
        return std::min(1.0, e);
    }
    bool mixed() const {
        std::int64_t sum = 0;
        for (auto v : visible) sum += v;
        return sum > 0 && sum < static_cast<std::int64_t>(rounds) * kRoundRays;
    }
};

// Refinement stops are checked when every replicate holds a power-of-two prefix of the
// sequence (a complete net): 8, 16, 32, ... rounds.
bool at_net_boundary(int rounds) {
    if (rounds < kReplicates || rounds % kReplicates != 0) return false;
    int per = rounds / kReplicates;
    return (per & (per - 1)) == 0;
}

// Rays-per-pixel checkpoints of the convergence curve: the first bound, then doublings to the cap.
std::vector<int> checkpoints(int max_rays) {
    std::vector<int> c;
    for (int r = kReplicates * kRoundRays; r < max_rays; r *= 2) c.push_back(r);
    c.push_back(max_rays);
    return c;
}

}  // namespace

OracleAreaStats sample_area_light(const Tracer& tracer, OracleFrame& frame, std::size_t li,
                                  const std::vector<SurfacePoint>& surfaces, const OracleSettings& settings,
                                  TraceCounters& counters) {
    const int W = frame.width, H = frame.height;
    const std::size_t n = frame.pixel_count();
    const AreaLight& light = tracer.lights()[li].area;
    OracleLightImage& img = frame.lights[li];
    const bool uniform = settings.area_uniform_rays > 0;
    const int max_rounds = std::max(1, (uniform ? settings.area_uniform_rays : settings.area_max_rays) / kRoundRays);
    const std::vector<int> marks = checkpoints(max_rounds * kRoundRays);

    std::vector<ReplicateSums> sums(n);
    std::atomic<std::uint64_t> shadow{0}, retraced{0};

    auto view_at = [&](std::size_t i) { return view_area_light(light, surfaces[i].p, surfaces[i].n); };
    auto round_at = [&](std::size_t i, TraceCounters& c, const AreaView& view) {
        ReplicateSums& s = sums[i];
        const int r = s.rounds;
        const auto replicate = static_cast<std::uint64_t>(s.replicate_of(r));
        AreaRound round = tracer.trace_area_round(li, surfaces[i], view, s.first_point_of(r),
                                                  round_scramble(settings.seed, li, i, replicate), c);
        s.add(round.visible);
        img.occluder_m[i] = std::min(img.occluder_m[i], round.occluder_t);
    };

    // ---- 1. one round everywhere ----
    tbb::parallel_for(0, H, [&](int y) {
        TraceCounters c;
        for (int x = 0; x < W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * W + x;
            if (!surfaces[i].hit) continue;
            AreaView view = view_at(i);
            img.U[i] = view.inside ? 1.0f : 0.0f;
            img.lightable[i] = view.lightable ? 1.0f : 0.0f;
            if (view.lightable) round_at(i, c, view);
        }
        shadow += c.shadow;
        retraced += c.retraced;
    });

    // ---- 2. refinement in waves: each wave refines the unrefined neighbours of the mixed
    // pixels of the previous one; E after each checkpoint is kept for the convergence curve ----
    std::vector<std::uint8_t> refined(n, 0);
    std::vector<std::size_t> frontier;
    for (std::size_t i = 0; i < n; ++i)
        if (img.lightable[i] != 0 && (uniform || sums[i].mixed())) frontier.push_back(i);
    std::vector<double> curve_sum(marks.size(), 0.0), curve_max(marks.size(), 0.0);
    std::vector<std::uint64_t> curve_sampling(marks.size(), 0);
    while (!frontier.empty()) {
        std::vector<std::size_t> wave;
        const int reach = uniform ? 0 : kDilation;
        for (std::size_t f : frontier) {
            const int fx = static_cast<int>(f % W), fy = static_cast<int>(f / W);
            for (int y = std::max(0, fy - reach); y <= std::min(H - 1, fy + reach); ++y)
                for (int x = std::max(0, fx - reach); x <= std::min(W - 1, fx + reach); ++x) {
                    const std::size_t i = static_cast<std::size_t>(y) * W + x;
                    if (img.lightable[i] == 0 || refined[i]) continue;
                    refined[i] = 1;  // claimed by this wave
                    wave.push_back(i);
                }
        }
        std::sort(wave.begin(), wave.end());
        std::vector<float> wave_e(wave.size() * marks.size(), 0.0f);
        std::vector<std::uint8_t> reached(wave.size() * marks.size(), 0);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, wave.size(), 64), [&](const auto& r) {
            TraceCounters c;
            for (std::size_t w = r.begin(); w != r.end(); ++w) {
                const std::size_t i = wave[w];
                AreaView view = view_at(i);
                ReplicateSums& s = sums[i];
                std::size_t next_mark = 0;
                auto record = [&](bool traced) {  // checkpoints this pixel has reached
                    while (next_mark < marks.size() && (!traced || marks[next_mark] <= s.rounds * kRoundRays)) {
                        wave_e[w * marks.size() + next_mark] = static_cast<float>(s.half_width());
                        reached[w * marks.size() + next_mark] = traced;
                        ++next_mark;
                    }
                };
                while (s.rounds < max_rounds) {
                    if (!uniform && at_net_boundary(s.rounds) && s.half_width() <= settings.area_target) break;
                    round_at(i, c, view);
                    record(true);
                }
                record(false);  // later checkpoints keep the final bound
            }
            shadow += c.shadow;
            retraced += c.retraced;
        });
        frontier.clear();
        for (std::size_t w = 0; w < wave.size(); ++w) {
            if (sums[wave[w]].mixed()) frontier.push_back(wave[w]);
            for (std::size_t m = 0; m < marks.size(); ++m) {
                double e = wave_e[w * marks.size() + m];
                curve_sum[m] += e;
                curve_max[m] = std::max(curve_max[m], e);
                curve_sampling[m] += reached[w * marks.size() + m];
            }
        }
        if (uniform) break;
    }

    // ---- 3. the answer, and what it cost ----
    OracleAreaStats st;
    std::uint64_t lightable = 0, rounds_total = 0;
    for (std::size_t i = 0; i < n; ++i) {
        if (img.lightable[i] == 0) continue;
        ++lightable;
        const ReplicateSums& s = sums[i];
        img.V[i] = static_cast<float>(s.mean());
        // Agreeing pixels are presumed exact (top of file, 4.).
        img.E[i] = refined[i] && s.mixed() ? static_cast<float>(s.half_width()) : 0.0f;
        rounds_total += static_cast<std::uint64_t>(s.rounds);
        st.rays_per_pixel_max = std::max(st.rays_per_pixel_max, s.rounds * kRoundRays);
        if (refined[i]) {
            ++st.refined;
            st.capped += img.E[i] > settings.area_target;
        }
    }
    st.rays = shadow;
    st.rays_per_pixel_mean = lightable ? static_cast<double>(rounds_total) * kRoundRays / lightable : 0.0;
    for (std::size_t m = 0; m < marks.size(); ++m) {
        ConvergencePoint p;
        p.rays = marks[m];
        p.mean_e = st.refined ? curve_sum[m] / static_cast<double>(st.refined) : 0.0;
        p.max_e = curve_max[m];
        p.sampling = curve_sampling[m];
        st.convergence.push_back(p);
    }
    counters.shadow += shadow;
    counters.retraced += retraced;
    return st;
}

}  // namespace penumbra::oracle_detail
