// The one translation unit that compiles tinygltf. Images are never decoded: penumbra needs
// geometry, cameras and lights only, so stb_image is left out and external images are not read.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#define TINYGLTF_NO_INCLUDE_JSON
// tinygltf expects nlohmann/json to be included first.
// clang-format off
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>
// clang-format on
