// Cut-outs on the GPU (alphaMode MASK; common/alpha_coverage.h): the buffers the shadow and
// camera passes' alpha test reads (shaders/cutout.glsl), uploaded once per session.
#pragma once

#include <string>
#include <vector>

#include "raster/gpu_passes.h"

namespace penumbra::raster {

struct SceneOnGpu;

// The cut-out bindings (kBindingCutoutUv ... kBindingCutoutTexels), in their resources' order.
std::span<const BindingDecl> cutout_bindings();
// Uploads the scene's cut-outs and writes SceneOnGpu::cutout_set; nothing where it has none.
void upload_cutouts(SceneOnGpu& s);
// The resources of cutout_bindings(), appended to `resources`.
void append_cutout_resources(const SceneOnGpu& s, std::vector<DescriptorResource>& resources);
// InputError for a family or option that cannot draw cut-outs: names it and a cut-out material.
[[noreturn]] void refuse_cutouts(const SceneOnGpu& s, const std::string& what);

}  // namespace penumbra::raster
