// The lookup pass's core, shared by every depth-map family (docs/raster.md, "Adding a depth-map
// variant"): one dispatch per light rebuilds the surface point the oracle uses (the pixel centre's
// ray against the triangle the camera pass saw), applies the technique's receiver biases and
// filters the shadow map. Every compare is done here on texelFetch'd depths, so a verdict is
// reproducible bit for bit; the linear comparison sampler is used only for "hw2x2" on devices
// that support it.
//
// A family's lookup is a .comp file of its own (raster/*_lookup.comp, shaders/lookup_depth_map.comp)
// that includes this file, defines the hooks declared below, and includes lookup_main.glsl. Each
// is compiled on its own, so a driver compiles only the family a technique uses.
#include "penumbra_shared.h"

layout(local_size_x = 8, local_size_y = 8) in;

// Ids must match kSpec* in penumbra_shared.h (GLSL wants literals here).
layout(constant_id = 0) const uint kLightKind = 0;
layout(constant_id = 1) const uint kFilterType = 0;  // kFilter*, or a family's own kind (its lookup reads it)
layout(constant_id = 2) const uint kPcfSize = 3;
layout(constant_id = 3) const uint kPoissonTapCount = 16;
layout(constant_id = 4) const uint kBilinearTaps = 0;
layout(constant_id = 5) const uint kReceiverPlane = 0;
layout(constant_id = 6) const uint kHardwareCompare = 0;
layout(constant_id = 7) const uint kMode = 0;

layout(binding = kBindingGBufferPrim, r32ui) uniform readonly uimage2D gbuffer_prim;
layout(std430, binding = kBindingPositions) readonly buffer Positions { float positions[]; };
layout(std430, binding = kBindingIndices) readonly buffer Indices { uint indices[]; };
layout(binding = kBindingShadowDepth) uniform sampler2DArray shadow_depth;
layout(binding = kBindingShadowPrim) uniform usampler2DArray shadow_prim;
layout(binding = kBindingShadowCompare) uniform sampler2DArrayShadow shadow_compare;
layout(std140, binding = kBindingLookupParams) uniform Params { LookupParams p; };
layout(std430, binding = kBindingLookupOut) writeonly buffer Out { LookupTexel texels[]; };
layout(std430, binding = kBindingFaceMask) buffer FaceMask { uint face_mask; };
layout(std430, binding = kBindingVisibilityOut) writeonly buffer VisibilityOut { float visibility[]; };

// The verdict of pixel `i`: with every lookup behind it, or V alone.
void store(uint i, LookupTexel o) {
    if (kMode == kModeLookup) texels[i] = o;
    if (kMode == kModeVisibility) visibility[i] = o.V;
}

vec3 vertex(uint i) { return vec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); }
#include "surface_seen.glsl"

// Suns: light from one direction, in one map or in several layers (a family's, e.g. cascades).
const bool kDirectional = kLightKind == kLightDirectional;

// The family's hooks, defined by the file that includes this one (lookup_main.glsl calls them).
// The layer (shadow view) that holds receiver point P: kMaxLayers or more for none.
uint select_layer(vec3 P);
// Shadow-map texel size at P in `layer`, metres.
float layer_footprint(vec3 P, uint layer);
// The receiver's world bias (metres) and the hardware constant bias of `layer`.
float world_bias(uint layer);
float constant_bias(uint layer);
// After the receiver biases: whether the biased point Pb, in `layer`, lies beyond every layer
// (then lit, flagged outside the map); `footprint` may become the layer's own.
bool beyond_layers(vec3 Pb, uint layer, inout float footprint);
// The technique's visibility of receiver m (texel coordinates and depth) in `layer`.
float family_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver);
// V of `layer` blended with another layer's where the family blends (v where it does not), and
// the texel that bounds the aliasing band there.
float blend_layers(uvec2 pix, uint layer, vec3 Pb, vec3 n, float h, float v);
float blended_footprint(vec3 Pb, uint layer, float footprint);

// reversed_z: the map and every depth a layer's view_proj gives are 1 - z; compares flip.
bool reversed_z() { return p.caster2.z > 0.5; }
// A map depth in the forward convention (what LookupTexel reports and the metrics read).
float forward_depth(float d) { return reversed_z() ? 1.0 - d : d; }
// 1 = lit: the reference at or in front of the stored depth (LESS_OR_EQUAL; GREATER_OR_EQUAL reversed).
bool lit_against(float ref, float stored) { return reversed_z() ? ref >= stored : ref <= stored; }

// How a normal offset scales with the angle to the light (kNormalFactor*): Godot and Unity URP
// take 1 - N.L, Filament and Babylon sin(theta).
float normal_factor(uint kind, float ndotl) {
    if (kind == kNormalFactorOneMinusNdotL) return 1.0 - max(ndotl, 0.0);
    if (kind == kNormalFactorSin) return sqrt(max(1.0 - ndotl * ndotl, 0.0));
    return 1.0;
}

// View depth of a camera-relative point (the eye is the origin for both projections).
float camera_depth(vec3 P) { return dot(P, p.cam_forward.xyz); }

// Continuous texel coordinates (texel i spans [i, i+1)) and depth in the layer.
vec3 to_map(vec3 X, uint layer) {
    vec4 c = p.view_proj[layer] * vec4(X, 1.0);
    vec3 n = c.xyz / c.w;
    return vec3((n.xy * 0.5 + 0.5) * p.map.x, n.z);
}

float depth_units_ref(float z) {
    // UNORM formats clamp the reference to [0, 1] before the compare (Vulkan spec, 16.3.4).
    return p.bias2.z > 0.0 ? clamp(z, 0.0, 1.0) : z;
}

// One point compare at texel t; 1 = lit (reference <= stored, LESS_OR_EQUAL).
float tap_point(ivec2 t, uint layer, float ref) {
    int res = int(p.map.x);
    if (kLightKind == kLightPoint) {
        t = clamp(t, ivec2(0), ivec2(res - 1));  // a cube face clamps to its edge
    } else if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(res)))) {
        return 1.0;  // outside the map: the border is lit
    }
    float stored = texelFetch(shadow_depth, ivec3(t, int(layer)), 0).r;
    return lit_against(depth_units_ref(ref), stored) ? 1.0 : 0.0;
}

// Reference depth at texel t: the receiver plane extrapolated to the texel centre when
// receiver-plane bias is on, else the receiver's own depth.
float ref_at(ivec2 t, vec3 m, vec2 dz) {
    if (kReceiverPlane == 0u) return m.z;
    return m.z + dot(dz, vec2(t) + 0.5 - m.xy);
}

float tap_at(vec2 uv, uint layer, vec3 m, vec2 dz) {
    ivec2 t = ivec2(floor(uv));
    return tap_point(t, layer, ref_at(t, m, dz));
}

// Bilinearly weighted 2x2 compare around uv, as a linear comparison sampler does.
float tap_bilinear(vec2 uv, uint layer, vec3 m, vec2 dz) {
    vec2 st = uv - 0.5;
    vec2 base = floor(st);
    // The linear comparison sampler where its four texels lie in the map. Across a 2D map's edge
    // the shader's own weights run instead: they read every texel outside as lit, while a border
    // texel compares as depth 1.0 and shadows a float reference beyond the map's far plane.
    bool in_map = all(greaterThanEqual(base, vec2(0.0))) && all(lessThan(base + 1.0, vec2(p.map.x)));
    if (kHardwareCompare != 0u && (in_map || kLightKind == kLightPoint)) {
        float ref = m.z + (kReceiverPlane != 0u ? dot(dz, uv - m.xy) : 0.0);
        return textureGrad(shadow_compare, vec4(uv * p.map.y, float(layer), depth_units_ref(ref)), vec2(0.0),
                           vec2(0.0));
    }
    vec2 f = st - base;
    ivec2 t = ivec2(base);
    float s00 = tap_point(t, layer, ref_at(t, m, dz));
    float s10 = tap_point(t + ivec2(1, 0), layer, ref_at(t + ivec2(1, 0), m, dz));
    float s01 = tap_point(t + ivec2(0, 1), layer, ref_at(t + ivec2(0, 1), m, dz));
    float s11 = tap_point(t + ivec2(1, 1), layer, ref_at(t + ivec2(1, 1), m, dz));
    return mix(mix(s00, s10, f.x), mix(s01, s11, f.x), f.y);
}

float grid_tap(vec2 uv, uint layer, vec3 m, vec2 dz) {
    return kBilinearTaps != 0u ? tap_bilinear(uv, layer, m, dz) : tap_at(uv, layer, m, dz);
}

// Per-pixel rotation of the Poisson disk from an integer hash: deterministic, no texture.
float pixel_angle(uvec2 pix) {
    uint h = pix.x * 0x8da6b343u ^ pix.y * 0xd8163841u;
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    return float(h & 0xFFFFu) * (6.28318530718 / 65536.0);
}

// Interleaved gradient noise (Jimenez, "Next Generation Post Processing in Call of Duty: Advanced
// Warfare", SIGGRAPH 2014) at the pixel centre, as three.js evaluates it at gl_FragCoord.xy.
float interleaved_gradient_noise(uvec2 pix) {
    vec2 c = vec2(pix) + 0.5;
    return fract(52.9829189 * fract(dot(c, vec2(0.06711056, 0.00583715))));
}

// Tap k of n on a Vogel disk (golden-angle spiral, unit radius) turned by phi: three.js r18x's
// vogelDiskSample (shadowmap_pars_fragment.glsl.js).
vec2 vogel_tap(uint k, uint n, float phi) {
    float r = sqrt((float(k) + 0.5) / float(n));
    float theta = float(k) * 2.399963229728653 + phi;
    return vec2(cos(theta), sin(theta)) * r;
}

vec2 poisson_tap(uint k) {
    vec4 pair = p.poisson[k >> 1];
    return (k & 1u) == 0u ? pair.xy : pair.zw;
}

// Metres along a perspective layer's axis from a stored depth (perspective_matrix's inverse).
float view_depth(float d) {
    float n = p.pcss.y, f = p.pcss.z;
    return n * f / (f - d * (f - n));
}

// Metres along the light per depth unit of an orthographic layer: its depth is affine in
// position, and row 2 of view_proj is the gradient, which points along the light.
float ortho_metres_per_depth(uint layer) {
    mat4 vp = p.view_proj[layer];
    return 1.0 / length(vec3(vp[0][2], vp[1][2], vp[2][2]));
}

// Metres of light depth a layer's [0, 1] depth covers (far - near): its own for each cascade.
float depth_range_m(uint layer) {
    if (kDirectional) return ortho_metres_per_depth(min(layer, max(uint(p.map.w), 1u) - 1u));
    return p.pcss.z - p.pcss.y;
}

// Percentage-closer soft shadows (Fernando 2005; reference 001): the average depth of the
// blockers inside the light's footprint seen from the receiver sets the penumbra width, and a
// Poisson PCF of that width filters. Radii are texels of the layer; a texel subtends
// p.footprint.y per metre of depth.
// A sun (orthographic layers, p.pcss.x = tan(alpha), alpha its angular radius): a blocker d
// metres above the receiver shadows it from up to d tan(alpha) away, so the search reaches
// (receiver - near) tan(alpha) and the filter radius is (receiver - blocker) tan(alpha), half
// the penumbra w = (d_receiver - d_blocker) 2 tan(alpha) (docs/raster.md, "A sun with a size").
float pcss_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    float a = pixel_angle(pix);
    mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a));
    float light_r = p.pcss.x, near = p.pcss.y, max_r = p.pcss.w;
    float per_texel = p.footprint.y;
    int res = int(p.map.x);
    // A sun's texels of radius per depth unit between blocker and receiver.
    float sun_texels = kDirectional ? ortho_metres_per_depth(layer) * light_r / layer_footprint(vec3(0.0), layer) : 0.0;
    // 1. blockers: the light seen from the receiver, projected onto the near plane.
    float search = kDirectional ? clamp(forward_depth(m.z) * sun_texels, 1.0, max_r)
                                : clamp(light_r * (z_receiver - near) / (z_receiver * near * per_texel), 1.0, max_r);
    float blocker_sum = 0.0;
    uint blockers = 0u;
    for (uint k = 0u; k < kPoissonTapCount; ++k) {
        ivec2 t = clamp(ivec2(floor(m.xy + rot * poisson_tap(k) * search)), ivec2(0), ivec2(res - 1));
        float stored = texelFetch(shadow_depth, ivec3(t, int(layer)), 0).r;
        if (!lit_against(depth_units_ref(ref_at(t, m, dz)), stored)) {
            stored = forward_depth(stored);
            blocker_sum += kDirectional ? stored : view_depth(stored);
            ++blockers;
        }
    }
    if (blockers == 0u) return 1.0;
    float z_blocker = blocker_sum / float(blockers);
    // 2. the penumbra: the light seen from the receiver, at the blockers' depth.
    float radius = kDirectional
                       ? clamp((forward_depth(m.z) - z_blocker) * sun_texels, 1.0, max_r)
                       : clamp(light_r * (z_receiver - z_blocker) / (z_receiver * z_blocker * per_texel), 1.0, max_r);
    // 3. PCF over it.
    float sum = 0.0;
    for (uint k = 0u; k < kPoissonTapCount; ++k) sum += grid_tap(m.xy + rot * poisson_tap(k) * radius, layer, m, dz);
    return sum / float(kPoissonTapCount);
}

// The pixel and the receiver's plane main() found, for a family that needs its neighbours (a
// moment map's mip level): compute shaders have no derivatives, so the lookup traces the
// neighbouring pixels' rays itself.
uvec2 g_pix;
vec3 g_plane_point, g_plane_normal;

// The camera ray through image point `pixel` (pixels, y down) against the receiver's plane.
vec3 on_receiver_plane(vec2 pixel) { return on_plane(camera_ray(pixel), g_plane_point, g_plane_normal, g_plane_point); }

// The depth map's compare filters (none, hw2x2, pcf, poisson, vogel, pcss) at receiver m.
float depth_filter_visibility(uvec2 pix, uint layer, vec3 m, vec2 dz, float z_receiver) {
    if (kFilterType == kFilterPcss) return pcss_visibility(pix, layer, m, dz, z_receiver);
    if (kFilterType == kFilterHw2x2) return tap_bilinear(m.xy, layer, m, dz);
    if (kFilterType == kFilterPcf) {
        float sum = 0.0;
        float half_span = 0.5 * float(kPcfSize - 1u);
        for (uint j = 0u; j < kPcfSize; ++j)
            for (uint i = 0u; i < kPcfSize; ++i)
                sum += grid_tap(m.xy + vec2(float(i) - half_span, float(j) - half_span), layer, m, dz);
        return sum / float(kPcfSize * kPcfSize);
    }
    if (kFilterType == kFilterPoisson) {
        float a = pixel_angle(pix);
        mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a));
        float sum = 0.0;
        for (uint k = 0u; k < kPoissonTapCount; ++k) sum += grid_tap(m.xy + rot * poisson_tap(k) * p.map.z, layer, m, dz);
        return sum / float(kPoissonTapCount);
    }
    if (kFilterType == kFilterVogel) {
        float phi = interleaved_gradient_noise(pix) * 6.28318530718;
        float sum = 0.0;
        for (uint k = 0u; k < kPoissonTapCount; ++k)
            sum += grid_tap(m.xy + vogel_tap(k, kPoissonTapCount, phi) * p.map.z, layer, m, dz);
        return sum / float(kPoissonTapCount);
    }
    return tap_at(m.xy, layer, m, dz);
}

// Depth gradient of the receiver plane in texel units of `layer`, from two tangent steps of h
// metres: the receiver-plane bias needs it, and so do the diagnostics.
vec2 plane_gradient(vec3 Pb, vec3 n, float h, uint layer, vec3 m) {
    if (kReceiverPlane == 0u && kMode != kModeLookup) return vec2(0.0);
    vec3 t1 = normalize(abs(n.x) > 0.9 ? cross(n, vec3(0.0, 1.0, 0.0)) : cross(n, vec3(1.0, 0.0, 0.0)));
    vec3 t2 = cross(n, t1);
    vec3 m1 = to_map(Pb + t1 * h, layer), m2 = to_map(Pb + t2 * h, layer);
    mat2 J = mat2(m1.xy - m.xy, m2.xy - m.xy);
    float det = determinant(J);
    return abs(det) > 1e-20 ? vec2(m1.z - m.z, m2.z - m.z) * inverse(J) : vec2(0.0);
}
