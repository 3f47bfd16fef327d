#include "pipeline/compare_files.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include "common/errors.h"
#include "common/json_reader.h"
#include "image_io/image_io.h"

namespace penumbra {
namespace {

std::optional<std::size_t> channel_named(const ImageFile& img, const std::string& name) {
    for (std::size_t c = 0; c < img.channel_names.size(); ++c)
        if (img.channel_names[c] == name) return c;
    return std::nullopt;
}

bool names_lights(const ImageFile& img) {
    return std::any_of(img.channel_names.begin(), img.channel_names.end(), [](const std::string& s) {
        return s.rfind("light", 0) == 0 && s.size() > 2 && s.substr(s.size() - 2) == ".V";
    });
}

std::string channel_list(const ImageFile& img) {
    std::vector<std::string> names;
    for (std::size_t c = 0; c < img.channel_names.size(); ++c)
        names.push_back(img.channel_names[c].empty() ? fmt::format("#{}", c) : img.channel_names[c]);
    return fmt::format("{}", fmt::join(names, ", "));
}

// Colour channels (not alpha): what "one channel per light" counts.
std::vector<std::size_t> colour_channels(const ImageFile& img) {
    std::vector<std::size_t> cs;
    for (std::size_t c = 0; c < img.channel_names.size(); ++c)
        if (img.channel_names[c] != "A" && img.channel_names[c] != "a") cs.push_back(c);
    return cs;
}

}  // namespace

EngineFrame load_engine_frame(const Scenario& sc, const std::filesystem::path& image,
                              const std::vector<std::size_t>& lights, const std::optional<std::filesystem::path>& depth,
                              DepthSpace depth_space) {
    // The size is checked from each file's header, before its pixels are decoded.
    const ExpectedImageSize size{sc.width, sc.height,
                                 fmt::format("the scenario's image size, {}x{} ({})", sc.width, sc.height, sc.label)};
    const ImageFile img = read_image(image, &size);
    EngineFrame f;
    f.label = path_text(image);
    f.width = img.width;
    f.height = img.height;
    nlohmann::json channels = nlohmann::json::array();
    const std::vector<std::size_t> colour = colour_channels(img);
    for (std::size_t k = 0; k < lights.size(); ++k) {
        const std::size_t li = lights[k];
        std::size_t c = 0;
        if (names_lights(img)) {
            auto named = channel_named(img, fmt::format("light{}.V", li));
            if (!named)
                throw InputError(fmt::format("{}: no channel light{}.V (it has {}); expected one for light {}", f.label,
                                             li, channel_list(img), li));
            c = *named;
        } else if (lights.size() == 1 && !colour.empty()) {
            c = colour[0];
        } else if (colour.size() == lights.size()) {
            c = colour[k];
        } else {
            throw InputError(fmt::format(
                "{}: channels {}; expected light<i>.V channels or one channel per light ({}), or --light to pick one",
                f.label, channel_list(img), lights.size()));
        }
        // 8-bit and 16-bit images are read normalised (255 -> 1). One whose values never
        // exceed one step was written as 0/1 integers, not as the factor in [0, 1].
        if (!img.floating) {
            const auto& ch = img.channels[c];
            const float hi = *std::max_element(ch.begin(), ch.end());
            const float step = 1.0f / static_cast<float>((1u << std::min(img.bits, 16)) - 1u);
            if (hi > 0 && hi <= 1.5f * step)
                throw InputError(fmt::format(
                    "{}: channel {}: an {}-bit image whose values are only 0 and 1 (of {}); expected the shadow "
                    "factor scaled to the full range, 0..1 as 0..{}",
                    f.label, img.channel_names[c], img.bits, (1u << std::min(img.bits, 16)) - 1u,
                    (1u << std::min(img.bits, 16)) - 1u));
        }
        f.V.push_back(img.channels[c]);
        channels.push_back({{"light", li}, {"channel", img.channel_names[c]}});
    }
    f.info = {
        {"image", f.label}, {"format", img.format}, {"bits", img.bits}, {"channels", channels}, {"lights", lights}};

    if (depth) {
        const ImageFile d = read_image(*depth, &size);
        f.depth_label = path_text(*depth);
        std::optional<std::size_t> c;
        for (const char* name : {"depth", "Z", "R", "Y"})
            if (!c) c = channel_named(d, name);
        if (!c && d.channels.size() == 1) c = 0;
        if (!c)
            throw InputError(fmt::format("{}: channels {}; expected a channel named depth, Z, R or Y, or a single one",
                                         f.depth_label, channel_list(d)));
        f.depth = d.channels[*c];
        f.depth_space = depth_space;
        f.info["depth_file"] = f.depth_label;
        f.info["depth_channel"] = d.channel_names[*c];
    }
    return f;
}

}  // namespace penumbra
