#include "pipeline/camera_path_files.h"

#include <fmt/format.h>

#include "image_io/image_io.h"
#include "pipeline/validate_files.h"

namespace penumbra {

void write_camera_path_outputs(OutputTransaction& out, const Scenario& scenario, const CameraPathResult& result,
                               const ValidateFiles& files) {
    write_validate_outputs(out, scenario, result.last, files);
    std::vector<ExrChannel> channels;  // none without lights: then no file
    for (std::size_t li = 0; li < result.flicker_map.size(); ++li)
        channels.push_back({fmt::format("light{}.flicker", li), {}, result.flicker_map[li]});
    if (!channels.empty()) write_exr(out, "flicker.exr", scenario.width, scenario.height, channels);
}

}  // namespace penumbra
