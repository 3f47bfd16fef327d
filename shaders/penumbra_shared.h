// Declarations shared by the GLSL shaders and the C++ raster path: descriptor bindings,
// specialization-constant ids and uniform layouts. Only vec4/mat4/uvec4 members, so std140
// and C++ agree on every offset without padding rules to remember.
#ifndef PENUMBRA_SHARED_H
#define PENUMBRA_SHARED_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>
namespace penumbra::gpu {
using uint = std::uint32_t;
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
#define PENUMBRA_CONST inline constexpr
#else
#define PENUMBRA_CONST const
#endif

PENUMBRA_CONST uint kNoPrim = 0xFFFFFFFFu;

// Camera pass: per-triangle "double sided" bits.
PENUMBRA_CONST uint kBindingDoubleSided = 0;

// Cut-outs (alphaMode MASK; shaders/cutout.glsl, common/alpha_coverage.h): the shadow passes'
// set, and the camera pass's beside kBindingDoubleSided, where the scene has cut-outs.
PENUMBRA_CONST uint kBindingCutoutUv = 1;          // float[2 * vertices]: the cut-out's texture coordinates
PENUMBRA_CONST uint kBindingCutoutAlpha = 2;       // float[vertices]: COLOR_0's alpha
PENUMBRA_CONST uint kBindingCutoutOfTriangle = 3;  // uint[triangles]: index into the materials, or kNoPrim
PENUMBRA_CONST uint kBindingCutoutMaterials = 4;   // CutoutMaterialGpu[]
PENUMBRA_CONST uint kBindingCutoutTexels = 5;      // uint[]: two 16-bit alphas each, the lower half first
PENUMBRA_CONST uint kCutoutNearest = 1u;           // CutoutMaterialGpu::texture.w bits
PENUMBRA_CONST uint kCutoutHasTexture = 2u;
PENUMBRA_CONST uint kCutoutWrapSShift = 2u;  // TextureWrap in two bits each
PENUMBRA_CONST uint kCutoutWrapTShift = 4u;
PENUMBRA_CONST uint kCutoutBlend = 64u;        // a BLEND material: tested at kBlendCutoff (shaders/cutout.glsl)
PENUMBRA_CONST uint kCutoutMipShift = 7u;      // two bits: 0 no mip levels, 1 the nearest level, 2 linear between two
PENUMBRA_CONST uint kCutoutMinNearest = 512u;  // minification samples a level's nearest texel
// Planar projection of a scene with cut-outs (shaders/planar_cutout.vert): per flattened vertex
// (u, v, COLOR_0 alpha, 1) / w of Blinn's projection, and per flattened triangle its scene triangle.
PENUMBRA_CONST uint kBindingPlanarAttributes = 6;  // vec4[3 * flattened cut-out triangles]
PENUMBRA_CONST uint kBindingPlanarTriangles = 7;   // uint[flattened cut-out triangles]
struct CutoutMaterialGpu {
    vec4 row0;      // KHR_texture_transform's first row (xyz), alphaCutoff (w)
    vec4 row1;      // its second row (xyz), baseColorFactor.a (w)
    uvec4 texture;  // first texel, width, height, kCutout* flags
};

// Lookup pass (one dispatch per light).
PENUMBRA_CONST uint kBindingGBufferPrim = 0;    // r32ui storage image: triangle seen per pixel
PENUMBRA_CONST uint kBindingPositions = 1;      // float[3 * vertices], camera-relative
PENUMBRA_CONST uint kBindingIndices = 2;        // uint[3 * triangles]
PENUMBRA_CONST uint kBindingShadowDepth = 3;    // sampler2DArray, nearest (texelFetch)
PENUMBRA_CONST uint kBindingShadowPrim = 4;     // usampler2DArray (texelFetch)
PENUMBRA_CONST uint kBindingShadowCompare = 5;  // sampler2DArrayShadow, linear when supported
PENUMBRA_CONST uint kBindingLookupParams = 6;   // uniform LookupParams
PENUMBRA_CONST uint kBindingLookupOut = 7;      // LookupTexel[pixels]
PENUMBRA_CONST uint kBindingFaceMask = 8;       // uint: bit f = cube face f is sampled
PENUMBRA_CONST uint kBindingVisibilityOut = 9;  // float[pixels]: V alone (kModeVisibility)
// sampler2DArray: a depth-map variant's own image (DepthMapVariant::family_image; the moment
// families' filtered moments, linear, trilinear with mipmaps, clamp to edge), else the depth map, never read
PENUMBRA_CONST uint kBindingFamilyImage = 10;
// SDSM's reduction (sdsm.comp) binds the first three above and this.
PENUMBRA_CONST uint kBindingSdsmRange = 3;  // uint[2]: least, greatest view depth (order-preserving bits)

// Specialization constants of the lookup shader.
PENUMBRA_CONST uint kSpecLightKind = 0;        // kLight*
PENUMBRA_CONST uint kSpecFilter = 1;           // kFilter*
PENUMBRA_CONST uint kSpecPcfSize = 2;          // taps per side of the grid
PENUMBRA_CONST uint kSpecPoissonTaps = 3;      // number of Poisson-disk taps
PENUMBRA_CONST uint kSpecBilinearTaps = 4;     // 1: each grid tap is a 2x2 bilinear compare
PENUMBRA_CONST uint kSpecReceiverPlane = 5;    // 1: receiver-plane depth bias
PENUMBRA_CONST uint kSpecHardwareCompare = 6;  // 1: 2x2 taps use the linear comparison sampler
PENUMBRA_CONST uint kSpecMode = 7;             // kMode*

PENUMBRA_CONST uint kLightDirectional = 0;
PENUMBRA_CONST uint kLightSpot = 1;
PENUMBRA_CONST uint kLightPoint = 2;

PENUMBRA_CONST uint kFilterNone = 0;
PENUMBRA_CONST uint kFilterHw2x2 = 1;
PENUMBRA_CONST uint kFilterPcf = 2;
PENUMBRA_CONST uint kFilterPoisson = 3;
PENUMBRA_CONST uint kFilterPcss = 4;
// A rotated Vogel disk of kSpecPoissonTaps taps (three.js's PCF).
PENUMBRA_CONST uint kFilterVogel = 5;
// A family's own lookup gives kSpecFilter its own meaning (the moment families: the moment kind).

// The moment families' passes (raster/filterable_moments.comp): the source texture, read by texelFetch
// (the depth map, or moments to blur), and the storage image they write.
PENUMBRA_CONST uint kBindingMomentSource = 0;
PENUMBRA_CONST uint kBindingMomentTarget = 1;
PENUMBRA_CONST uint kSpecMomentFilter = 0;  // the moment kind (raster/filterable.glsl)
PENUMBRA_CONST uint kSpecMomentPass = 1;    // kMomentPass*
PENUMBRA_CONST uint kSpecMomentRadius = 2;  // the blur's radius, texels
PENUMBRA_CONST uint kMomentPassWarp = 0;    // depth -> the family's moments
PENUMBRA_CONST uint kMomentPassBlurX = 1;   // separable Gaussian along x
PENUMBRA_CONST uint kMomentPassBlurY = 2;   // and along y

PENUMBRA_CONST uint kModeLookup = 0;      // write LookupTexel per pixel
PENUMBRA_CONST uint kModeFaceMask = 1;    // only mark the cube faces receivers would sample
PENUMBRA_CONST uint kModeVisibility = 2;  // write V alone, skipping the diagnostics

PENUMBRA_CONST uint kMaxPoissonTaps = 64;
PENUMBRA_CONST uint kMaxLayers = 8;  // six cube faces, or up to eight cascades

// Flags of LookupTexel.flags.
PENUMBRA_CONST uint kFlagSurface = 1u;      // a triangle covers the pixel
PENUMBRA_CONST uint kFlagBackFacing = 2u;   // N.L <= 0: V = 0, not a shadow-map verdict
PENUMBRA_CONST uint kFlagOutsideCone = 4u;  // spot light: outside the cone, V = 0
PENUMBRA_CONST uint kFlagOutsideMap = 8u;   // the lookup fell outside the light's map: V = 1
// Lookups put the layer (shadow view) they used in the flags' bits from here up; the read-back
// moves it to DepthMapLookups::layer.
PENUMBRA_CONST uint kFlagLayerShift = 8u;

struct LookupParams {
    vec4 cam_forward;  // xyz; w = 1 perspective, 0 orthographic
    vec4 cam_right;    // xyz; w = tan(yfov/2) * aspect (perspective) or xmag
    vec4 cam_up;       // xyz; w = tan(yfov/2) (perspective) or ymag
    vec4 image;        // width, height, 1/width, 1/height
    vec4 light_pos;    // camera-relative position (spot, point); w unused
    vec4 light_dir;    // unit direction light travels (directional, spot); w = cos(outer cone)
    vec4 bias;         // world metres, normal offset (texels), shader depth, hardware constant (depth units)
    vec4 bias2;        // hardware slope factor, hardware clamp, format r (0 = float), unused
    vec4 map;          // resolution, 1/resolution, filter radius (texels), layer count
    vec4 footprint;    // x: metres per texel (orthographic); y: metres per texel per metre of depth (perspective)
    mat4 view_proj[kMaxLayers];         // light clip space from camera-relative position, per layer
    vec4 light_axis[kMaxLayers];        // perspective: unit forward axis of each layer
    vec4 poisson[kMaxPoissonTaps / 2];  // two taps (x, y) per vec4, unit disk
    vec4 pcss;                          // light radius (m), near, far (m, perspective layers), largest radius (texels)
    // Cascades (raster/cascades_lookup.comp): x = cascade count, y = overlap fraction; per cascade (4 a vec4) the far
    // end of its slice of view depth (metres) and its texel size (metres).
    vec4 cascade;
    vec4 cascade_far[kMaxLayers / 4];
    vec4 cascade_texel[kMaxLayers / 4];
    vec4 moments;     // min variance, light-bleed reduction, exponent, negative exponent (msm: kMomentMsm)
    vec4 moment_map;  // x: mip levels of the moment texture (1: bilinear, more: trilinear), y: 1 msm 16-bit
    // Cascades: per cascade (4 a vec4) the factor its world bias (metres) and hardware
    // constant bias are multiplied by: 1, or with cascades.texel_scaled_bias its texel over the
    // first cascade's (the constant also by the first's depth range over its own).
    vec4 cascade_world_scale[kMaxLayers / 4];
    vec4 cascade_constant_scale[kMaxLayers / 4];
    // Engine bias terms (docs/raster.md, "Bias as engines apply it"). Receiver: normal offset in
    // metres, normal factor (kNormalFactor*), 1 = normal offset perpendicular to L, world offset
    // as a fraction of the layer's depth range.
    vec4 bias3;
    // Caster (for the peter-panning rule's reach): world metres, world texels, normal metres,
    // normal texels.
    vec4 caster;
    vec4 caster2;  // caster normal factor (kNormalFactor*), caster depth (depth units), 1 = reversed Z, unused
};

PENUMBRA_CONST uint kNormalFactorNone = 0;
PENUMBRA_CONST uint kNormalFactorOneMinusNdotL = 1;
PENUMBRA_CONST uint kNormalFactorSin = 2;

// The shadow pass's push constants when it applies caster offsets or reversed Z (shadow_bias.geom).
struct ShadowPush {
    mat4 view_proj;  // the layer's, reversed when caster.w says so
    vec4 light;      // xyz: unit direction light travels (w = 0), or camera-relative position (w = 1)
    vec4 texel;      // xyz: the layer's unit forward axis (positional lights); w: metres per texel (orthographic)
                     // or per texel per metre of depth along the axis (perspective)
    vec4 offsets;    // caster world metres, world texels, normal metres, normal texels
    vec4 caster;     // normal factor (kNormalFactor*), depth (depth units, forward), unused, 1 = reversed Z
};

// The moment passes' push constants: x exponent, y negative exponent (esm, evsm), z 1 for
// msm's 16-bit optimised quantisation; `layer` x the map layer, y the resolution.
struct MomentPassParams {
    vec4 warp;
    uvec4 layer;  // layer, resolution, 1 = the map holds reversed Z, unused
};

// SDSM's reduction: the camera as LookupParams gives it (push constants).
struct SdsmParams {
    vec4 cam_forward;  // xyz; w = 1 perspective, 0 orthographic
    vec4 cam_right;    // xyz; w = tan(yfov/2) * aspect (perspective) or xmag
    vec4 cam_up;       // xyz; w = tan(yfov/2) (perspective) or ymag
    vec4 image;        // width, height, 1/width, 1/height
};

// Per pixel and light, what the technique decided and the lookups behind it.
struct LookupTexel {
    float V;             // the technique's shadow factor, 1 lit
    float ref_depth;     // receiver depth compared at the centre texel, after every bias
    float stored_depth;  // depth stored in the centre texel (inf outside the map)
    float footprint_m;   // shadow-map texel size at the receiver, metres
    float texel_slope;   // receiver-plane depth change across half a texel (depth units)
    float bias_m;        // total bias expressed as metres along the light ray
    float depth_to_m;    // metres along the light ray per depth unit at the receiver
    uint stored_prim;    // triangle stored in the centre texel
    uint flags;          // kFlag*
};

#ifdef __cplusplus
}  // namespace penumbra::gpu
#undef PENUMBRA_CONST
#endif
#endif
