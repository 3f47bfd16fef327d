// libFuzzer target: the glTF loader on one file, text (.gltf) or binary (.glb); the loader
// tells them apart by the GLB magic, so one target serves both corpora.
#include "common/gltf_loader.h"
#include "fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    penumbra::fuzz::stand_in_for_images();
    using namespace penumbra;
    const auto file = fuzz::write_file(PENUMBRA_FUZZ_SCENE_NAME, data, size);
    fuzz::expect_input_errors_only([&] {
        GltfLoadOptions options;
        options.max_memory_bytes = fuzz::kMaxMemory;
        load_gltf(file, options);
    });
    return 0;
}
