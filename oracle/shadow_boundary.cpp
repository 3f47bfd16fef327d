// Distance from each receiver point to the nearest true shadow boundary, measured across the
// light direction (the metric of a shadow-map texel footprint), independent of any shadow-map
// resolution.
//
// 1. Every pair of 4-adjacent pixels on one plane whose verdicts differ brackets a boundary.
//    It is placed exactly where the segment between their surface points leaves the shadow of
//    the occluder triangles met from its shadowed end, confirmed by an exact shadow ray just
//    past it (locate_on_plane); where that cannot conclude, bisection with exact shadow rays
//    places it to 2^-steps of a pixel footprint.
// 2. The located boundary points are filed in a grid over a chart of the light's rays (a
//    directional light's rays by their foot on a plane across them, a point light's by their
//    direction), where the light-lateral distance from a point to a pixel is the distance from
//    the point to the pixel's ray. Two raster sweeps over that grid (a vector distance
//    transform, Danielsson 1980) give each cell the point nearest to its centre's ray; a pixel
//    takes the nearest of its own and the eight surrounding cells' points and of the points
//    filed in them, then walks along the boundary from there, or, in a cell too crowded to list
//    them all, searches a k-d tree of the chart's points from there (nearest_in_chart). A point
//    light whose rays spread too wide for one chart gets one per face of a cube around it, and
//    then the same sweeps over the image, for the pixels whose face sees no boundary point.
// Boundaries that no pixel pair straddles (hidden from the camera, or lying exactly on a
// silhouette) are not seen; pixels farther from every seen boundary report inf.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <glm/geometric.hpp>
#include <limits>
#include <optional>
#include <vector>

#include "common/stopwatch.h"
#include "oracle/tracer.h"

namespace penumbra::oracle_detail {

namespace {

// Squared distance from p to b in the plane perpendicular to the light direction at p.
double lateral_distance2(const glm::dvec3& p, const glm::dvec3& to_light, const glm::dvec3& b) {
    glm::dvec3 d = b - p;
    double along = glm::dot(d, to_light);
    return std::max(0.0, glm::dot(d, d) - along * along);
}

bool same_plane(const Tracer& tr, std::uint32_t a, std::uint32_t b) {
    if (a == b) return true;
    glm::dvec3 na = glm::normalize(tr.normal_ccw(a)), nb = glm::normalize(tr.normal_ccw(b));
    if (std::abs(glm::dot(na, nb)) < 1.0 - 1e-12) return false;
    double scale = glm::length(tr.vertex(a, 0)) + glm::length(tr.vertex(b, 0));
    return std::abs(glm::dot(na, tr.vertex(b, 0) - tr.vertex(a, 0))) <= 1e-12 * std::max(scale, 1e-300);
}

// The light's rays as points of a plane. A directional light's ray through p is its foot on the
// plane through the origin perpendicular to the light; a point light's, the gnomonic projection
// of its direction onto the plane at unit distance along `axis` (their mean direction, or a cube
// face's), which holds only directions less than ~75 degrees from it. A face's chart owns the
// pixels whose direction from the light lies in that face of the cube around it.
struct RayChart {
    bool directional = true;
    glm::dvec3 origin{0.0}, axis{0.0}, e1{0.0}, e2{0.0};
    int face = -1;  // 0..5: +x, -x, +y, -y, +z, -z; -1: every pixel

    bool owns(const glm::dvec3& p) const {
        if (face < 0) return true;
        const glm::dvec3 d = p - origin, m = glm::abs(d);
        const int k = m.x >= m.y && m.x >= m.z ? 0 : (m.y >= m.z ? 1 : 2);
        return 2 * k + (d[k] < 0) == face;
    }

    static constexpr double kMinAxisCos = 0.25;  // the widest direction charted: about 75 degrees

    bool map(const glm::dvec3& p, glm::dvec2& uv) const {
        if (directional) {
            uv = {glm::dot(p, e1), glm::dot(p, e2)};
            return true;
        }
        const glm::dvec3 d = p - origin;
        const double a = glm::dot(d, axis);
        if (!(a > kMinAxisCos * glm::length(d))) return false;
        uv = {glm::dot(d, e1) / a, glm::dot(d, e2) / a};
        return true;
    }
    // A point light's unit ray direction at chart point uv.
    glm::dvec3 ray_direction(const glm::dvec2& uv) const { return glm::normalize(axis + uv.x * e1 + uv.y * e2); }
};

// Two unit vectors completing unit n to an orthonormal basis (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited", JCGT 6(1)).
void complete_basis(const glm::dvec3& n, glm::dvec3& b1, glm::dvec3& b2) {
    const double sign = std::copysign(1.0, n.z), a = -1.0 / (sign + n.z), b = n.x * n.y * a;
    b1 = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    b2 = {b, sign + n.y * n.y * a, -n.y};
}

// The charts for the light's rays through the lightable pixels: one, or, for a point light whose
// rays towards them spread too wide for one, the six faces of a cube around it.
std::vector<RayChart> charts_for(const LocalLight& light, const OracleFrame& frame, const OracleLightImage& img) {
    RayChart c;
    if (light.type == LightType::directional) {
        c.axis = light.to_light;
        complete_basis(c.axis, c.e1, c.e2);
        return {c};
    }
    c.directional = false;
    c.origin = light.position;
    glm::dvec3 sum(0.0);
    for (std::size_t i = 0; i < frame.pixel_count(); ++i)
        if (img.lightable[i] != 0) sum += glm::normalize(glm::dvec3(frame.P[i]) - c.origin);
    bool one = glm::length(sum) > 0;
    if (one) {
        c.axis = glm::normalize(sum);
        complete_basis(c.axis, c.e1, c.e2);
        glm::dvec2 uv;
        for (std::size_t i = 0; i < frame.pixel_count() && one; ++i)
            one = img.lightable[i] == 0 || c.map(glm::dvec3(frame.P[i]), uv);
    }
    if (one) return {c};
    std::vector<RayChart> faces(6, c);
    for (int f = 0; f < 6; ++f) {
        faces[f].face = f;
        faces[f].axis = glm::dvec3(0.0);
        faces[f].axis[f / 2] = f % 2 ? -1.0 : 1.0;
        complete_basis(faces[f].axis, faces[f].e1, faces[f].e2);
    }
    return faces;
}

// A uniform grid of square cells over a rectangle of the chart.
struct ChartGrid {
    glm::dvec2 lo{0.0};
    double cell = 1;
    int nx = 1, ny = 1;

    std::size_t size() const { return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny); }
    std::size_t index(int x, int y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(x);
    }
    glm::ivec2 xy(std::size_t k) const {
        return {static_cast<int>(k % static_cast<std::size_t>(nx)), static_cast<int>(k / static_cast<std::size_t>(nx))};
    }
    glm::ivec2 cell_of(const glm::dvec2& uv) const {
        const glm::dvec2 f = (uv - lo) / cell;
        return {static_cast<int>(std::clamp(std::floor(f.x), 0.0, nx - 1.0)),
                static_cast<int>(std::clamp(std::floor(f.y), 0.0, ny - 1.0))};
    }
    glm::dvec2 centre(int x, int y) const { return lo + cell * glm::dvec2(x + 0.5, y + 0.5); }
};

// The walk along a boundary's points at each pixel (nearest_in_chart): each point's neighbours,
// and the most steps taken.
constexpr std::size_t kNeighbours = 6;
constexpr int kMaxWalkSteps = 64;
// Candidates a cell keeps at most (nearest_in_chart).
constexpr std::size_t kMaxCandidates = 48;

// A k-d tree over the boundary points a chart holds, keyed by their chart point (a directional
// light's, z = 0) or their position (a point light's), for the pixels of crowded cells: there a
// cell's candidates are cut to the kMaxCandidates nearest to its centre, and the walk along the
// boundary from the best of them keeps to one boundary where several run side by side (thin
// shadows seen from near the ground, docs/oracle.md section 6), so those pixels search the tree
// instead, from the best candidate, which is exact.
class SeedTree {
  public:
    SeedTree(std::vector<int> points, const std::vector<glm::dvec3>& keys) : order_(std::move(points)) {
        if (order_.empty()) return;
        nodes_.reserve(4 * order_.size() / kLeafPoints + 1);
        nodes_.resize(1);
        build(keys, 0, 0, static_cast<std::uint32_t>(order_.size()));
    }

    // Improves (cur, cur_d2) to the nearest point by measure(s), visiting only the nodes whose box
    // bound(lo, hi), a lower bound of the measure of any point in it, is below the nearest so far.
    template <typename Measure, typename Bound>
    void nearest(const Measure& measure, const Bound& bound, int& cur, double& cur_d2) const {
        if (nodes_.empty()) return;
        std::array<std::uint32_t, 64> stack;
        std::size_t top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& node = nodes_[stack[--top]];
            if (!(bound(node.lo, node.hi) < cur_d2)) continue;
            if (node.left == 0) {
                for (std::uint32_t f = node.begin; f != node.end; ++f) {
                    const double d2 = measure(order_[f]);
                    if (d2 < cur_d2) {
                        cur_d2 = d2;
                        cur = order_[f];
                    }
                }
                continue;
            }
            // The nearer child last, so that it is searched first.
            const Node &a = nodes_[node.left], &b = nodes_[node.left + 1];
            const bool a_first = bound(a.lo, a.hi) <= bound(b.lo, b.hi);
            stack[top++] = a_first ? node.left + 1 : node.left;
            stack[top++] = a_first ? node.left : node.left + 1;
        }
    }

  private:
    struct Node {
        glm::dvec3 lo, hi;
        std::uint32_t begin, end;
        std::uint32_t left = 0;  // its children are left and left + 1; 0: a leaf
    };
    static constexpr std::uint32_t kLeafPoints = 8;

    // Node `index` over order_[begin, end), split at the median of its box's longest side; its
    // children take the next two free slots. Depth is at most log2(points / kLeafPoints) + 2, so
    // the search's stack of 64 holds it.
    void build(const std::vector<glm::dvec3>& keys, std::uint32_t index, std::uint32_t begin, std::uint32_t end) {
        glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
        for (std::uint32_t f = begin; f != end; ++f) {
            lo = glm::min(lo, keys[static_cast<std::size_t>(order_[f])]);
            hi = glm::max(hi, keys[static_cast<std::size_t>(order_[f])]);
        }
        nodes_[index] = {lo, hi, begin, end};
        if (end - begin <= kLeafPoints) return;
        const glm::dvec3 extent = hi - lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        const std::uint32_t mid = begin + (end - begin) / 2;
        // Ties by index: the tree, and so the search's order, is the same on every run.
        std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end, [&](int a, int b) {
            const double ka = keys[static_cast<std::size_t>(a)][axis], kb = keys[static_cast<std::size_t>(b)][axis];
            return ka < kb || (ka == kb && a < b);
        });
        const auto left = static_cast<std::uint32_t>(nodes_.size());
        nodes_[index].left = left;
        nodes_.resize(left + 2);
        build(keys, left, begin, mid);
        build(keys, left + 1, mid, end);
    }

    std::vector<int> order_;
    std::vector<Node> nodes_;
};

// Cells about kCellsPerPoint per chart point of a lightable pixel, over their bounding box.
ChartGrid grid_over(const glm::dvec2& lo, const glm::dvec2& hi, std::size_t points) {
    constexpr double kCellsPerPoint = 1.0 / 16;
    ChartGrid g;
    g.lo = lo;
    const glm::dvec2 extent = hi - lo;
    if (!std::isfinite(extent.x) || !std::isfinite(extent.y)) return g;  // overflowed: one cell
    const double cells = std::max(1.0, kCellsPerPoint * static_cast<double>(points));
    // Square cells filling the box; a box thin in one direction gets at most `cells` along the other.
    double side = std::sqrt(extent.x * extent.y / cells);
    side = std::max(side, std::max(extent.x, extent.y) / cells);
    if (!(side > 0) || !std::isfinite(side)) side = 1;
    g.cell = side;
    g.nx = static_cast<int>(std::min(extent.x / side, cells)) + 1;
    g.ny = static_cast<int>(std::min(extent.y / side, cells)) + 1;
    return g;
}

// Where the segment from `from` to `to` leaves the shadow that triangle `prim` casts, as a
// fraction s of the way, `from` being in that shadow. Each edge of the triangle and the light
// span a plane (the edge and the light's direction, or the edge and the light's position); the
// triangle's shadow is the side of all three planes that holds the opposite vertex, and each
// side is a half-line of s. NaN when `from` is not inside, when the whole segment is, or when
// the triangle is not between the segment and the light.
double shadow_exit(const Tracer& tr, const LocalLight& light, std::uint32_t prim, const glm::dvec3& from,
                   const glm::dvec3& to) {
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    const bool directional = light.type == LightType::directional;
    double exit = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
        const glm::dvec3 &e0 = tr.vertex(prim, k), &e1 = tr.vertex(prim, (k + 1) % 3),
                         &opposite = tr.vertex(prim, (k + 2) % 3);
        const glm::dvec3 anchor = directional ? e0 : light.position;
        const glm::dvec3 c = directional ? glm::cross(e1 - e0, light.to_light) : glm::cross(e0 - anchor, e1 - anchor);
        const double side = glm::dot(opposite - anchor, c);
        if (!(side != 0)) return kNaN;  // the triangle is seen edge-on from the light
        const double g0 = glm::dot(from - anchor, c) * side, g1 = glm::dot(to - anchor, c) * side;
        if (!(g0 >= 0)) return kNaN;
        if (g1 < 0) exit = std::min(exit, g0 / (g0 - g1));
    }
    if (!(exit <= 1)) return kNaN;
    // In front: the ray from the exit point meets the triangle's plane between the point and the light.
    const glm::dvec3 q = from + exit * (to - from), n = tr.normal_ccw(prim);
    const double ahead = glm::dot(tr.vertex(prim, 0) - q, n);
    const double along = glm::dot(directional ? light.to_light : light.position - q, n);
    const double t = ahead / along;
    if (!(t > 0) || (!directional && !(t < 1))) return kNaN;
    return exit;
}

// Occluder triangles walked before falling back to bisection. Near a tessellated silhouette the
// triangles' shadows are slivers: on a field of 48x25-segment spheres, 12% of walks end at the
// first triangle, 85% within four, 99.4% within sixteen.
constexpr int kMaxWalk = 16;

// The boundary point between two pixels on one plane whose verdicts differ: a (verdict va)
// and b. Both are projected onto the exact plane of triangle `prim` in double.
//
// Where the ray from the shadowed end meets an occluder, the shadow of that triangle is exact
// geometry: the boundary is where the segment leaves it (shadow_exit), unless another
// triangle's shadow continues it. A verified ray a little past the exit says which: lit, the
// exit is the boundary; shadowed, the walk goes on from there with the triangle that ray met.
// "A little" is twice how far the verifying ray's float path may lie from the exact one, mapped
// onto the receiver, and not below the bisection's own resolution: the exit is exact, but a
// sliver of shadow thinner than that beyond it goes unseen (docs/oracle.md section 6). Two rays
// place most boundaries, where bisection takes `steps`; where the walk cannot conclude (no
// occluder met, kMaxWalk triangles walked, that distance above an eighth of the segment) the
// segment is bisected, as before.
glm::dvec3 locate_on_plane(const Tracer& tr, const LocalLight& light, std::uint32_t prim, glm::dvec3 a, glm::dvec3 b,
                           float va, int steps, std::uint64_t& rays) {
    const glm::dvec3 n = glm::normalize(tr.normal_ccw(prim));
    const glm::dvec3& v0 = tr.vertex(prim, 0);
    auto on_plane = [&](const glm::dvec3& q) { return q - glm::dot(q - v0, n) * n; };
    const glm::dvec3 n_lit = glm::dot(n, direction_to_light(light, a)) > 0 ? n : -n;
    const glm::dvec3 vabs =
        glm::max(glm::abs(tr.vertex(prim, 0)), glm::max(glm::abs(tr.vertex(prim, 1)), glm::abs(tr.vertex(prim, 2))));
    // The verdict at a point of the plane (1 lit, 0 shadowed), as the trace would judge it there.
    auto verdict = [&](const glm::dvec3& p, std::uint32_t* occluder) {
        SurfacePoint m;
        m.hit = true;
        m.p = p;
        m.n = n_lit;
        m.error = robust::surface_error_bound(m.p, vabs);
        ShadowSetup setup;
        setup_shadow(light, m, setup);
        if (!setup.lightable) return 0.0f;
        ++rays;
        const ShadowAnswer ans = tr.trace_shadow_verified(setup, m.p, kNoPrimitive);
        if (occluder) *occluder = ans.occluder;
        return ans.blocked ? 0.0f : 1.0f;
    };
    a = on_plane(a);
    b = on_plane(b);

    // ---- the walk over the occluders' shadow edges ----
    const glm::dvec3& lit = va == 0 ? b : a;
    glm::dvec3 from = va == 0 ? a : b;
    std::uint32_t occluder = kNoPrimitive;
    // A cut-out's shadow ends where its coverage does, inside its triangles: bisected.
    if (verdict(from, &occluder) == 0 && occluder != kNoPrimitive && !tr.is_cutout(occluder)) {
        const double segment = glm::length(lit - from);
        for (int walked = 0; walked < kMaxWalk; ++walked) {
            const double s = shadow_exit(tr, light, occluder, from, lit);
            if (!(s >= 0)) break;
            const glm::dvec3 exit = on_plane(from + s * (lit - from));
            const glm::dvec3 to_light = direction_to_light(light, exit);
            const double cos_nl = glm::dot(n_lit, to_light);
            if (!(cos_nl > 0)) break;
            // How far the verifying ray's float path may lie from the exact ray, on the receiver:
            // its origin is lifted off the plane by the error bound (docs/oracle.md section 3)
            // and rounded, the occluder's vertices are rounded (magnified by a point light's
            // projection), and a displacement across the light lands on the plane stretched by
            // 1 / cos.
            double magnification = 1;
            if (light.type != LightType::directional) {
                const glm::dvec3 no = tr.normal_ccw(occluder);
                const double to_occluder = glm::dot(tr.vertex(occluder, 0) - exit, no) / glm::dot(to_light, no);
                const double to_light_m = glm::length(light.position - exit);
                magnification = to_light_m / std::max(to_light_m - to_occluder, 1e-300);
            }
            double vmax = 0;
            for (int k = 0; k < 3; ++k) vmax = std::max(vmax, glm::length(tr.vertex(occluder, k)));
            const double lift = glm::dot(glm::abs(n_lit), robust::surface_error_bound(exit, vabs));
            constexpr double kRound = 2 * 1.7320508075688772 * robust::kFloatEps;  // 2 sqrt(3) eps
            const double fuzz = (lift + kRound * (glm::length(exit) + vmax * magnification)) / cos_nl;
            const double past = std::max(2 * fuzz, std::ldexp(segment, -steps));
            const double remaining = glm::length(lit - exit);
            if (!(past <= segment / 8) || !(past < remaining)) break;
            const glm::dvec3 probe = on_plane(exit + (past / remaining) * (lit - exit));
            std::uint32_t next = kNoPrimitive;
            if (verdict(probe, &next) == 1) return exit;
            if (next == kNoPrimitive || tr.is_cutout(next)) break;
            from = probe;
            occluder = next;
        }
    }

    // ---- bisection ----
    for (int s = 0; s < steps; ++s) {
        const glm::dvec3 m = on_plane(0.5 * (a + b));
        (verdict(m, nullptr) == va ? a : b) = m;
    }
    return 0.5 * (a + b);
}

// The sweeps of nearest_sweeps (below) in one band, reading the row before by its index: run
// through the banded visit, which takes it by a pointer, one band was 1.3-1.6 times slower
// (0.014-0.016 against 0.011-0.012 s on field32 at 1 thread on the device).
template <typename Skip, typename At>
void serial_sweeps(int W, int H, std::vector<int>& nearest, std::vector<double>& best, Skip skip, At at) {
    auto visit = [&](int x, int y, std::initializer_list<glm::ivec2> offsets) {
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(W) + static_cast<std::size_t>(x);
        if (skip(i)) return;
        int cur = nearest[i];
        double cur_d2 = best[i];
        std::optional<decltype(at(x, y))> measure;
        for (const glm::ivec2& o : offsets) {
            const int xn = x + o.x, yn = y + o.y;
            if (xn < 0 || yn < 0 || xn >= W || yn >= H) continue;
            const int s =
                nearest[static_cast<std::size_t>(yn) * static_cast<std::size_t>(W) + static_cast<std::size_t>(xn)];
            if (s < 0 || s == cur) continue;
            if (!measure) measure.emplace(at(x, y));
            const double d2 = (*measure)(s);
            if (d2 < cur_d2) {
                cur_d2 = d2;
                cur = s;
            }
        }
        nearest[i] = cur;
        best[i] = cur_d2;
    };
    for (int y = 0; y < H; ++y) {
        for (int x = 0; x < W; ++x) visit(x, y, {{-1, 0}, {-1, -1}, {0, -1}, {1, -1}});
        for (int x = W - 1; x >= 0; --x) visit(x, y, {{1, 0}});
    }
    for (int y = H - 1; y >= 0; --y) {
        for (int x = W - 1; x >= 0; --x) visit(x, y, {{1, 0}, {1, 1}, {0, 1}, {-1, 1}});
        for (int x = 0; x < W; ++x) visit(x, y, {{-1, 0}});
    }
}

// Danielsson's vector distance transform (1980) over a W x H grid of cells holding point
// indices, in the 8SSEDT order (Leymarie and Levine 1992): rows downwards, each taking the
// nearest of its own and its neighbours' points from the left and the row above, then from the
// right; then rows upwards, the mirror image. Without the second pass along each row a point
// cannot travel more sideways than up or down within a sweep. at(x, y) prepares the measure of
// cell (x, y), a function of a point index giving its squared distance, once, at the cell's
// first candidate.
//
// Each half is serial in its rows (a row's result depends on the whole row before it), yet a
// row's result depends on nothing else than its own cells and the row before it. So the rows are
// cut into bands swept side by side, each starting from the row before it as it stood before the
// half; then each band's rows are swept again from the last row of the band before (side by side,
// that row as the first sweep left it) until one comes out as it stands: from there on the band's
// rows follow from it. Where a band's redo changed its own last row, the next band is redone from
// the true one, in order. The result is the serial sweep's whatever the number of bands; where
// the values come from nearby points, each band redoes a few rows.
template <typename Skip, typename At>
void nearest_sweeps(int W, int H, std::vector<int>& nearest, std::vector<double>& best, Skip skip, At at) {
    const auto w = static_cast<std::size_t>(W);
    // Cell (x, y) from its neighbours' points; `prev` is the row swept before row y (nullptr at
    // the grid's edge), which the offsets name by their non-zero y.
    auto visit = [&](int x, int y, const int* prev, std::initializer_list<glm::ivec2> offsets) {
        const std::size_t i = static_cast<std::size_t>(y) * w + static_cast<std::size_t>(x);
        if (skip(i)) return;
        int cur = nearest[i];
        double cur_d2 = best[i];
        std::optional<decltype(at(x, y))> measure;
        for (const glm::ivec2& o : offsets) {
            const int xn = x + o.x;
            if (xn < 0 || xn >= W || (o.y != 0 && prev == nullptr)) continue;
            const int s = o.y != 0 ? prev[xn] : nearest[static_cast<std::size_t>(y) * w + static_cast<std::size_t>(xn)];
            if (s < 0 || s == cur) continue;
            if (!measure) measure.emplace(at(x, y));
            const double d2 = (*measure)(s);
            if (d2 < cur_d2) {
                cur_d2 = d2;
                cur = s;
            }
        }
        nearest[i] = cur;
        best[i] = cur_d2;
    };
    // Row y of the downward (dy = 1) or upward (dy = -1) half.
    auto sweep_row = [&](int y, int dy, const int* prev) {
        if (dy > 0) {
            for (int x = 0; x < W; ++x) visit(x, y, prev, {{-1, 0}, {-1, -1}, {0, -1}, {1, -1}});
            for (int x = W - 1; x >= 0; --x) visit(x, y, prev, {{1, 0}});
        } else {
            for (int x = W - 1; x >= 0; --x) visit(x, y, prev, {{1, 0}, {1, 1}, {0, 1}, {-1, 1}});
            for (int x = 0; x < W; ++x) visit(x, y, prev, {{-1, 0}});
        }
    };
    auto row_of = [&](std::vector<int>& v, int y) { return v.data() + static_cast<std::size_t>(y) * w; };
    // As many bands as the threads allowed (`--threads`), even beyond the cores: the result is the
    // same. Below four threads, the serial loop: two bands were slower than it on the 2-core
    // development VM (0.05 against 0.03 s on the sphere field at 1024^2).
    const auto threads =
        static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    constexpr int kMinBandRows = 16, kMinBandThreads = 4;
    const int bands = threads < kMinBandThreads ? 1 : std::clamp(std::min(threads, H / kMinBandRows), 1, H);
    if (bands == 1) return serial_sweeps(W, H, nearest, best, skip, at);
    const std::size_t band_cells = static_cast<std::size_t>(bands) * w;
    std::vector<int> before_nearest(nearest.size()), edges(band_cells), kept_nearest(band_cells);
    std::vector<double> before_best(best.size()), kept_best(band_cells);
    for (const int dy : {1, -1}) {
        // The k-th row of the half in its order; row_of(k - 1) is the row swept before it.
        auto y_of = [&](int k) { return dy > 0 ? k : H - 1 - k; };
        auto band_begin = [&](int b) { return static_cast<int>(static_cast<long>(H) * b / bands); };
        auto edge = [&](int b) { return edges.data() + static_cast<std::size_t>(b) * w; };
        auto last_row_before = [&](int b) { return row_of(nearest, y_of(band_begin(b) - 1)); };
        for (int b = 1; b < bands; ++b) std::copy_n(last_row_before(b), W, edge(b));
        // Each band from the row before it as it stood before the half.
        tbb::parallel_for(0, bands, [&](int b) {
            for (int k = band_begin(b); k < band_begin(b + 1); ++k) {
                const auto row = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(y_of(k)) * w);
                if (b > 0) {
                    std::copy_n(nearest.begin() + row, W, before_nearest.begin() + row);
                    std::copy_n(best.begin() + row, W, before_best.begin() + row);
                }
                sweep_row(y_of(k), dy, k > band_begin(b) ? row_of(nearest, y_of(k - 1)) : b > 0 ? edge(b) : nullptr);
            }
        });
        // Band b's rows again from `prev` (the row before the band), each from its values before
        // the half, until one comes out as it stands: the rows after it follow from it as they are.
        auto again = [&](int b, const int* prev) {
            int* kept_n = kept_nearest.data() + static_cast<std::size_t>(b) * w;
            double* kept_b = kept_best.data() + static_cast<std::size_t>(b) * w;
            for (int k = band_begin(b); k < band_begin(b + 1); ++k) {
                const auto row = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(y_of(k)) * w);
                std::copy_n(nearest.begin() + row, W, kept_n);
                std::copy_n(best.begin() + row, W, kept_b);
                std::copy_n(before_nearest.begin() + row, W, nearest.begin() + row);
                std::copy_n(before_best.begin() + row, W, best.begin() + row);
                sweep_row(y_of(k), dy, k > band_begin(b) ? row_of(nearest, y_of(k - 1)) : prev);
                if (std::equal(kept_n, kept_n + W, nearest.begin() + row) &&
                    std::memcmp(kept_b, best.data() + row, w * sizeof(double)) == 0)
                    return;
            }
        };
        // Side by side, each band from the last row of the band before as its first sweep left it;
        // then, in order, again from the true one where that band's own redo reached its last row
        // and changed it.
        for (int b = 1; b < bands; ++b) std::copy_n(last_row_before(b), W, edge(b));
        tbb::parallel_for(1, bands, [&](int b) { again(b, edge(b)); });
        for (int b = 2; b < bands; ++b)
            if (!std::equal(edge(b), edge(b) + W, last_row_before(b))) again(b, last_row_before(b));
    }
}

// The nearest boundary point of every lightable pixel, through a grid over the light's rays
// (docs/oracle.md section 6): each cell's nearest point to its centre's ray by the sweeps, then
// each pixel's nearest among its own and the eight surrounding cells' nearest and filed points,
// and along the boundary from there.
//
// on_found(i, s, d2) follows the search at every lightable pixel i, in increasing i along each row
// (rows run in parallel): s is the point found (-1 if none, or if the chart does not hold the
// pixel) and d2 its squared distance across the light at the pixel.
template <typename OnFound>
void nearest_in_chart(const RayChart& chart, const OracleFrame& frame, const OracleLightImage& img,
                      const LocalLight& light, const std::vector<glm::dvec3>& seeds, OracleBoundaryTimes& times,
                      OnFound on_found) {
    auto t0 = SteadyClock::now();
    const std::size_t n = frame.pixel_count();
    constexpr double kInf = std::numeric_limits<double>::infinity();
    struct Box {
        glm::dvec2 lo{kInf}, hi{-kInf};
        std::size_t count = 0;
    };
    const Box box = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, n, std::size_t(1) << 14), Box{},
        [&](const tbb::blocked_range<std::size_t>& r, Box b) {
            glm::dvec2 uv;
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                if (img.lightable[i] != 0 && chart.owns(glm::dvec3(frame.P[i])) &&
                    chart.map(glm::dvec3(frame.P[i]), uv)) {
                    b.lo = glm::min(b.lo, uv);
                    b.hi = glm::max(b.hi, uv);
                    ++b.count;
                }
            return b;
        },
        [](Box a, const Box& b) {
            a.lo = glm::min(a.lo, b.lo);
            a.hi = glm::max(a.hi, b.hi);
            a.count += b.count;
            return a;
        });
    if (box.count == 0) {
        times.grid_s += seconds_since(t0);
        return;
    }
    const ChartGrid grid = grid_over(box.lo, box.hi, box.count);

    // The boundary points filed by cell (a counting sort).
    const std::size_t m = seeds.size();
    std::vector<glm::dvec2> seed_uv(m);
    std::vector<std::size_t> seed_cell(m, grid.size());
    std::vector<std::uint32_t> first(grid.size() + 1, 0);
    for (std::size_t s = 0; s < m; ++s)
        if (chart.map(seeds[s], seed_uv[s])) {
            const glm::ivec2 c = grid.cell_of(seed_uv[s]);
            seed_cell[s] = grid.index(c.x, c.y);
            ++first[seed_cell[s] + 1];
        }
    for (std::size_t c = 0; c < grid.size(); ++c) first[c + 1] += first[c];
    std::vector<int> filed(first.back());
    {
        std::vector<std::uint32_t> next(first.begin(), first.end() - 1);
        for (std::size_t s = 0; s < m; ++s)
            if (seed_cell[s] < grid.size()) filed[next[seed_cell[s]]++] = static_cast<int>(s);
    }

    times.grid_s += seconds_since(t0);

    // Each cell's nearest point to its centre's ray: its own filed points, then the sweeps.
    // at_chart_point(uv) measures the points from chart point uv (see below); bound_at(uv), a
    // lower bound of that measure over a box of SeedTree keys.
    auto run = [&](auto at_chart_point, auto bound_at, const std::vector<glm::dvec3>& keys) {
        t0 = SteadyClock::now();
        std::vector<int> cell_nearest(grid.size(), -1);
        std::vector<double> cell_best(grid.size(), kInf);
        // Cell by cell, its filed points in increasing order: the first of the nearest stays.
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.size(), 4096),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t c = r.begin(); c != r.end(); ++c) {
                                  if (first[c] == first[c + 1]) continue;
                                  const glm::ivec2 xy = grid.xy(c);
                                  const auto measure = at_chart_point(grid.centre(xy.x, xy.y));
                                  for (std::uint32_t f = first[c]; f != first[c + 1]; ++f) {
                                      const double d2 = measure(filed[f]);
                                      if (d2 < cell_best[c]) {
                                          cell_best[c] = d2;
                                          cell_nearest[c] = filed[f];
                                      }
                                  }
                              }
                          });
        nearest_sweeps(
            grid.nx, grid.ny, cell_nearest, cell_best, [](std::size_t) { return false; },
            [&](int x, int y) { return at_chart_point(grid.centre(x, y)); });
        times.sweeps_s += seconds_since(t0);
        t0 = SteadyClock::now();

        // Each cell's candidates: the distinct points its own and the eight surrounding cells
        // hold or are nearest to (built once; about sixteen pixels share a cell).
        std::vector<std::uint32_t> list_first(grid.size() + 1, 0);
        std::vector<std::uint8_t> crowded(grid.size(), 0);
        std::vector<int> list;
        {
            std::vector<std::vector<int>> rows(static_cast<std::size_t>(grid.ny));
            tbb::parallel_for(0, grid.ny, [&](int y) {
                std::vector<int>& row = rows[static_cast<std::size_t>(y)];
                for (int x = 0; x < grid.nx; ++x) {
                    const std::size_t begin = row.size();
                    const int y0 = std::max(0, y - 1), y1 = std::min(grid.ny - 1, y + 1);
                    const int x0 = std::max(0, x - 1), x1 = std::min(grid.nx - 1, x + 1);
                    // The filed points are distinct (each is filed once); a cell's nearest point
                    // is new unless it is filed in the block or already taken.
                    for (int yn = y0; yn <= y1; ++yn)
                        for (int xn = x0; xn <= x1; ++xn)
                            for (std::uint32_t f = first[grid.index(xn, yn)]; f != first[grid.index(xn, yn) + 1]; ++f)
                                row.push_back(filed[f]);
                    const std::size_t filed_end = row.size();
                    for (int yn = y0; yn <= y1; ++yn)
                        for (int xn = x0; xn <= x1; ++xn) {
                            const int s = cell_nearest[grid.index(xn, yn)];
                            if (s < 0) continue;
                            const glm::ivec2 k = grid.xy(seed_cell[static_cast<std::size_t>(s)]);
                            if (k.x >= x0 && k.x <= x1 && k.y >= y0 && k.y <= y1) continue;
                            if (std::find(row.begin() + static_cast<std::ptrdiff_t>(filed_end), row.end(), s) ==
                                row.end())
                                row.push_back(s);
                        }
                    // Where points crowd (a chart whose pixels are far denser in places than
                    // its cells), only the kMaxCandidates nearest to the cell's centre are kept,
                    // and its pixels search the tree from the best of them.
                    if (row.size() - begin > kMaxCandidates) {
                        const auto measure = at_chart_point(grid.centre(x, y));
                        const auto from = row.begin() + static_cast<std::ptrdiff_t>(begin);
                        std::nth_element(from, from + static_cast<std::ptrdiff_t>(kMaxCandidates) - 1, row.end(),
                                         [&](int a, int b) { return measure(a) < measure(b); });
                        row.resize(begin + kMaxCandidates);
                        crowded[grid.index(x, y)] = 1;
                    }
                    list_first[grid.index(x, y) + 1] = static_cast<std::uint32_t>(row.size() - begin);
                }
            });
            for (std::size_t c = 0; c < grid.size(); ++c) list_first[c + 1] += list_first[c];
            list.resize(list_first.back());
            tbb::parallel_for(0, grid.ny, [&](int y) {
                const std::vector<int>& row = rows[static_cast<std::size_t>(y)];
                std::copy(row.begin(), row.end(), list.begin() + list_first[grid.index(0, y)]);
            });
        }

        // Each point's neighbours along its boundary: the kNeighbours points nearest to it in the
        // chart among those filed in its own and the eight surrounding cells.
        std::vector<std::array<int, kNeighbours>> neighbours(m);
        tbb::parallel_for(std::size_t(0), m, [&](std::size_t s) {
            neighbours[s].fill(-1);
            if (seed_cell[s] >= grid.size()) return;
            const glm::ivec2 c = grid.xy(seed_cell[s]);
            const int cx = c.x, cy = c.y;
            std::array<double, kNeighbours> d2s;
            d2s.fill(kInf);
            for (int y = std::max(0, cy - 1); y <= std::min(grid.ny - 1, cy + 1); ++y)
                for (int x = std::max(0, cx - 1); x <= std::min(grid.nx - 1, cx + 1); ++x)
                    for (std::uint32_t f = first[grid.index(x, y)]; f != first[grid.index(x, y) + 1]; ++f) {
                        const int t = filed[f];
                        if (static_cast<std::size_t>(t) == s) continue;
                        const glm::dvec2 d = seed_uv[static_cast<std::size_t>(t)] - seed_uv[s];
                        const double d2 = glm::dot(d, d);
                        if (!(d2 < d2s.back())) continue;
                        std::size_t k = kNeighbours - 1;  // insertion into the sorted nearest so far
                        for (; k > 0 && d2 < d2s[k - 1]; --k) {
                            d2s[k] = d2s[k - 1];
                            neighbours[s][k] = neighbours[s][k - 1];
                        }
                        d2s[k] = d2;
                        neighbours[s][k] = t;
                    }
        });

        // The crowded cells' pixels search the whole chart's points (SeedTree).
        std::optional<SeedTree> tree;
        if (std::find(crowded.begin(), crowded.end(), 1) != crowded.end()) {
            std::vector<int> charted;
            for (std::size_t s = 0; s < m; ++s)
                if (seed_cell[s] < grid.size()) charted.push_back(static_cast<int>(s));
            tree.emplace(std::move(charted), keys);
        }

        times.lists_s += seconds_since(t0);
        t0 = SteadyClock::now();

        // Each pixel: the nearest of its cell's candidates; then, unless that lies within a cell
        // (see below), a walk along the boundary to the nearest neighbour of the point so far
        // while that is nearer (the points of a boundary lie about a pixel apart, and the one
        // nearest to a cell's centre may be a cell away along the boundary from the one nearest
        // to the pixel). The search starts from the point found for the pixel before it in the
        // row, where comparisons mostly confirm; rows are the unit of work, so the result does
        // not depend on the thread count. Measured in the chart, then across the light direction
        // at the pixel itself.
        const int W = frame.width;
        const double cell2 = grid.cell * grid.cell;
        tbb::parallel_for(0, frame.height, [&](int y) {
            glm::dvec2 uv;
            int hint = -1;
            auto search = [&](std::size_t i) {
                const glm::dvec3 p(frame.P[i]);
                if (!chart.owns(p) || !chart.map(p, uv)) return on_found(i, -1, kInf);
                const auto measure = at_chart_point(uv);
                int cur = hint;
                double cur_d2 = cur >= 0 ? measure(cur) : kInf;
                const glm::ivec2 c = grid.cell_of(uv);
                auto scan = [&](std::uint32_t from, std::uint32_t to) {
                    for (std::uint32_t f = from; f != to; ++f) {
                        const int s = list[f];
                        const double d2 = measure(s);
                        if (d2 < cur_d2) {
                            cur_d2 = d2;
                            cur = s;
                        }
                    }
                };
                const std::size_t k = grid.index(c.x, c.y);
                scan(list_first[k], list_first[k + 1]);
                // A crowded cell's candidates are only some of its points: search them all, from
                // the nearest so far. Within a cell of a directional light's chart, every nearer
                // point lies in the 3 x 3 cells just scanned: cur is the nearest. Otherwise walk
                // along the boundary.
                if (crowded[k])
                    tree->nearest(measure, bound_at(uv), cur, cur_d2);
                else if (!(chart.directional && cur_d2 <= cell2))
                    for (int step = 0; cur >= 0 && step < kMaxWalkSteps; ++step) {
                        const int before = cur;
                        for (const int t : neighbours[static_cast<std::size_t>(cur)]) {
                            if (t < 0) break;
                            const double d2 = measure(t);
                            if (d2 < cur_d2) {
                                cur_d2 = d2;
                                cur = t;
                            }
                        }
                        if (cur == before) break;
                    }
                hint = cur;
                if (cur < 0) return on_found(i, -1, kInf);
                on_found(i, cur,
                         lateral_distance2(p, direction_to_light(light, p), seeds[static_cast<std::size_t>(cur)]));
            };
            for (std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(W),
                             end = i + static_cast<std::size_t>(W);
                 i != end; ++i)
                if (img.lightable[i] != 0) search(i);
        });
        times.pixels_s += seconds_since(t0);
    };
    if (chart.directional) {
        // The distance between a point and a ray is the distance between their chart points; the
        // tree's keys are those, and a box's bound is its distance from the pixel's (the same
        // differences, rounded alike, so never above a point's measure).
        std::vector<glm::dvec3> keys(m);
        for (std::size_t s = 0; s < m; ++s) keys[s] = glm::dvec3(seed_uv[s], 0.0);
        run(
            [&](const glm::dvec2& at) {
                return [&seed_uv, at](int s) {
                    const glm::dvec2 d = seed_uv[static_cast<std::size_t>(s)] - at;
                    return glm::dot(d, d);
                };
            },
            [](const glm::dvec2& at) {
                return [at](const glm::dvec3& lo, const glm::dvec3& hi) {
                    const glm::dvec2 d = glm::max(glm::dvec2(lo) - at, glm::max(at - glm::dvec2(hi), glm::dvec2(0.0)));
                    return glm::dot(d, d);
                };
            },
            keys);
    } else {
        // The tree's keys are the points themselves; a box's bound, the distance from the pixel's
        // ray to the box's bounding sphere, less a margin for the rounding of either measure.
        run(
            [&](const glm::dvec2& at) {
                return [&seeds, &chart, dir = chart.ray_direction(at)](int s) {
                    const glm::dvec3 d = seeds[static_cast<std::size_t>(s)] - chart.origin;
                    const double along = glm::dot(d, dir);
                    return std::max(0.0, glm::dot(d, d) - along * along);
                };
            },
            [&chart](const glm::dvec2& at) {
                return [&chart, dir = chart.ray_direction(at)](const glm::dvec3& lo, const glm::dvec3& hi) {
                    const glm::dvec3 c = 0.5 * (lo + hi) - chart.origin;
                    const double r = 0.5 * glm::length(hi - lo), along = glm::dot(c, dir);
                    const double gap =
                        std::sqrt(std::max(0.0, glm::dot(c, c) - along * along)) - r - 1e-7 * (glm::length(c) + r);
                    return gap > 0 ? gap * gap : 0.0;
                };
            },
            seeds);
    }
}

// The nearest boundary point of every lightable pixel carried through the image by the same
// sweeps, each pixel keeping the nearer of its own and its neighbours' points: a complement to
// the cube of charts, whose faces see only the boundary points within ~75 degrees of their axes.
void nearest_in_image(const OracleFrame& frame, const OracleLightImage& img, const LocalLight& light,
                      const std::vector<glm::dvec3>& seeds, std::vector<int>& nearest, std::vector<double>& best) {
    nearest_sweeps(
        frame.width, frame.height, nearest, best, [&](std::size_t i) { return img.lightable[i] == 0; },
        [&](int x, int y) {
            const glm::dvec3 p(frame.P[static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.width) +
                                       static_cast<std::size_t>(x)]);
            return [&seeds, p, to_light = direction_to_light(light, p)](int s) {
                return lateral_distance2(p, to_light, seeds[static_cast<std::size_t>(s)]);
            };
        });
}

}  // namespace

std::uint64_t locate_shadow_boundaries(const Tracer& tr, OracleFrame& frame, std::size_t li, int steps,
                                       OracleBoundaryTimes& times) {
    auto t0 = SteadyClock::now();
    const int W = frame.width, H = frame.height;
    OracleLightImage& img = frame.lights[li];
    const LocalLight& light = tr.lights()[li];
    std::uint64_t rays = 0;

    // ---- 1. boundary points between straddling pixel pairs ----
    // Rows are searched in parallel (the exact shadow rays are most of this phase's time); the
    // points are then taken in row-major order, as a serial loop would, so the output does not
    // depend on the thread count.
    struct Straddle {
        int i, j;
        glm::dvec3 seed;
    };
    std::vector<std::vector<Straddle>> rows(static_cast<std::size_t>(H));
    std::atomic<std::uint64_t> ray_count{0};
    tbb::parallel_for(tbb::blocked_range<int>(0, H, 8), [&](const tbb::blocked_range<int>& range) {
        std::uint64_t local_rays = 0;
        for (int y = range.begin(); y != range.end(); ++y) {
            std::vector<Straddle>& row = rows[static_cast<std::size_t>(y)];
            for (int x = 0; x < W; ++x) {
                const int i = y * W + x;
                if (img.lightable[i] == 0) continue;
                for (int dir = 0; dir < 2; ++dir) {
                    int xj = x + (dir == 0), yj = y + (dir == 1);
                    if (xj >= W || yj >= H) continue;
                    const int j = yj * W + xj;
                    if (img.lightable[j] == 0 || img.V[i] == img.V[j]) continue;
                    std::uint32_t pi = frame.prim[i], pj = frame.prim[j];
                    glm::dvec3 a(frame.P[i]), b(frame.P[j]);
                    glm::dvec3 seed;
                    if (same_plane(tr, pi, pj)) {
                        seed = locate_on_plane(tr, light, pi, a, b, img.V[i], steps, local_rays);
                    } else {
                        // A crease or a silhouette: accept the midpoint only where the surface is
                        // continuous (similar normals, no depth jump).
                        glm::dvec3 ni(frame.N[i]), nj(frame.N[j]);
                        double gap = glm::length(b - a);
                        if (glm::dot(ni, nj) < 0.9 || std::abs(glm::dot(ni, b - a)) > 0.1 * gap) continue;
                        seed = 0.5 * (a + b);
                    }
                    row.push_back({i, j, seed});
                }
            }
        }
        ray_count += local_rays;
    });
    rays = ray_count;
    times.locate_s += seconds_since(t0);
    t0 = SteadyClock::now();
    // Each straddling pixel's own points: the point between it and each neighbour whose verdict
    // differs; of these, the nearest (the first found among equals). A list sorted by pixel, not
    // an array over every pixel: that was 48 MB of fresh memory at 2048^2, 0.05 s to fault in.
    struct Found {
        int seed = -1;
        double d2 = std::numeric_limits<double>::infinity();
    };
    struct OwnPoint {
        std::uint32_t pixel;
        Found found;
    };
    // The points are numbered in row-major order (row y's from row_first[y]). A pixel of row y
    // has points from the pairs of row y and, through its upper neighbour, of row y - 1: each
    // row gathers its pixels' own points by itself, in the order a serial loop over the rows
    // would meet them, so the rows run in parallel (serially this took 0.02 s, a fifth of the
    // phase at 16 threads).
    std::vector<std::size_t> row_first(static_cast<std::size_t>(H) + 1, 0);
    for (std::size_t y = 0; y < rows.size(); ++y) row_first[y + 1] = row_first[y] + rows[y].size();
    std::vector<glm::dvec3> seeds(row_first.back());
    std::vector<std::vector<OwnPoint>> own_rows(static_cast<std::size_t>(H));
    tbb::parallel_for(0, H, [&](int y) {
        const auto row = static_cast<std::size_t>(y);
        for (std::size_t k = 0; k < rows[row].size(); ++k) seeds[row_first[row] + k] = rows[row][k].seed;
        std::vector<OwnPoint>& own_row = own_rows[row];
        auto offer = [&](int i, std::size_t s, const glm::dvec3& seed) {
            const glm::dvec3 p(frame.P[i]);
            const double d2 = lateral_distance2(p, direction_to_light(light, p), seed);
            if (d2 < Found{}.d2) own_row.push_back({static_cast<std::uint32_t>(i), {static_cast<int>(s), d2}});
        };
        if (y > 0)  // the pairs reaching down into this row
            for (std::size_t k = 0; k < rows[row - 1].size(); ++k)
                if (const Straddle& st = rows[row - 1][k]; st.j / W == y) offer(st.j, row_first[row - 1] + k, st.seed);
        for (std::size_t k = 0; k < rows[row].size(); ++k) {
            const Straddle& st = rows[row][k];
            offer(st.i, row_first[row] + k, st.seed);
            if (st.j / W == y) offer(st.j, row_first[row] + k, st.seed);
        }
        // Stable: of a pixel's points at the same distance, the first found stays, as when they
        // were compared one by one.
        std::stable_sort(own_row.begin(), own_row.end(),
                         [](const OwnPoint& a, const OwnPoint& b) { return a.pixel < b.pixel; });
        std::size_t kept = 0;
        for (std::size_t k = 0; k < own_row.size(); ++k) {
            if (kept > 0 && own_row[kept - 1].pixel == own_row[k].pixel) {
                if (own_row[k].found.d2 < own_row[kept - 1].found.d2) own_row[kept - 1].found = own_row[k].found;
            } else {
                own_row[kept++] = own_row[k];
            }
        }
        own_row.resize(kept);
    });
    rows = {};
    std::vector<std::size_t> own_first(static_cast<std::size_t>(H) + 1, 0);
    for (std::size_t y = 0; y < own_rows.size(); ++y) own_first[y + 1] = own_first[y] + own_rows[y].size();
    std::vector<OwnPoint> own(own_first.back());
    tbb::parallel_for(std::size_t(0), own_rows.size(), [&](std::size_t y) {
        std::copy(own_rows[y].begin(), own_rows[y].end(), own.begin() + static_cast<std::ptrdiff_t>(own_first[y]));
    });
    own_rows = {};

    // ---- 2. the nearest boundary point of every lightable pixel; 3. its distance ----
    // Step 3 at pixel i: the distance, and ambiguity within float error of a boundary.
    const Camera& cam = tr.camera();
    const glm::dvec3& eye = tr.camera_eye();  // zero but on a camera path's later frames
    // The ambiguity distance below is at most k (|P| + |B|) with k = 64 eps x 64 (cos_view >=
    // 1/64), so a squared distance above 2 k^2 (|P|^2 + max |B|^2), with a margin for rounding,
    // is not ambiguous: most pixels are decided without the square roots and the division.
    double seed_norm2 = 0;
    for (const glm::dvec3& b : seeds) seed_norm2 = std::max(seed_norm2, glm::dot(b, b));
    constexpr double kFar = 64 * 64 * robust::kFloatEps;
    constexpr double kFar2 = 2 * kFar * kFar * (1 + 1e-6);
    auto finish = [&](std::size_t i, const Found& f) {
        if (f.seed < 0) return;
        double dist = std::sqrt(f.d2);
        img.boundary_m[i] = static_cast<float>(dist);
        // The receiver point carries a float error of ~eps |P|, stretched along the surface by
        // 1 / cos(view angle); the boundary, ~eps |B|. Closer than that, the verdict is a coin
        // toss for any float implementation, so it is flagged rather than guessed.
        glm::dvec3 p(frame.P[i]);
        if (f.d2 > kFar2 * (glm::dot(p, p) + seed_norm2)) return;
        glm::dvec3 n(frame.N[i]);
        glm::dvec3 view = cam.type == ProjectionType::perspective ? glm::normalize(p - eye) : cam.forward;
        double cos_view = std::max(std::abs(glm::dot(n, view)), 1.0 / 64);
        double ambiguity = 64 * robust::kFloatEps * (glm::length(p) + glm::length(seeds[f.seed])) / cos_view;
        if (dist <= ambiguity) img.U[i] = 1.0f;
    };

    times.merge_s += seconds_since(t0);
    if (seeds.empty()) return rays;
    t0 = SteadyClock::now();
    const std::vector<RayChart> charts = charts_for(light, frame, img);
    times.grid_s += seconds_since(t0);
    if (charts.size() == 1) {
        // One chart maps every lightable pixel (charts_for): a pixel's search there is its last,
        // and step 3 follows it in the same pass. Each row walks its pixels' own points in order.
        std::vector<std::size_t> row_next(static_cast<std::size_t>(H));
        for (std::size_t y = 0, k = 0; y < row_next.size(); ++y) {
            while (k < own.size() && own[k].pixel < y * static_cast<std::size_t>(W)) ++k;
            row_next[y] = k;
        }
        nearest_in_chart(charts[0], frame, img, light, seeds, times, [&](std::size_t i, int s, double d2) {
            std::size_t& next = row_next[i / static_cast<std::size_t>(W)];
            while (next < own.size() && own[next].pixel < i) ++next;
            Found f;
            if (next < own.size() && own[next].pixel == i) f = own[next++].found;
            if (d2 < f.d2) f = {s, d2};
            finish(i, f);
        });
    } else {
        std::vector<int> nearest(frame.pixel_count(), -1);
        std::vector<double> best(frame.pixel_count(), std::numeric_limits<double>::infinity());
        for (const OwnPoint& o : own) {
            nearest[o.pixel] = o.found.seed;
            best[o.pixel] = o.found.d2;
        }
        auto keep_nearer = [&](std::size_t i, int s, double d2) {
            if (d2 < best[i]) {
                best[i] = d2;
                nearest[i] = s;
            }
        };
        for (const RayChart& chart : charts) nearest_in_chart(chart, frame, img, light, seeds, times, keep_nearer);
        t0 = SteadyClock::now();
        nearest_in_image(frame, img, light, seeds, nearest, best);
        times.sweeps_s += seconds_since(t0);
        t0 = SteadyClock::now();
        tbb::parallel_for(std::size_t(0), frame.pixel_count(), [&](std::size_t i) {
            if (img.lightable[i] != 0) finish(i, {nearest[i], best[i]});
        });
        times.pixels_s += seconds_since(t0);
    }
    return rays;
}

}  // namespace penumbra::oracle_detail
