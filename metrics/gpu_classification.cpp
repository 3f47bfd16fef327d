#include "metrics/gpu_classification.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

#include "classify_comp.h"
#include "common/errors.h"
#include "metrics/perceptual.h"
#include "metrics/score_sums.h"
#include "raster/gpu_passes.h"

namespace penumbra::metrics {

using raster::create_buffer;
using raster::DescriptorResource;
using raster::GpuBuffer;

std::string_view to_string(Scorer s) {
    return s == Scorer::gpu ? "gpu" : "cpu";
}

Scorer preferred_scorer(const raster::VulkanContext& ctx) {
    if (const char* env = std::getenv("PENUMBRA_SCORER")) {
        const std::string v = env;
        if (v == "cpu") return Scorer::cpu;
        if (v == "gpu" && ctx.shader_float64()) return Scorer::gpu;
    }
    if (!ctx.shader_float64()) return Scorer::cpu;
    return ctx.info().type == "cpu" ? Scorer::cpu : Scorer::gpu;
}

namespace {

// shaders/classify.comp's buffers, byte for byte.
struct OraclePixel {
    std::uint32_t bucket;
    float V, E, boundary_m, occluder_m;
    std::uint32_t prim;
};
static_assert(sizeof(OraclePixel) == 24);
constexpr std::uint32_t kOracleSurface = 16;

struct GpuRow {
    std::uint32_t surface, scored, back_facing, uncertain, coverage_mismatch;
    std::array<std::uint32_t, 6> counts, counts_visible;
    std::uint32_t acne_measured;
    std::array<std::uint32_t, 3> region_pixels;
    std::uint32_t band_oracle, band_raster, pad;
    double abs_sum, sq_sum, signed_sum, gap_sum, gap_max, acne_sum, acne_max;
    std::array<double, 3> region_abs;
    double penumbra_excess;
};
static_assert(sizeof(GpuRow) == 184 && offsetof(GpuRow, abs_sum) == 96);

struct Push {
    std::uint32_t width, height, mode, flags;
    float tolerance, visible_threshold, filter_reach_texels, depth_quantum;
    float aliasing_band_m, peter_panning_reach_m;
    float width_lo, width_hi;
};
constexpr std::uint32_t kModeLookups = 0, kModeGeometry = 1, kSoft = 1, kLightBleed = 2;
constexpr std::array<raster::BindingDecl, 8> kBindings = {{
    {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // oracle pixels
    {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // the lookups (LookupTexel per pixel)
    {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // or V alone: the same buffer, read as its mode says
    {3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // row sums
    {4, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // class per pixel
    {5, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // error per pixel
    {6, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // the perceptual error's test picture per pixel
    {7, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},  // the peter-panning gaps: a count, then the gaps
}};

// The bucket of docs/metrics.md ("Which pixels are scored"), as classification.cpp's bucket_of.
std::uint32_t bucket_of(const OracleFrame& of, const RasterFrame& camera, const OracleLightImage& o, std::size_t i) {
    if (of.A[i] == 0)
        return static_cast<std::uint32_t>(camera.A[i] != 0 ? PixelClass::coverage_mismatch : PixelClass::background);
    PixelClass c = PixelClass::correct;
    if (camera.A[i] == 0 || camera.prim[i] != of.prim[i])
        c = PixelClass::coverage_mismatch;
    else if (o.lightable[i] == 0)
        c = PixelClass::back_facing;
    else if (o.U[i] != 0)
        c = PixelClass::uncertain;
    return static_cast<std::uint32_t>(c) | kOracleSurface;
}

}  // namespace

struct GpuScorer::Impl {
    const raster::VulkanContext& ctx;
    const OracleFrame& oracle;
    std::uint32_t width, height;
    std::size_t pixels;
    bool direct;  // the device shares host memory: outputs are read where they are written
    raster::DescriptorSets sets;
    raster::UniquePipelineLayout layout;
    raster::UniquePipeline pipeline;
    struct Light {
        GpuBuffer oracle, rows, cls, errors, shown;
        // Host-visible: only the few peter-panning pixels write it, and their gaps' percentile
        // then needs no class map read back.
        GpuBuffer gaps;
        GpuBuffer cls_host, errors_host, shown_host;        // discrete devices, made on first need
        std::vector<float> truth;                           // the perceptual error's reference picture
        std::optional<PerceptualReference> filtered_truth;  // its filters, once a run needed them
    };
    std::vector<Light> lights;
    std::vector<std::uint32_t> camera_prim;  // the camera pass the buckets were made with
    std::uint64_t camera_pass = 0;           // its RasterStats::camera_pass, once a render named it

    Impl(const raster::VulkanContext& c, const OracleFrame& of)
        : ctx(c),
          oracle(of),
          width(static_cast<std::uint32_t>(of.width)),
          height(static_cast<std::uint32_t>(of.height)),
          pixels(of.pixel_count()),
          direct(c.info().type == "cpu" || c.info().type == "integrated-gpu"),
          sets(c, kBindings, VK_SHADER_STAGE_COMPUTE_BIT) {}

    // Uploads what the oracle and the camera pass fix per pixel (again when the camera pass
    // changed: a technique of another precision redraws it).
    void prepare(const RasterFrame& camera) {
        const std::size_t n = pixels;
        if (camera.width != oracle.width || camera.height != oracle.height || camera.A.size() != n ||
            camera.prim.size() != n)
            throw std::invalid_argument("GpuScorer: oracle and camera pass differ in size");
        camera_prim = camera.prim;
        lights.clear();
        std::vector<OraclePixel> px(n);
        const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
        for (const OracleLightImage& o : oracle.lights) {
            for (std::size_t size :
                 {o.V.size(), o.E.size(), o.U.size(), o.lightable.size(), o.occluder_m.size(), o.boundary_m.size()})
                if (size != n) throw std::invalid_argument("GpuScorer: an oracle light image has the wrong size");
            for (std::size_t i = 0; i < n; ++i)
                px[i] = {
                    bucket_of(oracle, camera, o, i), o.V[i], o.E[i], o.boundary_m[i], o.occluder_m[i], oracle.prim[i]};
            Light& l = lights.emplace_back();
            l.truth.resize(n);
            for (std::size_t i = 0; i < n; ++i) l.truth[i] = oracle.A[i] != 0 ? o.V[i] : 0.0f;
            l.oracle = raster::upload(ctx, px.data(), n * sizeof(OraclePixel), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
            l.rows = create_buffer(ctx, height * sizeof(GpuRow), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true);
            l.cls = create_buffer(ctx, n * 4, storage, direct);
            l.errors = create_buffer(ctx, n * 4, storage, direct);
            l.shown = create_buffer(ctx, n * 4, storage, direct);
            l.gaps = create_buffer(ctx, (n + 1) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true);
        }
    }

    const GpuBuffer& host(const GpuBuffer& device, GpuBuffer& staging) {
        if (direct) return device;
        if (!staging.buffer) staging = create_buffer(ctx, device.size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true);
        return staging;
    }
};

GpuScorer::GpuScorer(const raster::VulkanContext& ctx, const OracleFrame& oracle, const RasterFrame& camera) {
    if (!ctx.shader_float64())
        throw EnvironmentError(fmt::format("Vulkan device '{}' lacks shaderFloat64: no GPU scorer", ctx.info().name));
    const std::size_t n = oracle.pixel_count();
    if (oracle.A.size() != n || oracle.prim.size() != n)
        throw std::invalid_argument("GpuScorer: an oracle image has the wrong size");
    impl_ = std::make_unique<Impl>(ctx, oracle);
    Impl& m = *impl_;
    raster::UniqueShaderModule cs = raster::make_module(ctx, kClassifyComp, sizeof(kClassifyComp));
    m.layout = raster::make_pipeline_layout(ctx, m.sets.layout(), sizeof(Push), VK_SHADER_STAGE_COMPUTE_BIT);
    VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = cs.get();
    ci.stage.pName = "main";
    ci.layout = m.layout.get();
    VkPipeline p;
    VK_CHECK(vkCreateComputePipelines(ctx.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &p));
    m.pipeline = raster::UniquePipeline(ctx.device(), p);

    m.sets.reserve(oracle.lights.size());
    m.prepare(camera);
}

GpuScorer::~GpuScorer() = default;

bool GpuScorer::knows_camera(const raster::RasterStats& stats) const {
    return stats.camera_pass != 0 && stats.camera_pass == impl_->camera_pass;
}

void DeferredPerceptual::run(FrameScore& score) {
    // One light after another: run side by side (tbb::parallel_for) the lights' scratch images
    // made a 1,000-configuration sweep's resident memory grow 0.24 MB a configuration
    // (docs/sweep.md, "Down to the GPU's time").
    for (const Light& l : lights_) {
        const OracleFrame& of = *oracle_;
        LightErrorImage& img = score.images[l.index];
        LightScore& s = score.lights[l.index];
        const std::vector<float> shown(l.shown, l.shown + of.pixel_count());
        std::optional<PerceptualReference>& reference = *l.reference;
        if (!reference || reference->pixels_per_degree() != l.pixels_per_degree)
            reference.emplace(*l.truth, of.width, of.height, l.pixels_per_degree);
        img.perceptual = reference->error(shown);
        double sum = 0, mx = 0;
        for (std::size_t i = 0; i < img.perceptual.size(); ++i)
            if (of.A[i] != 0) {
                sum += img.perceptual[i];
                mx = std::max(mx, static_cast<double>(img.perceptual[i]));
            }
        s.perceptual = {s.pixels.surface ? sum / static_cast<double>(s.pixels.surface) : 0.0, mx};
    }
    lights_.clear();
}

std::optional<FrameScore> GpuScorer::score(const raster::RasterResult& rendered,
                                           std::span<const ScoringOptions> options, bool images,
                                           DeferredPerceptual* deferred) {
    Impl& m = *impl_;
    const std::size_t L = m.lights.size();
    const auto& out = rendered.stats.on_device;
    if (rendered.frame.width != m.oracle.width || rendered.frame.height != m.oracle.height ||
        rendered.frame.lights.size() != L)
        throw std::invalid_argument("GpuScorer: the render and the oracle differ in size or light count");
    if (L == 0) return FrameScore{};
    if (options.empty() || (options.size() != 1 && options.size() != L))
        throw std::invalid_argument("GpuScorer: need one ScoringOptions, or one per light");
    if (out.size() != L) return std::nullopt;
    if (!knows_camera(rendered.stats)) {
        if (rendered.frame.prim.empty()) return std::nullopt;  // rendered without the camera images
        if (rendered.frame.prim != m.camera_prim) m.prepare(rendered.frame);
        m.camera_pass = rendered.stats.camera_pass;
    }
    auto opt_of = [&](std::size_t li) -> const ScoringOptions& {
        return options.size() == 1 ? options[0] : options[li];
    };
    for (std::size_t li = 0; li < L; ++li) {
        const ScoringOptions& o = opt_of(li);
        if (!out[li].lookups && !(o.texel_footprint_m && o.bias_reach_m)) return std::nullopt;
        for (const std::optional<float>& scale : {o.texel_footprint_m, o.bias_reach_m})
            if (scale && !(*scale >= 0 && std::isfinite(*scale)))
                throw std::invalid_argument("GpuScorer: a given footprint or bias reach is not a finite length >= 0");
    }

    std::vector<Push> pushes(L);
    std::vector<ClassificationEvidence> evidence(L);
    for (std::size_t li = 0; li < L; ++li) {
        const ScoringOptions& o = opt_of(li);
        Push& p = pushes[li];
        p = {m.width,
             m.height,
             out[li].lookups ? kModeLookups : kModeGeometry,
             0u,
             o.tolerance,
             o.visible_threshold,
             o.filter_reach_texels,
             o.depth_quantum,
             0.0f,
             0.0f,
             kPenumbraWidthBand,
             1 - kPenumbraWidthBand};
        p.flags = (o.soft ? kSoft : 0u) | (o.light_bleeding ? kLightBleed : 0u);
        if (!out[li].lookups) {
            // classification.cpp's GeometryScales, from the given scales.
            ClassificationEvidence& ev = evidence[li];
            ev.source = Evidence::oracle_geometry;
            ev.texel_footprint_m = *o.texel_footprint_m;
            ev.bias_reach_m = *o.bias_reach_m;
            p.aliasing_band_m = (o.filter_reach_texels > 0 ? o.filter_reach_texels : 1.0f) * ev.texel_footprint_m;
            p.peter_panning_reach_m = ev.bias_reach_m + ev.texel_footprint_m;
        }
        const Impl::Light& l = m.lights[li];
        std::array<DescriptorResource, kBindings.size()> r{};
        r[0].buffer = {l.oracle.buffer.get(), 0, VK_WHOLE_SIZE};
        r[1].buffer = {out[li].buffer, 0, out[li].size};
        r[2].buffer = {out[li].buffer, 0, out[li].size};
        r[3].buffer = {l.rows.buffer.get(), 0, VK_WHOLE_SIZE};
        r[4].buffer = {l.cls.buffer.get(), 0, VK_WHOLE_SIZE};
        r[5].buffer = {l.errors.buffer.get(), 0, VK_WHOLE_SIZE};
        r[6].buffer = {l.shown.buffer.get(), 0, VK_WHOLE_SIZE};
        r[7].buffer = {l.gaps.buffer.get(), 0, VK_WHOLE_SIZE};
        m.sets.write(li, r);
        const std::uint32_t no_gaps = 0;
        std::memcpy(l.gaps.mapped, &no_gaps, sizeof(no_gaps));
    }
    m.ctx.submit_and_wait([&](VkCommandBuffer cmd) {
        // The lookups were written by an earlier submission: a fence wait makes no device write visible.
        raster::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                               VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, m.pipeline.get());
        for (std::size_t li = 0; li < L; ++li) {
            VkDescriptorSet set = m.sets[li];
            vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, m.layout.get(), 0, 1, &set, 0, nullptr);
            vkCmdPushConstants(cmd, m.layout.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(Push), &pushes[li]);
            vkCmdDispatch(cmd, m.height, 1, 1);  // a workgroup per row
        }
        raster::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                               VK_PIPELINE_STAGE_2_HOST_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                               VK_ACCESS_2_HOST_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
    });

    FrameScore result;
    result.lights.resize(L);
    result.images.resize(L);
    // What each light needs of the per-pixel outputs: everything for the perceptual error and
    // the images, nothing otherwise (the gaps' percentile reads the gaps alone).
    std::vector<bool> need_all(L);
    // Deferred and no images asked: the perceptual error's test picture alone comes back.
    const bool apart = deferred && !images;
    for (std::size_t li = 0; li < L; ++li) {
        const ScoringOptions& opt = opt_of(li);
        const auto* rows = static_cast<const GpuRow*>(m.lights[li].rows.mapped);
        // Rows added in order, as the CPU scorer adds its own (score_sums.h): the same sums.
        detail::RowSums t;
        for (std::uint32_t y = 0; y < m.height; ++y) {
            const GpuRow& r = rows[y];
            detail::RowSums row;
            row.pixels = {r.surface, r.scored, r.back_facing, r.uncertain, r.coverage_mismatch};
            for (std::size_t k = 0; k < 6; ++k) {
                row.counts[k] = r.counts[k];
                row.counts_visible[k] = r.counts_visible[k];
            }
            row.abs_sum = r.abs_sum;
            row.sq_sum = r.sq_sum;
            row.signed_sum = r.signed_sum;
            row.gap_sum = r.gap_sum;
            row.gap_max = r.gap_max;
            row.acne_sum = r.acne_sum;
            row.acne_max = r.acne_max;
            row.acne_measured = r.acne_measured;
            for (std::size_t k = 0; k < 3; ++k) {
                row.region_pixels[k] = r.region_pixels[k];
                row.region_abs[k] = r.region_abs[k];
            }
            row.penumbra_excess = r.penumbra_excess;
            row.band_oracle = r.band_oracle;
            row.band_raster = r.band_raster;
            t.add(row);
        }
        LightScore& s = result.lights[li];
        s.evidence = evidence[li];
        detail::fill_score(t, opt, s);
        const auto pp = s.count(PixelClass::peter_panning);
        result.images[li].visible_threshold = opt.visible_threshold;
        need_all[li] = images || opt.perceptual;
        if (pp > 0) {
            // Nearest rank, as score_light: the gaps' order does not change the value at a rank.
            const auto* g = static_cast<const std::uint32_t*>(m.lights[li].gaps.mapped);
            if (g[0] != pp) throw std::logic_error("GpuScorer: the gaps and the peter-panning count differ");
            std::vector<float> gaps(pp);
            std::memcpy(gaps.data(), g + 1, pp * sizeof(float));
            const std::size_t rank = (gaps.size() * 95 + 99) / 100 - 1;
            std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(rank), gaps.end());
            s.peter_panning_gap_p95 = gaps[rank];
        }
    }

    if (!m.direct && std::find(need_all.begin(), need_all.end(), true) != need_all.end()) {
        m.ctx.submit_and_wait([&](VkCommandBuffer cmd) {
            for (std::size_t li = 0; li < L; ++li) {
                Impl::Light& l = m.lights[li];
                auto copy = [&](const GpuBuffer& from, GpuBuffer& staging) {
                    const GpuBuffer& to = m.host(from, staging);
                    VkBufferCopy region{0, 0, from.size};
                    vkCmdCopyBuffer(cmd, from.buffer.get(), to.buffer.get(), 1, &region);
                };
                if (!need_all[li]) continue;
                if (!apart) {
                    copy(l.cls, l.cls_host);
                    copy(l.errors, l.errors_host);
                }
                copy(l.shown, l.shown_host);
            }
            raster::memory_barrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                   VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
        });
    }

    const std::size_t n = m.pixels;
    DeferredPerceptual own;
    DeferredPerceptual& later = deferred ? *deferred : own;
    later.oracle_ = &m.oracle;
    later.lights_.clear();
    for (std::size_t li = 0; li < L; ++li) {
        if (!need_all[li]) continue;
        Impl::Light& l = m.lights[li];
        const ScoringOptions& opt = opt_of(li);
        if (!apart) {
            LightErrorImage& img = result.images[li];
            const auto* cls = static_cast<const std::uint32_t*>(m.host(l.cls, l.cls_host).mapped);
            const auto* err = static_cast<const float*>(m.host(l.errors, l.errors_host).mapped);
            img.cls.resize(n);
            for (std::size_t i = 0; i < n; ++i) img.cls[i] = static_cast<std::uint8_t>(cls[i]);
            img.error.assign(err, err + n);
        }
        if (!opt.perceptual) continue;
        // As score_light: both pictures agree wherever the pixel is not scored (the shader made
        // the test picture so).
        DeferredPerceptual::Light& p = later.lights_.emplace_back();
        p.index = li;
        p.pixels_per_degree = opt.pixels_per_degree;
        p.truth = &l.truth;
        p.reference = &l.filtered_truth;
        p.shown = static_cast<const float*>(m.host(l.shown, l.shown_host).mapped);
    }
    if (!deferred) later.run(result);
    return result;
}

}  // namespace penumbra::metrics
