// Cut-outs on the GPU (alphaMode MASK; common/alpha_coverage.h): the buffers the shadow and
// camera passes' alpha test reads (shaders/cutout.glsl), uploaded once per session.
#pragma once

#include <string>
#include <vector>

#include "raster/gpu_passes.h"
#include "raster/technique.h"

namespace penumbra::raster {

struct SceneOnGpu;

// The cut-out bindings (kBindingCutoutUv ... kBindingCutoutTexels), in their resources' order.
std::span<const BindingDecl> cutout_bindings();
// Uploads the scene's cut-outs and writes SceneOnGpu::cutout_set, once per SceneOnGpu; nothing
// where it has none.
void upload_cutouts(SceneOnGpu& s);
// The resources of cutout_bindings(), appended to `resources`.
void append_cutout_resources(const SceneOnGpu& s, std::vector<DescriptorResource>& resources);
// InputError for a family or option that cannot draw cut-outs: names it and a cut-out material.
[[noreturn]] void refuse_cutouts(const SceneOnGpu& s, const std::string& what);
// For a family that draws every triangle opaque: refuses a scene with cut-outs, and a `blend`
// other than opaque on a scene with blended materials.
void check_alpha_rules(const SceneOnGpu& s, const Technique& t, const std::string& family);
// The alpha-tested shadow passes' specialisation (shaders/cutout.glsl): kBlendCutoff, the
// technique's blend cutoff or -1 (a blended material is opaque) unless blend is cutout(T), and
// kMipmaps, alpha.mipmaps.
std::vector<std::uint32_t> alpha_spec(const Technique& t);

}  // namespace penumbra::raster
