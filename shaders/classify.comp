#version 460
#extension GL_GOOGLE_include_directive : require
// The verdict per pixel on the GPU (metrics/gpu_classification.h): the rules of
// metrics/classification.cpp, one workgroup per image row and light. The pixels of a row are
// classified in parallel, a chunk of kChunk at a time; every double sum then runs over the
// chunk's pixels in the CPU's order, one invocation per sum, and every float operation is the
// CPU's own (`precise`: no fused multiply-add), making counts and sums identical to the
// reference. Counts are integers: any order gives them. The host adds the rows in order, as
// the CPU does.
#include "penumbra_shared.h"

const uint kChunk = 256u;
layout(local_size_x = 256) in;

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

// RowSums of metrics/classification.cpp (the gaps aside: they go to `gaps`, in no order, which
// their percentile does not need).
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
// The perceptual error's test picture: the raster's V where the pixel is scored, the truth
// (the oracle's V on a surface, else 0) elsewhere, as score_light makes it.
layout(std430, binding = 6) writeonly buffer Shown { float shown[]; };
// The peter-panning gaps of the light, appended in any order (count zeroed by the host).
layout(std430, binding = 7) buffer Gaps {
    uint gap_count;
    float gaps[];
};

const uint kModeLookups = 0u, kModeGeometry = 1u;
const uint kSoft = 1u, kLightBleed = 2u;
layout(push_constant) uniform Push {
    uint width, height, mode, flags;
    float tolerance, visible_threshold, filter_reach_texels, depth_quantum;
    float aliasing_band_m, peter_panning_reach_m;  // kModeGeometry: scales.aliasing_band_m, bias_reach + footprint
    float width_lo, width_hi;                      // the soft lights' penumbra-width band
}
pc;

// What each pixel of the chunk adds to the double sums, and when (kAdd* bits).
const uint kAddScored = 1u, kAddPeterPanning = 2u, kAddAcne = 4u, kAddRegion = 8u, kRegionShift = 4u;
shared float c_error[kChunk], c_excess[kChunk], c_gap[kChunk], c_acne[kChunk];
shared uint c_adds[kChunk];

// The integer counts, in Row's order: surface .. band_raster.
const uint kSurface = 0u, kScored = 1u, kBackFacingCount = 2u, kUncertainCount = 3u, kMismatch = 4u, kClass = 5u,
           kVisible = 11u, kAcneMeasured = 17u, kRegion = 18u, kBandOracle = 21u, kBandRaster = 22u, kCounts = 23u;
shared uint c_counts[kCounts];
// The nine double sums (abs, sq, signed, gap, acne, region 0..2, penumbra excess) and two maxima.
const uint kSums = 9u;
shared double c_sums[kSums], c_most[kSums];

void main() {
    const uint y = gl_WorkGroupID.x;
    const uint tid = gl_LocalInvocationID.x;
    if (tid < kCounts) c_counts[tid] = 0u;
    uint counts[kCounts];
    for (uint k = 0u; k < kCounts; ++k) counts[k] = 0u;
    // Invocation k < kSums keeps sum k (and the gap's and acne's maxima), as RowSums adds them.
    precise double sum = 0.0lf;
    double most = 0.0lf;
    const bool lookups = pc.mode == kModeLookups;

    for (uint x0 = 0u; x0 < pc.width; x0 += kChunk) {
        const uint x = x0 + tid;
        uint adds = 0u;
        float e_out = 0.0, excess_out = 0.0, gap_out = 0.0, acne_out = 0.0;
        if (x < pc.width) {
            const uint i = y * pc.width + x;
            OraclePixel o = oracle[i];
            float rv;  // not a ?: a V-only output is too short to read as texels
            if (lookups)
                rv = texels[i].V;
            else
                rv = visibility[i];
            uint bucket = o.bucket & 15u;
            uint c = bucket;
            precise float e = 0.0;
            if ((o.bucket & kOracleSurface) != 0u) {
                ++counts[kSurface];
                if (bucket == kCoverageMismatch) {
                    ++counts[kMismatch];
                } else if (bucket == kBackFacing) {
                    ++counts[kBackFacingCount];
                } else if (bucket == kUncertain) {
                    ++counts[kUncertainCount];
                } else {
                    ++counts[kScored];
                    e = rv - o.V;
                    precise float ae = abs(e);
                    adds |= kAddScored;
                    e_out = e;
                    c = kCorrect;
                    precise float margin = pc.tolerance + o.E;
                    if ((pc.flags & kSoft) != 0u) {
                        precise float upper = 1.0 - margin;
                        uint region = o.V <= margin ? 0u : o.V >= upper ? 2u : 1u;
                        ++counts[kRegion + region];
                        adds |= kAddRegion | (region << kRegionShift);
                        precise float excess = ae - o.E;
                        excess_out = max(0.0, excess);
                        if (o.V > pc.width_lo && o.V < pc.width_hi) ++counts[kBandOracle];
                        if (rv > pc.width_lo && rv < pc.width_hi) ++counts[kBandRaster];
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
                                acne_out = depth;
                                adds |= kAddAcne;
                                ++counts[kAcneMeasured];
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
                        ++counts[kClass + k];
                        if (ae >= pc.visible_threshold) ++counts[kVisible + k];
                        if (c == kPeterPanning) {
                            gap_out = o.occluder_m;
                            adds |= kAddPeterPanning;
                            gaps[atomicAdd(gap_count, 1u)] = o.occluder_m;
                        }
                    }
                }
            }
            cls[i] = c;
            errors[i] = e;
            const float truth = (o.bucket & kOracleSurface) != 0u ? o.V : 0.0;
            shown[i] = c >= kCorrect ? rv : truth;
        }
        c_error[tid] = e_out;
        c_excess[tid] = excess_out;
        c_gap[tid] = gap_out;
        c_acne[tid] = acne_out;
        c_adds[tid] = adds;
        barrier();
        // The double sums over the chunk, pixel by pixel in x order, each on its own invocation
        // (the same code on each: no divergence within the loop).
        if (tid < kSums) {
            const uint n = min(kChunk, pc.width - x0);
            for (uint j = 0u; j < n; ++j) {
                const uint a = c_adds[j];
                const bool scored = (a & kAddScored) != 0u;
                const uint region = (a & kAddRegion) != 0u ? (a >> kRegionShift) & 3u : 3u;
                precise float ae = abs(c_error[j]);
                precise double ed = double(c_error[j]);
                precise double sq = ed * ed;
                double term = double(ae);
                bool add = scored;  // abs, and region k's |error| below
                if (tid == 1u) term = sq;
                if (tid == 2u) term = ed;
                if (tid == 3u) {
                    term = double(c_gap[j]);
                    add = (a & kAddPeterPanning) != 0u;
                }
                if (tid == 4u) {
                    term = double(c_acne[j]);
                    add = (a & kAddAcne) != 0u;
                }
                if (tid >= 5u && tid < 8u) add = region == tid - 5u;
                if (tid == 8u) {
                    term = double(c_excess[j]);
                    add = region == 1u;
                }
                if (add) {
                    sum += term;
                    most = max(most, term);
                }
            }
        }
        barrier();
    }
    for (uint k = 0u; k < kCounts; ++k)
        if (counts[k] != 0u) atomicAdd(c_counts[k], counts[k]);
    if (tid < kSums) {
        c_sums[tid] = sum;
        c_most[tid] = most;
    }
    barrier();
    if (tid == 0u) {
        Row s;
        s.surface = c_counts[kSurface];
        s.scored = c_counts[kScored];
        s.back_facing = c_counts[kBackFacingCount];
        s.uncertain = c_counts[kUncertainCount];
        s.coverage_mismatch = c_counts[kMismatch];
        for (uint k = 0u; k < 6u; ++k) {
            s.counts[k] = c_counts[kClass + k];
            s.counts_visible[k] = c_counts[kVisible + k];
        }
        s.acne_measured = c_counts[kAcneMeasured];
        for (uint k = 0u; k < 3u; ++k) {
            s.region_pixels[k] = c_counts[kRegion + k];
            s.region_abs[k] = c_sums[5u + k];
        }
        s.band_oracle = c_counts[kBandOracle];
        s.band_raster = c_counts[kBandRaster];
        s.pad = 0u;
        s.abs_sum = c_sums[0];
        s.sq_sum = c_sums[1];
        s.signed_sum = c_sums[2];
        s.gap_sum = c_sums[3];
        s.gap_max = c_most[3];
        s.acne_sum = c_sums[4];
        s.acne_max = c_most[4];
        s.penumbra_excess = c_sums[8];
        rows[y] = s;
    }
}
