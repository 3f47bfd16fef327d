// Raster path speed: GPU time of the shadow passes against a bare depth-only pass of the same
// triangles, size, format and light matrix in the same run: the diagnostic pass (it also writes
// the triangle id per texel, for the acne rule) and the production pass (depth-only, what a
// V-only render draws: the ratio is what penumbra's production figure pays beyond an engine's
// bare pass), and of the camera pass (camera raster + per-light lookup),
// at shadow-map resolutions 1024^2 ... 8192^2, 1280 x 720 pixels, on the chosen Vulkan device
// (lavapipe unless --device or $PENUMBRA_VK_DEVICE says otherwise).
//
// Scene: the bundled default scenario with only its directional light (one map per run), plus
// a terrain to load the rasteriser: --terrain (131k triangles) or --terrain-grid N (2 N^2, e.g.
// 1024 for 2.1M). Median of --repeat runs per resolution on one session, every map drawn, the
// three passes interleaved in each run (a device whose speed drifts moves all three alike);
// one warm-up run of each first, discarded; wall clock includes submission and waiting, not setup.
// A last row draws the sun in 4 cascades of 2048^2 (the cascaded family), against 4 bare passes
// of the same views (its production column is not measured: "-").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/raster_bench_args.h"
#include "common/scenario.h"
#include "raster/gpu_passes.h"
#include "raster/raster.h"
// SPIR-V compiled from shaders/ at build time.
#include "shadow_vert.h"

namespace {

using namespace penumbra;
using bench::median;

// The anchor: the same triangles into a depth-only target of the same size and format from the
// same light matrix, vertex shader only, no colour target, no bias: what an engine's bare depth
// pass costs on this device. The diagnostic shadow pass also writes the triangle id per texel
// (for the acne rule), which is what it pays beyond this; the production pass should not.
class BareDepthPass {
  public:
    BareDepthPass(const raster::VulkanContext& ctx, const Scene& scene, const glm::dvec3& origin) : ctx_(ctx) {
        std::vector<float> pos;
        for (const glm::dvec3& p : scene.positions) {
            const glm::dvec3 r = p - origin;
            pos.insert(pos.end(), {static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z)});
        }
        std::vector<std::uint32_t> idx;
        for (const auto& t : scene.triangles) idx.insert(idx.end(), {t.x, t.y, t.z});
        count_ = static_cast<std::uint32_t>(idx.size());
        positions_ = raster::upload(ctx, pos.data(), pos.size() * sizeof(float), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
        indices_ =
            raster::upload(ctx, idx.data(), idx.size() * sizeof(std::uint32_t), VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
        layout_ = raster::make_pipeline_layout(ctx, VK_NULL_HANDLE, sizeof(glm::mat4), VK_SHADER_STAGE_VERTEX_BIT);
        make_pipeline();
        VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
        qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
        qi.queryCount = 2;
        VkQueryPool qp;
        VK_CHECK(vkCreateQueryPool(ctx.device(), &qi, nullptr, &qp));
        queries_ = raster::UniqueQueryPool(ctx.device(), qp);
    }

    double render_ms(const glm::dmat4& view_proj, std::uint32_t res) {
        if (depth_.width != res)
            depth_ = raster::create_image(ctx_, kFormat, res, res, 1, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                                          VK_IMAGE_ASPECT_DEPTH_BIT, false);
        const glm::mat4 vp(view_proj);
        ctx_.submit_and_wait([&](VkCommandBuffer cmd) {
            vkCmdResetQueryPool(cmd, queries_.get(), 0, 2);
            raster::image_barrier(cmd, depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, 1, VK_IMAGE_LAYOUT_UNDEFINED,
                                  VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                                  raster::kFragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
            vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), 0);
            VkRenderingAttachmentInfo da{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
            da.imageView = depth_.view.get();
            da.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
            da.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
            da.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
            da.clearValue.depthStencil.depth = 1.0f;
            VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
            ri.renderArea = {{0, 0}, {res, res}};
            ri.layerCount = 1;
            ri.pDepthAttachment = &da;
            vkCmdBeginRendering(cmd, &ri);
            raster::set_viewport(cmd, res, res);
            vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.get());
            vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(vp), &vp);
            vkCmdSetDepthBias(cmd, 0.0f, 0.0f, 0.0f);  // dynamic in the shared pipeline set-up; no bias here
            VkDeviceSize zero = 0;
            vkCmdBindVertexBuffers(cmd, 0, 1, positions_.buffer.ptr(), &zero);
            vkCmdBindIndexBuffer(cmd, indices_.buffer.get(), 0, VK_INDEX_TYPE_UINT32);
            vkCmdDrawIndexed(cmd, count_, 1, 0, 0, 0);
            vkCmdEndRendering(cmd);
            vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries_.get(), 1);
        });
        std::uint64_t t[2] = {0, 0};
        VK_CHECK(vkGetQueryPoolResults(ctx_.device(), queries_.get(), 0, 2, sizeof(t), t, sizeof(std::uint64_t),
                                       VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
        return raster::ticks_to_ms(ctx_, t[0], t[1]);
    }

  private:
    static constexpr VkFormat kFormat = VK_FORMAT_D32_SFLOAT;  // the technique's d32

    void make_pipeline() {
        // The shadow pass's state (depth clamp, back-face culling, LESS), no fragment shader.
        pipeline_ =
            raster::make_graphics_pipeline(ctx_, layout_.get(),
                                           {kShadowVert, sizeof(kShadowVert), nullptr, 0, kFormat, VK_COMPARE_OP_LESS,
                                            VK_CULL_MODE_BACK_BIT, VK_FRONT_FACE_CLOCKWISE, true, false});
    }

    const raster::VulkanContext& ctx_;
    raster::GpuBuffer positions_, indices_;
    std::uint32_t count_ = 0;
    raster::UniquePipelineLayout layout_;
    raster::UniquePipeline pipeline_;
    raster::UniqueQueryPool queries_;
    raster::GpuImage depth_;
};

}  // namespace

int main(int argc, char** argv) {
    const auto args = bench::parse_raster_bench_args(argc, argv, "raster_bench", 3, true);
    if (!args) return 2;
    const int repeat = args->repeat;
    try {
        Scenario sc = load_scenario(args->scenario);
        sc.lights.resize(1);  // the directional light: one map per run
        if (args->terrain_grid > 0) bench::add_terrain(sc.scene, args->terrain_grid);
        raster::ContextOptions co;
        co.device = args->device;
        raster::VulkanContext ctx(co);
        std::printf("device: %s (%s)\nscene: %zu triangles, %dx%d px, 1 directional light\n", ctx.info().name.c_str(),
                    ctx.info().driver.c_str(), sc.scene.triangle_count(), sc.width, sc.height);
        BareDepthPass bare(ctx, sc.scene, sc.camera.eye);
        std::printf("%-10s %10s %10s %10s %9s %9s %14s %10s %10s\n", "map", "diag ms", "prod ms", "bare ms",
                    "diag/bare", "prod/bare", "camera+lookup", "lookup ms", "wall ms");
        for (int res : {1024, 2048, 4096, 8192}) {
            raster::Technique t = raster::parse_technique({{"resolution", res}, {"bias", {{"slope", 1.5}}}}, "bench");
            std::vector<double> shadow, production, depth_only, camera, lookup, wall;
            raster::RasterSession session(sc, ctx);
            raster::RenderOptions fresh;  // every render draws its map: timing runs reuse nothing
            fresh.reuse_maps = false;
            raster::RenderOptions v_only = fresh;  // the production render: depth-only maps, V alone
            v_only.lookups = false;
            const raster::RasterResult first = session.render(t, fresh);  // warm-up: pipelines, first touch
            session.render(t, v_only);
            const glm::dmat4 view_proj = first.stats.lights[0].projection.view_proj[0];
            bare.render_ms(view_proj, static_cast<std::uint32_t>(res));
            for (int r = 0; r < repeat; ++r) {
                raster::RasterResult out = session.render(t, fresh);
                shadow.push_back(out.stats.gpu_ms["shadow"]);
                production.push_back(session.render(t, v_only).stats.gpu_ms["shadow"]);
                depth_only.push_back(bare.render_ms(view_proj, static_cast<std::uint32_t>(res)));
                camera.push_back(out.stats.camera_ms + out.stats.gpu_ms["lookup"]);
                lookup.push_back(out.stats.gpu_ms["lookup"]);
                wall.push_back(out.stats.render_s * 1e3);
            }
            const double bare_ms = std::max(median(depth_only), 1e-9);
            std::printf("%5d^2    %10.3f %10.3f %10.3f %9.2f %9.2f %14.2f %10.2f %10.2f\n", res, median(shadow),
                        median(production), median(depth_only), median(shadow) / bare_ms, median(production) / bare_ms,
                        median(camera), median(lookup), median(wall));
        }
        {  // issue #34: a sun in 4 cascades of 2048^2 (the cascaded family's defaults), every layer drawn
            const raster::Technique t = raster::parse_technique(
                {{"family", "cascaded"}, {"resolution", 2048}, {"bias", {{"slope", 1.5}}}}, "bench");
            std::vector<double> shadow, depth_only, camera, lookup, wall;
            raster::RasterSession session(sc, ctx);
            raster::RenderOptions fresh;
            fresh.reuse_maps = false;
            const raster::RasterResult first = session.render(t, fresh);
            const std::vector<glm::dmat4> views = first.stats.lights[0].projection.view_proj;
            for (const glm::dmat4& v : views) bare.render_ms(v, 2048);
            for (int r = 0; r < repeat; ++r) {
                raster::RasterResult out = session.render(t, fresh);
                shadow.push_back(out.stats.gpu_ms["shadow"]);
                double bare_ms = 0;
                for (const glm::dmat4& v : views) bare_ms += bare.render_ms(v, 2048);
                depth_only.push_back(bare_ms);
                camera.push_back(out.stats.camera_ms + out.stats.gpu_ms["lookup"]);
                lookup.push_back(out.stats.gpu_ms["lookup"]);
                wall.push_back(out.stats.render_s * 1e3);
            }
            const double bare_ms = std::max(median(depth_only), 1e-9);
            std::printf("%zux2048^2 %10.3f %10s %10.3f %9.2f %9s %14.2f %10.2f %10.2f  (cascades)\n", views.size(),
                        median(shadow), "-", median(depth_only), median(shadow) / bare_ms, "-", median(camera),
                        median(lookup), median(wall));
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raster_bench: %s\n", e.what());
        return 3;
    }
    return 0;
}
