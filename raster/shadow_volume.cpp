// The shadow_volume family (docs/raster.md, "Shadow volumes"). Per light: the volumes built on
// the CPU from the scene's triangle adjacency (once per scene and light, kept by the family),
// drawn into the stencil buffer over the camera's depth with two-sided stencil (z-fail by
// default), then a full-screen pass turns "count == 0" into V = 1. No map, no texels, no bias:
// the verdict is exact up to rasterisation, so any wrong pixel away from a boundary is a bug.
#include "raster/shadow_volume.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <optional>
#include <unordered_map>

#include "common/camera.h"
#include "common/errors.h"
#include "common/json_reader.h"
#include "common/stopwatch.h"
#include "raster/cutouts.h"
#include "raster/surface_seen.h"
#include "raster/technique_family.h"
#include "shaders/penumbra_shared.h"
// SPIR-V compiled from shaders/ at build time.
#include "resolve_frag.h"
#include "resolve_vert.h"
#include "volume_frag.h"
#include "volume_vert.h"

namespace penumbra::raster {

const char* to_string(OpenMeshRule r) {
    return r == OpenMeshRule::skip ? "skip" : "include";
}
const char* to_string(StencilMethod m) {
    return m == StencilMethod::zfail ? "zfail" : "zpass";
}

const ShadowVolumeParameters* shadow_volume_parameters(const Technique& t) {
    return t.parameters<ShadowVolumeParameters>();
}

namespace {

struct PositionHash {
    std::size_t operator()(const glm::dvec3& p) const {
        std::size_t h = 0;
        for (int k = 0; k < 3; ++k) {
            std::uint64_t bits;
            std::memcpy(&bits, &p[k], sizeof bits);
            h = h * 0x9E3779B97F4A7C15ull + (bits ^ (bits >> 29));
        }
        return h;
    }
};

std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

}  // namespace

SceneTopology scene_topology(const Scene& scene) {
    SceneTopology topo;
    // Weld vertices by exact position: scenes built triangle by triangle (or glTF primitives
    // split by material) share no indices, yet their edges are the same edges.
    std::unordered_map<glm::dvec3, std::uint32_t, PositionHash> ids;
    topo.welded.resize(scene.positions.size());
    for (std::size_t v = 0; v < scene.positions.size(); ++v)
        topo.welded[v] = ids.emplace(scene.positions[v], static_cast<std::uint32_t>(ids.size())).first->second;

    const std::size_t n = scene.triangles.size();
    topo.mesh_of.assign(n, kNoMesh);
    // Directed edge uses, keyed by node and welded pair: (key, node, +1 for min->max / -1, triangle).
    struct Use {
        std::uint32_t node;
        std::uint64_t key;
        int direction;
        std::uint32_t triangle;
        bool operator<(const Use& o) const { return std::tie(node, key) < std::tie(o.node, o.key); }
    };
    std::vector<Use> uses;
    uses.reserve(3 * n);
    std::vector<std::uint32_t> parent(n);
    std::iota(parent.begin(), parent.end(), 0u);
    std::vector<bool> valid(n, false);
    for (std::uint32_t t = 0; t < n; ++t) {
        const glm::u32vec3& tri = scene.triangles[t];
        const std::uint32_t w[3] = {topo.welded[tri.x], topo.welded[tri.y], topo.welded[tri.z]};
        if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) continue;  // degenerate: casts nothing
        valid[t] = true;
        const std::uint32_t node = t < scene.triangle_node.size() ? scene.triangle_node[t] : 0u;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = w[k], b = w[(k + 1) % 3];
            uses.push_back({node, edge_key(a, b), a < b ? 1 : -1, t});
        }
    }
    std::sort(uses.begin(), uses.end());
    // Triangles sharing an edge are one mesh.
    for (std::size_t i = 0, j = 0; i < uses.size(); i = j) {
        for (j = i + 1; j < uses.size() && uses[j].node == uses[i].node && uses[j].key == uses[i].key; ++j) {
            const std::uint32_t ra = find_root(parent, uses[i].triangle), rb = find_root(parent, uses[j].triangle);
            if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
        }
    }
    std::unordered_map<std::uint32_t, std::uint32_t> mesh_of_root;
    for (std::uint32_t t = 0; t < n; ++t) {
        if (!valid[t]) continue;
        const std::uint32_t root = find_root(parent, t);
        auto [it, added] = mesh_of_root.emplace(root, static_cast<std::uint32_t>(topo.meshes.size()));
        if (added) {
            MeshTopology m;
            m.node = t < scene.triangle_node.size() ? scene.triangle_node[t] : 0u;
            m.first_triangle = t;
            topo.meshes.push_back(m);
        }
        topo.mesh_of[t] = it->second;
        ++topo.meshes[it->second].triangles;
    }
    for (std::size_t i = 0, j = 0; i < uses.size(); i = j) {
        int forward = 0, backward = 0;
        for (j = i; j < uses.size() && uses[j].node == uses[i].node && uses[j].key == uses[i].key; ++j)
            (uses[j].direction > 0 ? forward : backward) += 1;
        MeshTopology& m = topo.meshes[topo.mesh_of[uses[i].triangle]];
        if (forward + backward == 1)
            ++m.open_edges;
        else if (forward != 1 || backward != 1)
            ++m.non_manifold_edges;  // three or more triangles, or two wound the same way
    }
    return topo;
}

ShadowVolumeGeometry build_shadow_volume(std::span<const glm::vec3> positions, const Scene& scene,
                                         const SceneTopology& topology, const Light& light, const glm::dvec3& light_rel,
                                         OpenMeshRule rule, double finite_reach_m) {
    ShadowVolumeGeometry g;
    const bool directional = light.type == LightType::directional;
    const bool finite = finite_reach_m > 0;
    const glm::dvec3 dir = glm::normalize(light.direction);
    auto at = [&](std::uint32_t v) { return glm::vec4(positions[v], 1.0f); };
    // The point at infinity behind v, seen from the light (Everitt & Kilgard's w = 0), or the
    // point `finite_reach_m` beyond.
    auto infinity = [&](std::uint32_t v) {
        const glm::dvec3 p(positions[v]);
        const glm::dvec3 d = directional ? dir : p - light_rel;
        if (!finite) return glm::vec4(glm::vec3(d), 0.0f);
        const glm::dvec3 far = directional ? p + dir * finite_reach_m : light_rel + glm::normalize(d) * finite_reach_m;
        return glm::vec4(glm::vec3(far), 1.0f);
    };
    std::vector<bool> skipped(topology.meshes.size(), false);
    // Directed silhouette candidates: (welded pair key, +1 min->max / -1, a scene vertex of each end).
    struct Side {
        std::uint64_t key;
        int direction;
        std::uint32_t lo, hi;  // scene vertices at the pair's min and max welded ids
        bool operator<(const Side& o) const { return key < o.key; }
    };
    std::vector<Side> sides;
    for (std::uint32_t t = 0; t < scene.triangles.size(); ++t) {
        const std::uint32_t m = topology.mesh_of[t];
        if (m == kNoMesh) continue;
        const bool closed = topology.meshes[m].closed();
        if (!closed && rule == OpenMeshRule::skip) {
            skipped[m] = true;
            continue;
        }
        glm::u32vec3 tri = scene.triangles[t];
        const glm::dvec3 a(positions[tri.x]), b(positions[tri.y]), c(positions[tri.z]);
        const glm::dvec3 n = glm::cross(b - a, c - a);
        const double facing = directional ? -glm::dot(n, dir) : glm::dot(n, light_rel - a);
        // A closed mesh casts from its unlit side alone (every ray through it leaves through
        // one), so that no cap lies on a lit face; an open one from every triangle.
        if (facing == 0 || (closed && facing > 0)) continue;
        if (facing < 0) std::swap(tri.y, tri.z);  // each prism is wound to face the light
        ++g.caster_triangles;
        const std::uint32_t v[3] = {tri.x, tri.y, tri.z};
        for (int k = 0; k < 3; ++k) g.vertices.push_back(at(v[k]));  // near cap
        if (!directional || finite) {  // far cap (a directional light's at infinity collapses to one point)
            g.vertices.push_back(infinity(v[0]));
            g.vertices.push_back(infinity(v[2]));
            g.vertices.push_back(infinity(v[1]));
            g.cap_triangles += 1;
        }
        g.cap_triangles += 1;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t p = v[k], q = v[(k + 1) % 3];
            const std::uint32_t wp = topology.welded[p], wq = topology.welded[q];
            sides.push_back({edge_key(wp, wq), wp < wq ? 1 : -1, wp < wq ? p : q, wp < wq ? q : p});
        }
    }
    // Sides two prisms share with opposite orientation cancel: what is left is the silhouette
    // (an edge used |net| times, so open and non-manifold edges stay counted right).
    std::stable_sort(sides.begin(), sides.end());
    for (std::size_t i = 0, j = 0; i < sides.size(); i = j) {
        int net = 0;
        for (j = i; j < sides.size() && sides[j].key == sides[i].key; ++j) net += sides[j].direction;
        // The prism's edge p -> q gives the side (q, p, p_inf, q_inf), wound outwards.
        const std::uint32_t p = net > 0 ? sides[i].lo : sides[i].hi, q = net > 0 ? sides[i].hi : sides[i].lo;
        for (int k = 0; k < std::abs(net); ++k) {
            const glm::vec4 quad[6] = {at(q), at(p), infinity(p), at(q), infinity(p), infinity(q)};
            g.vertices.insert(g.vertices.end(), std::begin(quad), std::end(quad));
            ++g.silhouette_edges;
        }
    }
    for (std::uint32_t m = 0; m < skipped.size(); ++m)
        if (skipped[m]) g.skipped_meshes.push_back(m);
    return g;
}

double volume_reach(const Light& light, const glm::dvec3& light_rel, const glm::dvec3& center_rel, double radius) {
    const double diameter = 2.0 * std::max(radius, 1e-9);
    if (light.type == LightType::directional) return 2.0 * diameter;
    return 1e4 * (glm::length(light_rel - center_rel) + diameter);
}

namespace {

constexpr VkFormat kVisibilityFormat = VK_FORMAT_R32_SFLOAT;
constexpr std::array<BindingDecl, 1> kDepthBindings = {{{gpu::kBindingDoubleSided, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}}};

const ShadowVolumeParameters& parameters_of(const Technique& t) {
    static const ShadowVolumeParameters kDefault;
    const ShadowVolumeParameters* p = shadow_volume_parameters(t);
    return p ? *p : kDefault;
}

VkStencilOpState stencil_ops(VkStencilOp pass, VkStencilOp depth_fail) {
    VkStencilOpState s{};
    s.failOp = VK_STENCIL_OP_KEEP;
    s.passOp = pass;
    s.depthFailOp = depth_fail;
    s.compareOp = VK_COMPARE_OP_ALWAYS;
    s.compareMask = s.writeMask = 0xFF;
    return s;
}

// The volumes' passes (GraphicsSetup): reversed depth (equal fails), no culling, counter-clockwise
// front as in the camera pass (camera_matrix has flipped y), a depth-stencil target, homogeneous
// vertices (w = 0 at infinity), no colour target.
GraphicsSetup volume_setup(const std::uint32_t* vert, std::size_t vert_bytes, const std::uint32_t* frag,
                           std::size_t frag_bytes, VkFormat depth_stencil) {
    GraphicsSetup g{vert,
                    vert_bytes,
                    frag,
                    frag_bytes,
                    depth_stencil,
                    VK_COMPARE_OP_GREATER,
                    VK_CULL_MODE_NONE,
                    VK_FRONT_FACE_COUNTER_CLOCKWISE,
                    false,
                    false};
    g.vertex_input = VertexInput::vec4;
    g.colour_format = VK_FORMAT_UNDEFINED;
    g.stencil_attachment = true;
    return g;
}

// What the family keeps of one light between renders: the volumes depend on the light and the
// open-mesh rule alone (the scene is the session's).
struct LightVolume {
    bool valid = false;
    LightType type{};
    glm::dvec3 position{0.0}, direction{0.0};
    OpenMeshRule rule{};
    double reach = 0;               // build_shadow_volume's finite_reach_m (0: to infinity)
    ShadowVolumeGeometry geometry;  // vertices dropped once uploaded
    std::size_t vertex_count = 0;
    GpuBuffer vertices;
    double build_ms = 0;  // CPU: silhouette and extrusion, when built
    bool reused = false;  // kept from the previous render
};

class ShadowVolumeFamily final : public TechniqueFamily {
  public:
    explicit ShadowVolumeFamily(const SceneOnGpu& s)
        : s_(s),
          topology_(scene_topology(s.scenario.scene)),
          depth_sets_(s.ctx, kDepthBindings, VK_SHADER_STAGE_FRAGMENT_BIT),
          timer_(s.ctx) {}

    void render(const Technique& technique, std::span<const Light> lights, const RenderOptions&, RasterFrame& frame,
                RasterStats& stats) override {
        // A volume is extruded from a triangle's edges: a cut-out's holes have none.
        check_alpha_rules(s_, technique, "shadow_volume");
        const ShadowVolumeParameters& p = parameters_of(technique);
        // The volumes are camera-relative: a session moved to another eye (a camera path) or
        // drawing at another precision builds them again.
        if (!drawn_once_ || drawn_origin_ != s_.origin || drawn_precision_ != s_.precision) {
            drawn_once_ = true;
            drawn_origin_ = s_.origin;
            drawn_precision_ = s_.precision;
            for (LightVolume& v : volumes_) v.valid = false;
            drawn_bounds_.reset();
        }
        prepare(lights.size());
        const Scene& scene = s_.scenario.scene;
        for (std::size_t li = 0; li < lights.size(); ++li) {
            const Light& l = lights[li];
            LightVolume& v = volumes_[li];
            v.build_ms = 0;
            const glm::dvec3 light_rel = drawn_light_position(l, s_.origin, s_.precision);
            // An orthographic camera cannot draw points at infinity: its volumes end beyond the scene.
            const double reach = s_.camera.type == ProjectionType::orthographic
                                     ? volume_reach(l, light_rel, drawn_bounds().center(), drawn_bounds().radius())
                                     : 0.0;
            v.reused = v.valid && v.type == l.type && v.position == l.position && v.direction == l.direction &&
                       v.rule == p.open_meshes && v.reach == reach;
            if (v.reused) continue;
            auto t0 = SteadyClock::now();
            v = LightVolume{};
            v.geometry = build_shadow_volume(s_.drawn_positions, scene, topology_, l, light_rel, p.open_meshes, reach);
            v.build_ms = seconds_since(t0) * 1e3;
            v.vertex_count = v.geometry.vertices.size();
            if (v.vertex_count > 0)
                v.vertices = upload(s_.ctx, v.geometry.vertices.data(), v.vertex_count * sizeof(glm::vec4),
                                    VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
            v.geometry.vertices = {};
            v.type = l.type;
            v.position = l.position;
            v.direction = l.direction;
            v.rule = p.open_meshes;
            v.reach = reach;
            v.valid = true;
        }
        if (!volumes_.empty()) skipped_warning(scene, volumes_[0].geometry.skipped_meshes, stats);
        const UniquePipeline& volume = p.method == StencilMethod::zfail ? zfail_ : zpass_;
        const std::size_t L = lights.size();
        const std::uint32_t queries = static_cast<std::uint32_t>(2 + 2 * L);
        const std::uint32_t W = s_.width, H = s_.height;
        auto t_render = SteadyClock::now();
        s_.ctx.submit_and_wait([&](VkCommandBuffer cmd) {
            timer_.reset(cmd, 0, queries);
            timer_.write(cmd, 0, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT);
            image_barrier(
                cmd, depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT, 1,
                VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE,
                VK_ACCESS_2_NONE, kFragmentTests,
                VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
            // The camera's depth again, through the volumes' vertex shader (the session's pass
            // keeps no depth, and a D32 target has no stencil).
            begin_depth_stencil_rendering(cmd, VK_NULL_HANDLE, depth_.view.get(), W, H, true, true);
            const glm::mat4 vp = s_.camera_view_proj;
            VkDeviceSize zero = 0;
            if (scene_vertex_count_ > 0) {
                vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, depth_pipeline_.get());
                VkDescriptorSet set = depth_sets_[0];
                vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, depth_layout_.get(), 0, 1, &set, 0,
                                        nullptr);
                vkCmdPushConstants(cmd, depth_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
                vkCmdBindVertexBuffers(cmd, 0, 1, scene_vertices_.buffer.ptr(), &zero);
                vkCmdDraw(cmd, scene_vertex_count_, 1, 0, 0);
            }
            vkCmdEndRendering(cmd);
            timer_.write(cmd, 1);
            for (std::size_t li = 0; li < L; ++li) {
                const LightVolume& v = volumes_[li];
                memory_barrier(
                    cmd, kFragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kFragmentTests,
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
                begin_depth_stencil_rendering(cmd, VK_NULL_HANDLE, depth_.view.get(), W, H, false, true);
                if (v.vertex_count > 0) {
                    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, volume.get());
                    vkCmdPushConstants(cmd, volume_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
                    vkCmdBindVertexBuffers(cmd, 0, 1, v.vertices.buffer.ptr(), &zero);
                    vkCmdDraw(cmd, static_cast<std::uint32_t>(v.vertex_count), 1, 0, 0);
                }
                vkCmdEndRendering(cmd);
                timer_.write(cmd, static_cast<std::uint32_t>(2 + 2 * li));
                memory_barrier(
                    cmd, kFragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kFragmentTests,
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
                image_barrier(cmd, visibility_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                              VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                              VK_ACCESS_2_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                              VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
                begin_depth_stencil_rendering(cmd, visibility_.view.get(), depth_.view.get(), W, H, false, false);
                vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, resolve_.get());
                vkCmdDraw(cmd, 3, 1, 0, 0);
                vkCmdEndRendering(cmd);
                image_barrier(cmd, visibility_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1,
                              VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                              VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                              VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
                VkBufferImageCopy region{};
                region.bufferOffset = li * s_.pixels * sizeof(float);
                region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
                region.imageExtent = {W, H, 1};
                vkCmdCopyImageToBuffer(cmd, visibility_.image.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                       readback_.buffer.get(), 1, &region);
                timer_.write(cmd, static_cast<std::uint32_t>(3 + 2 * li));
            }
            memory_barrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                           VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
        });
        stats.render_s += seconds_since(t_render);
        stats.hw2x2 = "unused";
        timer_.read(0, queries);
        auto ms = [&](std::size_t a, std::size_t b) {
            return timer_.ms(static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b));
        };
        stats.gpu_ms.add("depth", ms(0, 1), "the camera's depth and stencil redrawn for the volumes, once a render");
        const float* visible = static_cast<const float*>(readback_.mapped);
        for (std::size_t li = 0; li < L; ++li) {
            RasterLightImage img;
            img.V.assign(visible + li * s_.pixels, visible + (li + 1) * s_.pixels);
            unlit_outside_light(lights[li], img.V);
            frame.lights.push_back(std::move(img));
            RasterLightStats ls;
            const double stencil = ms(1 + 2 * li, 2 + 2 * li);
            const double resolve = ms(2 + 2 * li, 3 + 2 * li);
            ls.gpu_ms.add("stencil", stencil, "the light's volumes into the stencil, two-sided, one draw");
            ls.gpu_ms.add("resolve", resolve, "stencil == 0 to V, and its copy back");
            stats.gpu_ms.add(ls.gpu_ms);
            ls.family_keys = describe(li);
            stats.lights.push_back(std::move(ls));
        }
    }

  private:
    // The bounds of the positions as drawn (the frame the volumes are built in), once per frame.
    const Bounds& drawn_bounds() {
        if (!drawn_bounds_) {
            drawn_bounds_.emplace();
            for (const glm::vec3& p : s_.drawn_positions) drawn_bounds_->grow(glm::dvec3(p));
        }
        return *drawn_bounds_;
    }

    // What open_meshes "skip" left out, said on every render that leaves something out (the
    // volumes of every light skip the same meshes): the count, their share of the triangles and
    // the largest by name, so that a run's false_lit is not read as the technique's.
    void skipped_warning(const Scene& scene, const std::vector<std::uint32_t>& skipped, RasterStats& stats) const {
        if (skipped.empty()) return;
        std::vector<std::uint32_t> largest = skipped;
        std::stable_sort(largest.begin(), largest.end(), [&](std::uint32_t a, std::uint32_t b) {
            return topology_.meshes[a].triangles > topology_.meshes[b].triangles;
        });
        std::size_t triangles = 0;
        for (std::uint32_t m : skipped) triangles += topology_.meshes[m].triangles;
        std::string names;
        for (std::size_t i = 0; i < largest.size() && i < kSkippedNamed; ++i)
            names +=
                fmt::format("{}{} ({} triangles)", i ? ", " : "", scene.node_label(topology_.meshes[largest[i]].node),
                            topology_.meshes[largest[i]].triangles);
        if (largest.size() > kSkippedNamed) names += fmt::format(" and {} more", largest.size() - kSkippedNamed);
        stats.warnings.push_back(
            fmt::format("shadow_volume.open_meshes \"skip\": {} open mesh{} cast no shadow, {} of the scene's {} "
                        "triangles ({:.1f}%): "
                        "{}; \"include\" casts them (raster.json's shadow_volume.open_meshes lists each)",
                        skipped.size(), skipped.size() == 1 ? "" : "es", triangles, scene.triangles.size(),
                        100.0 * double(triangles) / double(std::max<std::size_t>(1, scene.triangles.size())), names));
    }
    static constexpr std::size_t kSkippedNamed = 3;

    // raster.json's shadow_volume object of light li.
    nlohmann::json describe(std::size_t li) const {
        const LightVolume& v = volumes_[li];
        nlohmann::json open = nlohmann::json::array();
        std::size_t open_edges = 0, non_manifold_edges = 0;
        for (std::size_t m = 0; m < topology_.meshes.size(); ++m) {
            const MeshTopology& t = topology_.meshes[m];
            if (t.closed()) continue;
            const bool skipped = std::binary_search(v.geometry.skipped_meshes.begin(), v.geometry.skipped_meshes.end(),
                                                    static_cast<std::uint32_t>(m));
            open_edges += t.open_edges;
            non_manifold_edges += t.non_manifold_edges;
            open.push_back({{"mesh", m},
                            {"node", t.node},
                            {"first_triangle", t.first_triangle},
                            {"triangles", t.triangles},
                            {"open_edges", t.open_edges},
                            {"non_manifold_edges", t.non_manifold_edges},
                            {"casts", !skipped}});
        }
        const std::size_t bytes = v.vertex_count * sizeof(glm::vec4);
        return {{"meshes", topology_.meshes.size()},
                {"closed_meshes", topology_.meshes.size() - open.size()},
                {"open_meshes", open},
                {"open_edges", open_edges},
                {"non_manifold_edges", non_manifold_edges},
                {"caster_triangles", v.geometry.caster_triangles},
                {"silhouette_edges", v.geometry.silhouette_edges},
                {"cap_triangles", v.geometry.cap_triangles},
                {"volume_vertices", v.vertex_count},
                {"volume_bytes", bytes},
                {"extrude_ms", v.build_ms},
                {"volumes_reused", v.reused},
                {"stencil_format", format_ == VK_FORMAT_D32_SFLOAT_S8_UINT ? "d32s8" : "d24s8"}};
    }

    // Pipelines, the targets and the scene's vertices, made on first use; the per-light
    // slots and the read-back buffer grow with the number of lights.
    void prepare(std::size_t lights) {
        const VulkanContext& ctx = s_.ctx;
        if (!depth_pipeline_) {
            format_ = VK_FORMAT_UNDEFINED;
            for (VkFormat f : {VK_FORMAT_D32_SFLOAT_S8_UINT, VK_FORMAT_D24_UNORM_S8_UINT}) {
                VkFormatProperties props;
                vkGetPhysicalDeviceFormatProperties(ctx.physical(), f, &props);
                if (props.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) {
                    format_ = f;
                    break;
                }
            }
            if (format_ == VK_FORMAT_UNDEFINED)
                throw EnvironmentError("shadow_volume: the device has no depth-stencil attachment format");
            depth_ = create_image(ctx, format_, s_.width, s_.height, 1, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                                  VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT, false);
            visibility_ = create_image(ctx, kVisibilityFormat, s_.width, s_.height, 1,
                                       VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                       VK_IMAGE_ASPECT_COLOR_BIT, false);
            // The scene unindexed, w = 1: a cap drawn over its triangle gets the same depth.
            const Scene& scene = s_.scenario.scene;
            std::vector<glm::vec4> v;
            v.reserve(3 * scene.triangles.size());
            for (const glm::u32vec3& t : scene.triangles)
                for (std::uint32_t k : {t.x, t.y, t.z}) v.push_back(glm::vec4(s_.drawn_positions[k], 1.0f));
            scene_vertex_count_ = static_cast<std::uint32_t>(v.size());
            if (!v.empty())
                scene_vertices_ =
                    upload(ctx, v.data(), v.size() * sizeof(glm::vec4), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
            depth_sets_.reserve(1);
            DescriptorResource ds;
            ds.buffer = {s_.double_sided.buffer.get(), 0, VK_WHOLE_SIZE};
            depth_sets_.write(0, std::span(&ds, 1));
            depth_layout_ =
                make_pipeline_layout(ctx, depth_sets_.layout(), sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
            volume_layout_ = make_pipeline_layout(ctx, VK_NULL_HANDLE, sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
            GraphicsSetup d = volume_setup(kVolumeVert, sizeof(kVolumeVert), kVolumeFrag, sizeof(kVolumeFrag), format_);
            d.depth_clamp = true;  // rasterised as the volumes are; volume.frag clips at near and far
            depth_pipeline_ = make_graphics_pipeline(ctx, depth_layout_.get(), d);
            // The volumes: depth-tested against the camera's depth, never written; depth clamp
            // keeps the far caps at infinity (clip w = 0) from being clipped by the far plane.
            GraphicsSetup z = volume_setup(kVolumeVert, sizeof(kVolumeVert), nullptr, 0, format_);
            z.depth_write = false;
            z.depth_clamp = true;
            z.stencil_test = true;
            // Carmack's reverse: behind the surface, a back face (leaving a volume) +1, a front
            // face (entering one) -1.
            z.front = stencil_ops(VK_STENCIL_OP_KEEP, VK_STENCIL_OP_DECREMENT_AND_WRAP);
            z.back = stencil_ops(VK_STENCIL_OP_KEEP, VK_STENCIL_OP_INCREMENT_AND_WRAP);
            zfail_ = make_graphics_pipeline(ctx, volume_layout_.get(), z);
            // Heidmann: in front of the surface, a front face +1, a back face -1.
            z.front = stencil_ops(VK_STENCIL_OP_INCREMENT_AND_WRAP, VK_STENCIL_OP_KEEP);
            z.back = stencil_ops(VK_STENCIL_OP_DECREMENT_AND_WRAP, VK_STENCIL_OP_KEEP);
            zpass_ = make_graphics_pipeline(ctx, volume_layout_.get(), z);
            GraphicsSetup r =
                volume_setup(kResolveVert, sizeof(kResolveVert), kResolveFrag, sizeof(kResolveFrag), format_);
            r.vertex_input = VertexInput::none;
            r.colour_format = kVisibilityFormat;
            r.depth_test = r.depth_write = false;
            r.stencil_test = true;
            r.front = r.back = stencil_ops(VK_STENCIL_OP_KEEP, VK_STENCIL_OP_KEEP);
            r.front.compareOp = r.back.compareOp = VK_COMPARE_OP_EQUAL;  // reference 0: outside every volume
            r.front.writeMask = r.back.writeMask = 0;
            resolve_ = make_graphics_pipeline(ctx, volume_layout_.get(), r);
        }
        if (volumes_.size() < lights) volumes_.resize(lights);
        if (!readback_.buffer || readback_lights_ < lights) {
            readback_ = create_buffer(ctx, std::max<std::size_t>(lights, 1) * s_.pixels * sizeof(float),
                                      VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
            readback_lights_ = lights;
        }
        timer_.ensure(static_cast<std::uint32_t>(2 + 2 * lights));  // also with no lights: the depth pass is timed
    }

    // As the depth map's lookup: V = 0 where the seen side faces away from the light (the near
    // caps lie there) or outside a spot's cone; background 0.
    void unlit_outside_light(const Light& l, std::vector<float>& V) const {
        const Scenario& sc = s_.scenario;
        const PrimaryRays rays(s_.camera, sc.width, sc.height);
        const LightReach reach(l, drawn_light_position(l, s_.origin, s_.precision));
        const std::vector<glm::vec3>& p = s_.drawn_positions;
        for (int y = 0; y < sc.height; ++y)
            for (int x = 0; x < sc.width; ++x) {
                const std::size_t i = static_cast<std::size_t>(y) * sc.width + x;
                const std::uint32_t id = s_.prim[i];
                if (id == kNoPrimitive) {
                    V[i] = 0.0f;
                    continue;
                }
                const glm::u32vec3 t = sc.scene.triangles[id];
                if (!reach.lightable(surface_seen(rays.at(x + 0.5, y + 0.5), glm::dvec3(p[t.x]), glm::dvec3(p[t.y]),
                                                  glm::dvec3(p[t.z]))))
                    V[i] = 0.0f;
            }
    }

  private:
    const SceneOnGpu& s_;
    SceneTopology topology_;
    bool drawn_once_ = false;
    glm::dvec3 drawn_origin_{0.0};  // the frame origin and precision the volumes were built for
    Precision drawn_precision_ = Precision::camera_relative;
    std::optional<Bounds> drawn_bounds_;
    DescriptorSets depth_sets_;
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    GpuImage depth_, visibility_;
    GpuBuffer scene_vertices_, readback_;
    std::uint32_t scene_vertex_count_ = 0;
    std::size_t readback_lights_ = 0;
    UniquePipelineLayout depth_layout_, volume_layout_;
    UniquePipeline depth_pipeline_, zfail_, zpass_, resolve_;
    GpuTimestamps timer_;
    std::vector<LightVolume> volumes_;
};

void parse_keys(JsonObject& o, Technique& t) {
    auto p = std::make_shared<ShadowVolumeParameters>();
    if (o.has("shadow_volume")) {
        JsonObject v = o.object("shadow_volume");
        p->open_meshes =
            pick_enum(v, "open_meshes", OpenMeshRule::include, {OpenMeshRule::skip, OpenMeshRule::include});
        p->method = pick_enum(v, "method", StencilMethod::zfail, {StencilMethod::zfail, StencilMethod::zpass});
        v.finish();
    }
    // The depth map's keys mean nothing here: left unread, they are refused as unknown.
    t.bias = Bias{};
    t.resolution = 0;
    t.family_parameters = std::move(p);
}

}  // namespace

FamilyEntry shadow_volume_family_entry() {
    FamilyEntry e;
    e.draws_maps = false;
    e.name = "shadow_volume";
    e.description =
        "stencil shadow volumes (Crow 1977; Heidmann 1991; z-fail, Everitt & Kilgard 2002): silhouettes from "
        "triangle adjacency extruded to infinity, counted in the stencil; exact hard shadows, no map";
    e.parse = parse_keys;
    e.write = [](const Technique& t, nlohmann::json& j) {
        const ShadowVolumeParameters& p = parameters_of(t);
        j["shadow_volume"] = {{"open_meshes", to_string(p.open_meshes)}, {"method", to_string(p.method)}};
    };
    e.hints = [](const Technique& t) {
        ScoringHints h;
        h.filter_reach_texels = 0;  // no map, no filter: V only, and nothing excused as aliasing
        h.exact = true;
        h.false_lit_cure = parameters_of(t).open_meshes == OpenMeshRule::skip
                               ? "casters the volumes leave out (open meshes, with shadow_volume.open_meshes \"skip\": "
                                 "the warnings count them; \"include\" casts them)"
                               : "casters the volumes leave out (degenerate or welded-away triangles)";
        return h;
    };
    e.memory = [](const Technique&) {
        RasterMemory m;  // no shadow map: resolution 0 counts no map bytes
        m.resolution = 0;
        m.directional_layers = m.spot_layers = m.cube_layers = 0;
        // Depth-stencil and V targets (8 + 4 bytes a pixel), a read-back of 4 a pixel a light;
        // per light and caster triangle its two caps (2 x 48 bytes) and, bounding the sides, one
        // silhouette edge's (96 bytes); the depth pass's 48 bytes a triangle are in the scene term.
        m.pixel_bytes = 12;
        m.pixel_bytes_per_light = 4;
        m.triangle_bytes_per_light = 192;
        return m;
    };
    e.describe_light = [](const Technique& t, const Light&, const RasterLightStats& stats) {
        nlohmann::json v = stats.family_keys;
        v["method"] = to_string(parameters_of(t).method);
        v["rule"] = to_string(parameters_of(t).open_meshes);
        return nlohmann::json{{"shadow_volume", v}};
    };
    e.sweep_keys = {"shadow_volume.open_meshes", "shadow_volume.method"};
    e.make = [](const SceneOnGpu& s) -> std::unique_ptr<TechniqueFamily> {
        return std::make_unique<ShadowVolumeFamily>(s);
    };
    return e;
}

}  // namespace penumbra::raster
