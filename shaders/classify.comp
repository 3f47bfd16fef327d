#version 460
#extension GL_GOOGLE_include_directive : require
// The verdict per pixel on the GPU (metrics/gpu_classification.h): the rules of
// metrics/classification.cpp, one invocation per image row and light so that every sum runs
// over the row's pixels in the CPU's order, in double, and every float operation is the CPU's
// own (`precise`: no fused multiply-add), making counts and sums identical to the reference.
// The host adds the rows in order, as the CPU does.
#include "penumbra_shared.h"

layout(local_size_x = 64) in;

// What the oracle (and the session's camera pass) fixed per pixel, uploaded once per session.
struct OraclePixel {
    uint bucket;  // PixelClass of the pixel's bucket (4 = scored) | kOracleSurface
    float V, E, boundary_m, occluder_m;
    uint prim;  // the oracle's triangle
};
const uint kOracleSurface = 16u;

// PixelClass ids (metrics/classification.h).
const uint kBackground = 0u, kBackFacing = 1u, kUncertain = 2u, kCoverageMismatch = 3u, kCorrect = 4u,
           kAliasing = 5u, kAcne = 6u, kPeterPanning = 7u, kFalseShadow = 8u, kFalseLit = 9u, kLightBleeding = 10u;
// Index in kErrorClasses: acne, peter_panning, aliasing, false_shadow, false_lit, light_bleeding.
uint error_index(uint c) {
    if (c == kAcne) return 0u;
    if (c == kPeterPanning) return 1u;
    if (c == kAliasing) return 2u;
    if (c == kFalseShadow) return 3u;
    if (c == kFalseLit) return 4u;
    return 5u;
}

// RowSums of metrics/classification.cpp (the gaps list aside: the host reads it from `cls`).
struct Row {
    uint surface, scored, back_facing, uncertain, coverage_mismatch;
    uint counts[6];
    uint counts_visible[6];
    uint acne_measured;
    uint region_pixels[3];
    uint band_oracle, band_raster;
    uint pad;
    double abs_sum, sq_sum, signed_sum, gap_sum, gap_max, acne_sum, acne_max;
    double region_abs[3];
    double penumbra_excess;
};

layout(std430, binding = 0) readonly buffer Oracle { OraclePixel oracle[]; };
layout(std430, binding = 1) readonly buffer Lookups { LookupTexel texels[]; };
layout(std430, binding = 2) readonly buffer Visibility { float visibility[]; };
layout(std430, binding = 3) writeonly buffer Rows { Row rows[]; };
layout(std430, binding = 4) writeonly buffer Classes { uint cls[]; };
layout(std430, binding = 5) writeonly buffer Errors { float errors[]; };
layout(std430, binding = 6) writeonly buffer Shown { float raster_v[]; };

const uint kModeLookups = 0u, kModeGeometry = 1u;
const uint kSoft = 1u, kLightBleed = 2u;
layout(push_constant) uniform Push {
    uint width, height, mode, flags;
    float tolerance, visible_threshold, filter_reach_texels, depth_quantum;
    float aliasing_band_m, peter_panning_reach_m;  // kModeGeometry: scales.aliasing_band_m, bias_reach + footprint
    float width_lo, width_hi;                      // the soft lights' penumbra-width band
}
pc;

void main() {
    uint y = gl_GlobalInvocationID.x;
    if (y >= pc.height) return;
    Row s;
    s.surface = 0u;
    s.scored = 0u;
    s.back_facing = 0u;
    s.uncertain = 0u;
    s.coverage_mismatch = 0u;
    for (int k = 0; k < 6; ++k) {
        s.counts[k] = 0u;
        s.counts_visible[k] = 0u;
    }
    s.acne_measured = 0u;
    s.region_pixels[0] = s.region_pixels[1] = s.region_pixels[2] = 0u;
    s.band_oracle = 0u;
    s.band_raster = 0u;
    s.pad = 0u;
    s.abs_sum = s.sq_sum = s.signed_sum = s.gap_sum = s.gap_max = s.acne_sum = s.acne_max = 0.0lf;
    s.region_abs[0] = s.region_abs[1] = s.region_abs[2] = 0.0lf;
    s.penumbra_excess = 0.0lf;

    for (uint x = 0u; x < pc.width; ++x) {
        uint i = y * pc.width + x;
        OraclePixel o = oracle[i];
        bool lookups = pc.mode == kModeLookups;
        float rv;  // not a ?: a V-only output is too short to read as texels
        if (lookups)
            rv = texels[i].V;
        else
            rv = visibility[i];
        raster_v[i] = rv;
        uint bucket = o.bucket & 15u;
        uint c = bucket;
        precise float e = 0.0;
        if ((o.bucket & kOracleSurface) != 0u) {
            ++s.surface;
            if (bucket == kCoverageMismatch) {
                ++s.coverage_mismatch;
            } else if (bucket == kBackFacing) {
                ++s.back_facing;
            } else if (bucket == kUncertain) {
                ++s.uncertain;
            } else {
                ++s.scored;
                e = rv - o.V;
                precise float ae = abs(e);
                s.abs_sum += double(ae);
                precise double ed = double(e);
                precise double sq = ed * ed;
                s.sq_sum += sq;
                s.signed_sum += ed;
                c = kCorrect;
                precise float margin = pc.tolerance + o.E;
                if ((pc.flags & kSoft) != 0u) {
                    precise float upper = 1.0 - margin;
                    uint region = o.V <= margin ? 0u : o.V >= upper ? 2u : 1u;
                    ++s.region_pixels[region];
                    s.region_abs[region] += double(ae);
                    precise float excess = ae - o.E;
                    if (region == 1u) s.penumbra_excess += double(max(0.0, excess));
                    if (o.V > pc.width_lo && o.V < pc.width_hi) ++s.band_oracle;
                    if (rv > pc.width_lo && rv < pc.width_hi) ++s.band_raster;
                }
                if (ae > margin) {
                    if (lookups) {
                        LookupTexel t = texels[i];
                        precise float reach = pc.filter_reach_texels * t.footprint_m;
                        precise float slope = t.texel_slope + pc.depth_quantum;
                        precise float gap = t.ref_depth - t.stored_depth;
                        precise float pp_reach = t.bias_m + t.footprint_m;
                        if (t.footprint_m > 0.0 && o.boundary_m <= reach) {
                            c = kAliasing;
                        } else if (e < 0.0) {
                            bool in_map = (t.flags & kFlagOutsideMap) == 0u;
                            c = in_map && (t.stored_prim == o.prim || gap <= slope) ? kAcne : kFalseShadow;
                        } else {
                            c = o.occluder_m <= pp_reach ? kPeterPanning : kFalseLit;
                        }
                        if (c == kAcne && t.ref_depth > t.stored_depth) {
                            // Only where the centre texel itself holds the receiver behind.
                            precise float depth = gap * t.depth_to_m;
                            s.acne_sum += double(depth);
                            s.acne_max = max(s.acne_max, double(depth));
                            ++s.acne_measured;
                        }
                    } else {
                        if (pc.aliasing_band_m > 0.0 && o.boundary_m <= pc.aliasing_band_m)
                            c = kAliasing;
                        else if (e < 0.0)
                            c = isinf(o.occluder_m) ? kAcne : kFalseShadow;
                        else
                            c = o.occluder_m <= pc.peter_panning_reach_m ? kPeterPanning : kFalseLit;
                    }
                    if (c == kFalseLit && (pc.flags & kLightBleed) != 0u && o.V <= margin) c = kLightBleeding;
                    uint k = error_index(c);
                    ++s.counts[k];
                    if (ae >= pc.visible_threshold) ++s.counts_visible[k];
                    if (c == kPeterPanning) {
                        s.gap_sum += double(o.occluder_m);
                        s.gap_max = max(s.gap_max, double(o.occluder_m));
                    }
                }
            }
        }
        cls[i] = c;
        errors[i] = e;
    }
    rows[y] = s;
}
