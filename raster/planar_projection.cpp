// The planar_projection family (docs/raster.md, "Planar projection shadows"). Per light: the
// casters (every triangle not on the receiver plane) are flattened onto the plane on the CPU by
// Blinn's matrix, drawn from the camera into a coverage target (the stencil: one mark per pixel,
// however many casters cover it), read back; a pixel is then in shadow iff the camera sees the
// receiver plane there and the light reaches it, and a flattened caster covers it. Nothing else
// is ever shadowed: that is the technique, and its false light is what the verdict shows.
#include "raster/planar_projection.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

#include "common/camera.h"
#include "common/errors.h"
#include "common/stopwatch.h"
#include "raster/cutouts.h"
#include "raster/surface_seen.h"
#include "raster/technique_family.h"
#include "raster/vk_check.h"
#include "shaders/penumbra_shared.h"
// SPIR-V compiled from shaders/ at build time.
#include "planar_cutout_frag.h"
#include "planar_cutout_vert.h"
#include "shadow_frag.h"
#include "shadow_vert.h"

namespace penumbra::raster {

const PlanarProjection* planar_of(const Technique& t) {
    return t.family == "planar_projection" ? t.parameters<PlanarProjection>() : nullptr;
}

std::optional<glm::dvec4> largest_upward_plane(const Scene& scene) {
    const double tol = 1e-6 * (1.0 + (scene.bounds.empty() ? 0.0 : scene.bounds.radius()));
    // Rounded (n, d) to the summed area and the first exact plane seen with that key.
    std::map<std::array<long long, 4>, std::pair<double, glm::dvec4>> planes;
    for (const glm::u32vec3& tri : scene.triangles) {
        const glm::dvec3 a = scene.positions[tri.x], b = scene.positions[tri.y], c = scene.positions[tri.z];
        const glm::dvec3 cross = glm::cross(b - a, c - a);
        const double twice_area = glm::length(cross);
        if (!(twice_area > 0)) continue;
        const glm::dvec3 n = cross / twice_area;
        if (n.y < 0.9) continue;
        const double d = -glm::dot(n, a);
        const std::array<long long, 4> key = {std::llround(n.x * 1e6), std::llround(n.y * 1e6), std::llround(n.z * 1e6),
                                              std::llround(d / tol)};
        auto [it, fresh] = planes.try_emplace(key, 0.0, glm::dvec4(n, d));
        it->second.first += 0.5 * twice_area;
    }
    std::optional<glm::dvec4> best;
    double best_area = 0;
    for (const auto& [key, entry] : planes)
        if (entry.first > best_area) {
            best_area = entry.first;
            best = entry.second;
        }
    return best;
}

glm::dmat4 planar_shadow_matrix(const glm::dvec4& plane, const glm::dvec4& light) {
    const double dot = glm::dot(plane, light);
    glm::dmat4 m(0.0);
    for (int col = 0; col < 4; ++col)
        for (int row = 0; row < 4; ++row) m[col][row] = (row == col ? dot : 0.0) - light[row] * plane[col];
    return m;
}

namespace {

constexpr VkFormat kCoverageDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr const char* kStencilPass =
    "the casters flattened onto the receiver plane, drawn from the camera into a coverage target (the stencil: a "
    "pixel is marked once however many casters cover it), without the copy to the host";

// The light as a homogeneous point: (position, 1), or (towards the light, 0) for a sun. Area
// lights are drawn from their centre, as the depth map draws them without samples.
glm::dvec4 homogeneous_light(const Light& l) {
    return l.type == LightType::directional ? glm::dvec4(-l.direction, 0.0) : glm::dvec4(l.position, 1.0);
}

class PlanarProjectionFamily final : public TechniqueFamily {
  public:
    explicit PlanarProjectionFamily(const SceneOnGpu& scene) : s_(scene), ctx_(scene.ctx), timer_(scene.ctx) {}
    void render(const Technique& t, std::span<const Light> lights, const RenderOptions& options, RasterFrame& frame,
                RasterStats& stats) override;

  private:
    // A light's casters flattened onto the plane: camera-relative float3 per vertex, three per
    // triangle; the cut-outs' (and blend cutout(T)'s blended) apart, with what their alpha test
    // reads (shaders/planar_cutout.vert).
    struct Flattened {
        std::vector<float> opaque, cutout;
        std::vector<glm::vec4> cutout_over_w;         // (u, v, alpha, 1) / w per cut-out vertex
        std::vector<std::uint32_t> cutout_triangles;  // the scene triangle of each
    };
    void ensure_resources();
    Flattened flattened_casters(const glm::dvec4& plane, const Light& light, const Technique& t) const;
    VkPipeline cutout_pipeline(const Technique& t);
    std::vector<float> visibility(const glm::dvec4& plane, const Light& light, const std::uint32_t* coverage) const;

    const SceneOnGpu& s_;
    const VulkanContext& ctx_;
    UniquePipelineLayout layout_;
    UniquePipeline pipeline_;
    // Cut-outs: their set (the cut-out bindings and the flattened attributes, one set per light),
    // layout and pipelines by blend cutoff.
    std::unique_ptr<DescriptorSets> cutout_sets_;
    UniquePipelineLayout cutout_layout_;
    std::map<double, UniquePipeline> cutout_pipelines_;
    MemoryArena arena_;
    GpuImage coverage_, depth_;
    GpuTimestamps timer_;
    // The receiver plane the per-triangle flags below were computed for.
    std::optional<glm::dvec4> flags_plane_;
    std::vector<std::uint8_t> on_plane_;  // per triangle: all three vertices on the receiver plane
};

void PlanarProjectionFamily::ensure_resources() {
    if (pipeline_) return;
    layout_ = make_pipeline_layout(ctx_, VK_NULL_HANDLE, sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
    // Flattened triangles wind either way: nothing culled. No depth test: each lies on the
    // plane, so it covers exactly the plane points in its shadow; whether the camera sees the
    // plane there is the camera pass's triangle per pixel. No depth clamp: the near plane clips.
    pipeline_ = make_graphics_pipeline(
        ctx_, layout_.get(),
        {kShadowVert, sizeof(kShadowVert), kShadowFrag, sizeof(kShadowFrag), kCoverageDepthFormat, VK_COMPARE_OP_ALWAYS,
         VK_CULL_MODE_NONE, VK_FRONT_FACE_COUNTER_CLOCKWISE, false, false});
    if (s_.has_cutouts) {
        std::vector<BindingDecl> bindings(cutout_bindings().begin(), cutout_bindings().end());
        bindings.push_back({gpu::kBindingPlanarAttributes, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER});
        bindings.push_back({gpu::kBindingPlanarTriangles, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER});
        cutout_sets_ =
            std::make_unique<DescriptorSets>(ctx_, bindings, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
        cutout_layout_ =
            make_pipeline_layout(ctx_, cutout_sets_->layout(), sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
    }
    arena_ = MemoryArena(ctx_);
    arena_.add(coverage_, kPrimFormat, s_.width, s_.height, 1,
               VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, VK_IMAGE_ASPECT_COLOR_BIT, false);
    arena_.add(depth_, kCoverageDepthFormat, s_.width, s_.height, 1, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
               VK_IMAGE_ASPECT_DEPTH_BIT, false);
    arena_.commit();
}

PlanarProjectionFamily::Flattened PlanarProjectionFamily::flattened_casters(const glm::dvec4& plane, const Light& light,
                                                                            const Technique& t) const {
    const Scene& scene = s_.scenario.scene;
    const glm::dmat4 m = planar_shadow_matrix(plane, homogeneous_light(light));
    Flattened out;
    for (std::size_t ti = 0; ti < scene.triangles.size(); ++ti) {
        if (on_plane_[ti]) continue;  // the receiver itself
        const CutoutMaterial* material = scene.alpha_material_of(ti);
        const bool blended = material && material->mode == AlphaMode::blend;
        if (blended && t.blend == Blend::none) continue;
        const bool alpha_test = material && (!blended || t.blend == Blend::cutout);
        const glm::u32vec3 tri = scene.triangles[ti];
        std::array<glm::dvec3, 3> flat;
        std::array<double, 3> w{};
        bool kept = true;
        for (int k = 0; k < 3; ++k) {
            const glm::dvec4 p = m * glm::dvec4(scene.positions[tri[k]], 1.0);
            // w <= 0: the vertex is as high above the plane as the light, or higher; Blinn's
            // matrix sends it through infinity to the far side (an anti-shadow): dropped.
            if (!(p.w > 1e-12 * std::abs(glm::dot(plane, homogeneous_light(light))))) kept = false;
            flat[k] = glm::dvec3(p) / p.w;
            w[k] = p.w;
        }
        if (!kept) continue;
        std::vector<float>& target = alpha_test ? out.cutout : out.opaque;
        for (int k = 0; k < 3; ++k) {
            const glm::vec3 local(flat[k] - s_.origin);
            target.insert(target.end(), {local.x, local.y, local.z});
            if (!alpha_test) continue;
            const glm::dvec2 uv(scene.texcoords[tri[k]]);
            out.cutout_over_w.emplace_back(uv.x / w[k], uv.y / w[k], scene.vertex_alpha[tri[k]] / w[k], 1.0 / w[k]);
        }
        if (alpha_test) out.cutout_triangles.push_back(static_cast<std::uint32_t>(ti));
    }
    return out;
}

VkPipeline PlanarProjectionFamily::cutout_pipeline(const Technique& t) {
    const double blend_cutoff = t.blend == Blend::cutout ? t.blend_cutoff : -1;
    UniquePipeline& p = cutout_pipelines_[blend_cutoff];
    if (!p) {
        GraphicsSetup g{kPlanarCutoutVert,
                        sizeof(kPlanarCutoutVert),
                        kPlanarCutoutFrag,
                        sizeof(kPlanarCutoutFrag),
                        kCoverageDepthFormat,
                        VK_COMPARE_OP_ALWAYS,
                        VK_CULL_MODE_NONE,
                        VK_FRONT_FACE_COUNTER_CLOCKWISE,
                        false,
                        false};
        Technique level0 = t;
        level0.alpha_mipmaps = false;  // a flattened triangle has no map texels to minify over
        g.frag_spec = alpha_spec(level0);
        p = make_graphics_pipeline(ctx_, cutout_layout_.get(), g);
    }
    return p.get();
}

std::vector<float> PlanarProjectionFamily::visibility(const glm::dvec4& plane, const Light& light,
                                                      const std::uint32_t* coverage) const {
    const Scene& scene = s_.scenario.scene;
    const PrimaryRays rays(s_.camera, s_.width, s_.height);
    const glm::dvec3 plane_n(plane);
    // In the frame and at the precision the session drew the scene, as the other families judge it.
    const glm::dvec3 light_position = drawn_light_position(light, s_.origin, s_.precision);
    const LightReach reach(light, light_position);
    const std::vector<glm::vec3>& drawn = s_.drawn_positions;
    std::vector<float> V(s_.pixels, 0.0f);
    for (std::uint32_t y = 0; y < s_.height; ++y)
        for (std::uint32_t x = 0; x < s_.width; ++x) {
            const std::size_t i = std::size_t{y} * s_.width + x;
            if (s_.A[i] == 0) continue;
            const std::uint32_t prim = s_.prim[i];
            const glm::u32vec3 tri = scene.triangles[prim];
            const SurfaceSeen seen = surface_seen(rays.at(x + 0.5, y + 0.5), glm::dvec3(drawn[tri.x]),
                                                  glm::dvec3(drawn[tri.y]), glm::dvec3(drawn[tri.z]));
            if (!reach.lightable(seen)) continue;  // V = 0, not scored
            // Only the receiver plane takes shadow, and only where the light is on its upper side.
            const glm::dvec3 to_light =
                light.type == LightType::directional ? -light.direction : light_position - seen.point;
            const bool receives = on_plane_[prim] && glm::dot(plane_n, to_light) > 0;
            V[i] = receives && coverage[i] != gpu::kNoPrim ? 0.0f : 1.0f;
        }
    return V;
}

void PlanarProjectionFamily::render(const Technique& t, std::span<const Light> lights, const RenderOptions&,
                                    RasterFrame& frame, RasterStats& stats) {
    auto t0 = SteadyClock::now();
    stats.hw2x2 = "unused";  // no map, no compare
    const Scenario& sc = s_.scenario;
    const Scene& scene = sc.scene;
    const PlanarProjection* params = planar_of(t);
    std::optional<glm::dvec4> plane = params ? params->plane : std::nullopt;
    if (!plane) plane = largest_upward_plane(scene);
    if (!plane)
        throw InputError(
            fmt::format("{}: technique.planar.plane: the scene has no upward-facing plane to receive "
                        "planar shadows; give one as [nx, ny, nz, d]",
                        sc.label));
    if (flags_plane_ != plane) {
        const double tol = 1e-6 * (1.0 + (scene.bounds.empty() ? 0.0 : scene.bounds.radius()));
        on_plane_.assign(scene.triangles.size(), 0);
        for (std::size_t ti = 0; ti < scene.triangles.size(); ++ti) {
            bool on = true;
            for (int k = 0; k < 3; ++k)
                on = on &&
                     std::abs(glm::dot(glm::dvec3(*plane), scene.positions[scene.triangles[ti][k]]) + plane->w) <= tol;
            on_plane_[ti] = on ? 1 : 0;
        }
        flags_plane_ = plane;
    }
    ensure_resources();
    const std::size_t n = lights.size();
    timer_.ensure(static_cast<std::uint32_t>(2 * n));
    // Per light: its flattened casters (the cut-outs' apart) and the host copy of its coverage.
    std::vector<GpuBuffer> vertices(n), readback(n), cutout_vertices(n), cutout_over_w(n), cutout_triangles(n);
    std::vector<std::uint32_t> vertex_counts(n, 0), cutout_counts(n, 0);
    const glm::mat4 vp = s_.camera_view_proj;
    auto host_buffer = [&](const void* data, std::size_t bytes, VkBufferUsageFlags usage) {
        GpuBuffer b = create_buffer(ctx_, std::max<std::size_t>(bytes, 4), usage, true);
        if (bytes) std::memcpy(b.mapped, data, bytes);
        return b;
    };
    if (cutout_sets_) cutout_sets_->reserve(n);
    for (std::size_t li = 0; li < n; ++li) {
        const Flattened flat = flattened_casters(*plane, lights[li], t);
        vertex_counts[li] = static_cast<std::uint32_t>(flat.opaque.size() / 3);
        if (!flat.opaque.empty())
            vertices[li] =
                host_buffer(flat.opaque.data(), flat.opaque.size() * sizeof(float), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
        cutout_counts[li] = static_cast<std::uint32_t>(flat.cutout.size() / 3);
        if (cutout_sets_) {
            cutout_vertices[li] =
                host_buffer(flat.cutout.data(), flat.cutout.size() * sizeof(float), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
            cutout_over_w[li] = host_buffer(flat.cutout_over_w.data(), flat.cutout_over_w.size() * sizeof(glm::vec4),
                                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
            cutout_triangles[li] =
                host_buffer(flat.cutout_triangles.data(), flat.cutout_triangles.size() * sizeof(std::uint32_t),
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
            std::vector<DescriptorResource> resources;
            append_cutout_resources(s_, resources);
            for (const GpuBuffer* b : {&cutout_over_w[li], &cutout_triangles[li]}) {
                DescriptorResource r;
                r.buffer = {b->buffer.get(), 0, VK_WHOLE_SIZE};
                resources.push_back(r);
            }
            cutout_sets_->write(li, resources);
        }
        readback[li] = create_buffer(ctx_, s_.pixels * sizeof(std::uint32_t), VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
    }
    stats.setup_s += seconds_since(t0);

    auto t1 = SteadyClock::now();
    ctx_.submit_and_wait([&](VkCommandBuffer cmd) {
        timer_.reset(cmd, 0, static_cast<std::uint32_t>(2 * n));
        for (std::size_t li = 0; li < n; ++li) {
            const auto q = static_cast<std::uint32_t>(2 * li);
            image_barrier(cmd, coverage_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
                          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
            image_barrier(
                cmd, depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, kFragmentTests, VK_ACCESS_2_NONE, kFragmentTests,
                VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
            timer_.write(cmd, q);
            begin_rendering(cmd, coverage_.view.get(), depth_.view.get(), s_.width, s_.height, 0.0f);
            if (vertex_counts[li] > 0) {
                vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.get());
                vkCmdSetDepthBias(cmd, 0.0f, 0.0f, 0.0f);
                vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
                VkDeviceSize zero = 0;
                vkCmdBindVertexBuffers(cmd, 0, 1, vertices[li].buffer.ptr(), &zero);
                vkCmdDraw(cmd, vertex_counts[li], 1, 0, 0);
            }
            if (cutout_counts[li] > 0) {  // the cut-outs' shadows where they are opaque
                vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, cutout_pipeline(t));
                VkDescriptorSet set = (*cutout_sets_)[li];
                vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, cutout_layout_.get(), 0, 1, &set, 0,
                                        nullptr);
                vkCmdSetDepthBias(cmd, 0.0f, 0.0f, 0.0f);
                vkCmdPushConstants(cmd, cutout_layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
                VkDeviceSize zero = 0;
                vkCmdBindVertexBuffers(cmd, 0, 1, cutout_vertices[li].buffer.ptr(), &zero);
                vkCmdDraw(cmd, cutout_counts[li], 1, 0, 0);
            }
            vkCmdEndRendering(cmd);
            timer_.write(cmd, q + 1);
            image_barrier(cmd, coverage_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1,
                          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
            VkBufferImageCopy region{};
            region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
            region.imageExtent = {s_.width, s_.height, 1};
            vkCmdCopyImageToBuffer(cmd, coverage_.image.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                   readback[li].buffer.get(), 1, &region);
        }
        memory_barrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                       VK_ACCESS_2_HOST_READ_BIT);
    });
    stats.render_s += seconds_since(t1);

    timer_.read(0, static_cast<std::uint32_t>(2 * n));
    stats.lights.resize(n);
    for (std::size_t li = 0; li < n; ++li) {
        RasterLightStats& ls = stats.lights[li];
        ls = {};
        ls.gpu_ms.add("stencil", timer_.ms(2 * li, 2 * li + 1), kStencilPass);
        stats.gpu_ms.add(ls.gpu_ms);
        RasterLightImage img;
        img.V = visibility(*plane, lights[li], static_cast<const std::uint32_t*>(readback[li].mapped));
        frame.lights.push_back(std::move(img));
    }
}

nlohmann::json plane_json(const glm::dvec4& p) {
    return nlohmann::json::array({p.x, p.y, p.z, p.w});
}

}  // namespace

FamilyEntry planar_projection_family_entry() {
    FamilyEntry e;
    e.draws_maps = false;
    e.name = "planar_projection";
    e.description =
        "planar projection shadows (Blinn 1988): casters flattened onto one receiver plane by the light's projection "
        "matrix, drawn through a stencil once per pixel; nothing but that plane receives shadow";
    e.parse = [](JsonObject& o, Technique& t) {
        PlanarProjection p;
        if (o.has("planar")) {
            JsonObject po = o.object("planar");
            if (po.has("plane")) {
                const nlohmann::json& v = po.get("plane");
                if (!v.is_array() || v.size() != 4 || !std::all_of(v.begin(), v.end(), [](const nlohmann::json& x) {
                        return x.is_number() && std::isfinite(x.get<double>()) && std::abs(x.get<double>()) <= 1e12;
                    }))
                    po.fail("plane", "expected [nx, ny, nz, d], four finite numbers (the plane n.x + d = 0)");
                const glm::dvec3 n(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
                const double len = glm::length(n);
                if (!(len > 1e-12)) po.fail("plane", "the normal [nx, ny, nz] is zero");
                // Stored normalised (a unit normal as given), so that writing it back parses to the same plane.
                const double scale = std::abs(len - 1.0) < 1e-12 ? 1.0 : len;
                p.plane = glm::dvec4(n / scale, v[3].get<double>() / scale);
            }
            po.finish();
        }
        t.family_parameters = std::make_shared<const PlanarProjection>(p);
    };
    e.write = [](const Technique& t, nlohmann::json& j) {
        const PlanarProjection* p = planar_of(t);
        nlohmann::json planar = nlohmann::json::object();
        if (p && p->plane) planar["plane"] = plane_json(*p->plane);
        j["planar"] = planar;
    };
    // V only (the metrics classify from the oracle's geometry), and no map, filter or bias: no
    // aliasing band and no peter-panning reach, so every shadow it loses is false light.
    e.hints = [](const Technique&) {
        ScoringHints h;
        h.exact = true;  // no map, no bias: nothing excused as aliasing or peter-panning
        h.false_lit_cure =
            "planar projection shadows its one plane, so every other receiver reads lit (and casters below the plane "
            "or beyond the light cast nothing); pick a family with a map or volumes for them";
        return h;
    };
    // No shadow map: the coverage target is the size of the image (counted with the frame).
    // The coverage target and its depth (4 + 4 bytes a pixel), a read-back of 4 a pixel a light,
    // and each light's flattened casters (36 bytes a triangle).
    e.memory = [](const Technique&) { return RasterMemory{0, 4, 0, 0, 0, 0, 8, 4, 36}; };
    e.describe_light = [](const Technique& t, const Light&, const RasterLightStats&) {
        const PlanarProjection* p = planar_of(t);
        return nlohmann::json{{"projection", "planar"},
                              {"planar",
                               {{"plane", p && p->plane ? plane_json(*p->plane) : nlohmann::json("largest_upward")},
                                {"receivers", "the plane only"},
                                {"stencil", "one mark per pixel: never darkened twice"}}}};
    };
    e.sweep_keys = {"planar.plane", "precision"};
    e.make = [](const SceneOnGpu& scene) -> std::unique_ptr<TechniqueFamily> {
        return std::make_unique<PlanarProjectionFamily>(scene);
    };
    return e;
}

}  // namespace penumbra::raster
