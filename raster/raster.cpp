#include "raster/raster.h"

#include <fmt/format.h>

#include <atomic>
#include <cstring>

#include "common/camera.h"
#include "common/errors.h"
#include "common/stopwatch.h"
#include "raster/cutouts.h"
#include "raster/surface_seen.h"
#include "raster/technique_family.h"
#include "shaders/penumbra_shared.h"
// SPIR-V compiled from shaders/ at build time.
#include "camera_cutout_frag.h"
#include "camera_frag.h"
#include "camera_vert.h"
#include "cutout_vert.h"

namespace penumbra::raster {

namespace {

constexpr VkFormat kCameraDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr std::array<BindingDecl, 1> kCameraBindings = {
    {{gpu::kBindingDoubleSided, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}}};

// Camera clip space from camera-relative positions, matching docs/design.md's pixel centres:
// y is flipped so that row 0 is the top row; reversed depth (1 at znear) for precision. The
// far plane is zfar or just beyond the scene, whichever is nearer (glTF allows zfar = inf).
glm::mat4 camera_matrix(const Camera& cam, int w, int h, const Bounds& scene) {
    double near = cam.znear;
    double far = std::max(near * 2, farthest_along(scene, cam.eye, cam.forward) * 1.01 + 1e-6);
    far = std::min(far, std::min(cam.zfar, 3.0e38));
    bool persp = cam.type == ProjectionType::perspective;
    glm::dvec2 plane = ndc_to_image_plane(cam, w, h);
    glm::dmat4 m(0.0);
    for (int c = 0; c < 3; ++c) {
        m[c][0] = cam.right[c] / plane.x;
        m[c][1] = -cam.up[c] / plane.y;
        if (persp) {
            m[c][2] = -cam.forward[c] * near / (far - near);
            m[c][3] = cam.forward[c];
        } else {
            m[c][2] = -cam.forward[c] / (far - near);
        }
    }
    m[3][2] = persp ? near * far / (far - near) : far / (far - near);
    m[3][3] = persp ? 0.0 : 1.0;
    return glm::mat4(m);
}

// Uploads the scene in the camera-centred frame and draws the camera pass: the triangle seen
// through every pixel, which every family's lookups start from.
void prepare_scene(SceneOnGpu& s) {
    const Scenario& sc = s.scenario;
    const VulkanContext& ctx = s.ctx;
    s.width = static_cast<std::uint32_t>(sc.width);
    s.height = static_cast<std::uint32_t>(sc.height);
    s.pixels = static_cast<std::size_t>(s.width) * s.height;
    s.origin = s.camera.eye;
    const std::uint32_t max_dim = ctx.limits().maxImageDimension2D;
    if (s.width > max_dim || s.height > max_dim)
        throw InputError(fmt::format("{}: image {}x{} exceeds the device's maxImageDimension2D {}", sc.label, s.width,
                                     s.height, max_dim));

    const Scene& scene = sc.scene;
    s.camera_view_proj = camera_matrix(s.camera, sc.width, sc.height, scene.bounds);
    // Double subtraction, then float: precision near the camera (world_float32 rounds the world
    // position to float first, as an engine's vertex buffer holds it).
    s.drawn_positions = drawn_positions(scene, s.origin, s.precision);
    static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "positions upload as packed float3");
    std::vector<std::uint32_t> idx(scene.triangles.size() * 3);
    std::vector<std::uint32_t> bits((scene.triangles.size() + 31) / 32 + 1, 0u);
    s.sided_runs.clear();
    for (std::size_t t = 0; t < scene.triangles.size(); ++t) {
        idx[3 * t] = scene.triangles[t].x;
        idx[3 * t + 1] = scene.triangles[t].y;
        idx[3 * t + 2] = scene.triangles[t].z;
        const bool two = scene.double_sided[t] != 0;
        const CutoutMaterial* m = scene.alpha_material_of(t);
        const AlphaMode alpha = m ? m->mode : AlphaMode::opaque;
        if (two) bits[t / 32] |= 1u << (t % 32);
        if (s.sided_runs.empty() || s.sided_runs.back().double_sided != two || s.sided_runs.back().alpha != alpha)
            s.sided_runs.push_back({static_cast<std::uint32_t>(t), 0, two, alpha});
        ++s.sided_runs.back().count;
    }
    s.index_count = static_cast<std::uint32_t>(idx.size());
    s.positions = upload(ctx, s.drawn_positions.data(), s.drawn_positions.size() * sizeof(glm::vec3),
                         VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    s.indices = upload(ctx, idx.data(), idx.size() * sizeof(std::uint32_t),
                       VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
    s.double_sided = upload(ctx, bits.data(), bits.size() * sizeof(std::uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);

    s.gbuffer_prim =
        create_image(ctx, kPrimFormat, s.width, s.height, 1,
                     VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                     VK_IMAGE_ASPECT_COLOR_BIT, false);
    GpuImage depth = create_image(ctx, kCameraDepthFormat, s.width, s.height, 1,
                                  VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT, false);
    GpuBuffer readback = create_buffer(ctx, s.pixels * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);

    // The camera pass culls nothing: the fragment shader drops single-sided back faces using
    // gl_FrontFacing. Front = counter-clockwise as seen, which with camera_matrix's y flip is
    // VK_FRONT_FACE_COUNTER_CLOCKWISE (pinned by the culling and primitive-agreement tests).
    // A scene with cut-outs is drawn with the alpha test (shaders/camera_cutout.frag), its set
    // holding the cut-outs' bindings beside the double-sided bits.
    upload_cutouts(s);
    std::vector<BindingDecl> bindings(kCameraBindings.begin(), kCameraBindings.end());
    std::vector<DescriptorResource> resources(1);
    resources[0].buffer = {s.double_sided.buffer.get(), 0, VK_WHOLE_SIZE};
    if (s.has_cutouts) {
        bindings.insert(bindings.end(), cutout_bindings().begin(), cutout_bindings().end());
        append_cutout_resources(s, resources);
    }
    DescriptorSets sets(
        ctx, bindings,
        s.has_cutouts ? VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT : VK_SHADER_STAGE_FRAGMENT_BIT);
    sets.reserve(1);
    sets.write(0, resources);
    UniquePipelineLayout layout =
        make_pipeline_layout(ctx, sets.layout(), sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
    UniquePipeline pipeline = make_graphics_pipeline(
        ctx, layout.get(),
        {s.has_cutouts ? kCutoutVert : kCameraVert, s.has_cutouts ? sizeof(kCutoutVert) : sizeof(kCameraVert),
         s.has_cutouts ? kCameraCutoutFrag : kCameraFrag,
         s.has_cutouts ? sizeof(kCameraCutoutFrag) : sizeof(kCameraFrag), kCameraDepthFormat, VK_COMPARE_OP_GREATER,
         VK_CULL_MODE_NONE, VK_FRONT_FACE_COUNTER_CLOCKWISE, false, false});
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = 2;
    VkQueryPool qp;
    VK_CHECK(vkCreateQueryPool(ctx.device(), &qi, nullptr, &qp));
    UniqueQueryPool queries(ctx.device(), qp);

    ctx.submit_and_wait([&](VkCommandBuffer cmd) {
        vkCmdResetQueryPool(cmd, queries.get(), 0, 2);
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, queries.get(), 0);
        image_barrier(cmd, s.gbuffer_prim.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
        image_barrier(cmd, depth.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                      kFragmentTests,
                      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
        begin_rendering(cmd, s.gbuffer_prim.view.get(), depth.view.get(), s.width, s.height, 0.0f);
        if (s.index_count > 0) {
            const glm::mat4 vp = s.camera_view_proj;
            vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.get());
            VkDescriptorSet set = sets[0];
            vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout.get(), 0, 1, &set, 0, nullptr);
            vkCmdPushConstants(cmd, layout.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
            vkCmdSetDepthBias(cmd, 0.0f, 0.0f, 0.0f);
            VkDeviceSize zero = 0;
            vkCmdBindVertexBuffers(cmd, 0, 1, s.positions.buffer.ptr(), &zero);
            vkCmdBindIndexBuffer(cmd, s.indices.buffer.get(), 0, VK_INDEX_TYPE_UINT32);
            vkCmdDrawIndexed(cmd, s.index_count, 1, 0, 0, 0);
        }
        vkCmdEndRendering(cmd);
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries.get(), 1);
        // The lookups read the triangle per pixel as a storage image from here on.
        image_barrier(cmd, s.gbuffer_prim.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, 1,
                      VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL,
                      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {s.width, s.height, 1};
        vkCmdCopyImageToBuffer(cmd, s.gbuffer_prim.image.get(), VK_IMAGE_LAYOUT_GENERAL, readback.buffer.get(), 1,
                               &region);
        memory_barrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                       VK_ACCESS_2_HOST_READ_BIT);
    });
    std::uint64_t t[2] = {0, 0};
    VK_CHECK(vkGetQueryPoolResults(ctx.device(), queries.get(), 0, 2, sizeof(t), t, sizeof(std::uint64_t),
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    s.camera_ms = ticks_to_ms(ctx, t[0], t[1]);
    static std::atomic<std::uint64_t> passes_drawn{0};
    s.camera_pass = ++passes_drawn;
    s.prim.resize(s.pixels);
    std::memcpy(s.prim.data(), readback.mapped, s.pixels * 4);
    s.A.resize(s.pixels);
    for (std::size_t i = 0; i < s.pixels; ++i) s.A[i] = s.prim[i] == kNoPrimitive ? 0.0f : 1.0f;
}

}  // namespace

void PassTimes::add(std::string_view name, double ms) {
    for (auto& [n, t] : entries)
        if (n == name) {
            t += ms;
            return;
        }
    entries.emplace_back(std::string(name), ms);
}

void PassTimes::add(std::string_view name, double ms, std::string_view what) {
    add(name, ms);
    if (what.empty()) return;
    for (auto& [n, w] : includes)
        if (n == name) {
            // Passes of one name drawn two ways (a light's lookups beside another's samples): both said.
            if (w.find(what) == std::string::npos) w += std::string("; and ") + std::string(what);
            return;
        }
    includes.emplace_back(std::string(name), std::string(what));
}

void PassTimes::add(const PassTimes& other) {
    for (const auto& [n, t] : other.entries) add(n, t, other.what(n));
}

std::string_view PassTimes::what(std::string_view name) const {
    for (const auto& [n, w] : includes)
        if (n == name) return w;
    return {};
}

double PassTimes::operator[](std::string_view name) const {
    for (const auto& [n, t] : entries)
        if (n == name) return t;
    return 0;
}

double PassTimes::total() const {
    double sum = 0;
    for (const auto& e : entries) sum += e.second;
    return sum;
}

struct RasterSession::Impl {
    Impl(const Scenario& scenario, const VulkanContext& ctx)
        : scene(std::make_unique<SceneOnGpu>(SceneOnGpu{scenario, ctx, scenario.camera})) {}
    // Families refer to the scene: they are dropped before it whenever it is replaced.
    using Families = std::map<std::string, std::unique_ptr<TechniqueFamily>>;
    std::unique_ptr<SceneOnGpu> scene;
    Families families;  // made on first use
    double setup_s = 0;
    bool first_render = true;
};

RasterSession::RasterSession(const Scenario& scenario, const VulkanContext& ctx)
    : impl_(std::make_unique<Impl>(scenario, ctx)) {
    auto t0 = SteadyClock::now();
    prepare_scene(*impl_->scene);
    impl_->setup_s = seconds_since(t0);
}

RasterSession::~RasterSession() = default;

void RasterSession::set_camera(const Camera& camera) {
    // The scene is uploaded relative to the eye, so a new eye is a new upload; the families keep
    // their pipelines and maps (a map is drawn again when its matrices, relative to the eye, change).
    auto t0 = SteadyClock::now();
    impl_->scene->camera = camera;
    prepare_scene(*impl_->scene);
    impl_->setup_s = seconds_since(t0);
}

const Scenario& RasterSession::scenario() const {
    return impl_->scene->scenario;
}
double RasterSession::setup_s() const {
    return impl_->setup_s;
}

RasterResult RasterSession::render(const Technique& technique, const RenderOptions& options) {
    const Scenario& sc = impl_->scene->scenario;
    check_technique_lights(technique, sc.lights, sc.label + ": technique");  // before any work
    const FamilyEntry* entry = find_technique_family(technique.family);
    if (!entry) throw InputError(fmt::format("technique.family: \"{}\" is not a technique family", technique.family));
    RasterResult out;
    RasterStats& stats = out.stats;
    stats.device = impl_->scene->ctx.info();
    // The first render pays for the session: a cold run's set-up time includes the uploads.
    if (impl_->first_render) stats.setup_s = impl_->setup_s;
    // A render that throws leaves the session as it was: a new precision is drawn on a scene and
    // families of its own, kept only once the render has succeeded.
    std::unique_ptr<SceneOnGpu> fresh_scene;
    Impl::Families fresh_families;
    Impl::Families* families = &impl_->families;
    if (technique.precision != impl_->scene->precision) {
        // The vertex buffer holds the positions as the technique rounds them: upload them again
        // and redo the camera pass.
        auto t0 = SteadyClock::now();
        fresh_scene = std::make_unique<SceneOnGpu>(SceneOnGpu{sc, impl_->scene->ctx, impl_->scene->camera});
        fresh_scene->precision = technique.precision;
        prepare_scene(*fresh_scene);
        stats.setup_s += seconds_since(t0);
        families = &fresh_families;
    }
    const SceneOnGpu& s = fresh_scene ? *fresh_scene : *impl_->scene;
    stats.camera_ms = s.camera_ms;
    stats.camera_pass = s.camera_pass;
    stats.family = std::string(entry->name);
    std::unique_ptr<TechniqueFamily>& family = (*families)[entry->name];
    if (!family) family = entry->make(s);
    RasterFrame& f = out.frame;
    f.width = sc.width;
    f.height = sc.height;
    f.frame_origin = s.origin;
    if (options.camera_images) {
        f.A = s.A;
        f.prim = s.prim;
    }
    try {
        family->render(technique, sc.lights, options, f, stats);
    } catch (...) {
        families->erase(entry->name);  // half-updated caches: made afresh next time
        throw;
    }
    if (fresh_scene) {
        impl_->families = std::move(fresh_families);  // the old families go before their scene
        impl_->scene = std::move(fresh_scene);
    }
    impl_->first_render = false;
    return out;
}

RasterResult run_raster(const Scenario& scenario, const Technique& technique, const VulkanContext& ctx) {
    RasterSession session(scenario, ctx);
    return session.render(technique);
}

}  // namespace penumbra::raster
