#include "report/frame_files.h"

#include <fmt/format.h>

#include <future>
#include <memory>

#include "common/preview.h"
#include "common/stopwatch.h"
#include "image_io/image_io.h"

namespace penumbra::report {

namespace {

// Views of the frame's own arrays (no copies). Masks and flags (A, U, lightable: 0 or 1) are
// stored as half, which holds them exactly in half the bytes.
std::vector<ExrChannelView> oracle_channels(const OracleFrame& f) {
    const ExrStorage flag = ExrStorage::half;
    std::vector<ExrChannelView> ch;
    ch.push_back({"A", flag, f.A.data(), 1});
    ch.push_back({"prim", ExrStorage::u32, f.prim.data(), 1});
    ch.push_back({"depth", ExrStorage::f32, f.depth.data(), 1});
    for (int c = 0; c < 3; ++c) {
        ch.push_back({std::string("P.") + "XYZ"[c], ExrStorage::f32, &f.P.data()->x + c, 3});
        ch.push_back({std::string("N.") + "XYZ"[c], ExrStorage::f32, &f.N.data()->x + c, 3});
    }
    for (std::size_t li = 0; li < f.lights.size(); ++li) {
        const OracleLightImage& img = f.lights[li];
        std::string prefix = fmt::format("light{}.", li);
        ch.push_back({prefix + "V", ExrStorage::f32, img.V.data(), 1});
        ch.push_back({prefix + "E", ExrStorage::f32, img.E.data(), 1});
        ch.push_back({prefix + "U", flag, img.U.data(), 1});
        ch.push_back({prefix + "lightable", flag, img.lightable.data(), 1});
        ch.push_back({prefix + "occluder_m", ExrStorage::f32, img.occluder_m.data(), 1});
        ch.push_back({prefix + "boundary_m", ExrStorage::f32, img.boundary_m.data(), 1});
    }
    return ch;
}

// The channels the boundary phase writes: each light's U and boundary_m.
bool boundary_channel(const std::string& name) {
    return name.ends_with(".U") || name.ends_with(".boundary_m");
}

VisibilityPreview oracle_preview(const OracleFrame& f) {
    VisibilityPreview p{f.width, &f.A, &f.N, {}};
    for (const auto& l : f.lights) p.lights.push_back({&l.V, &l.U});
    return p;
}

std::vector<ExrChannel> raster_channels(const RasterFrame& f) {
    std::vector<ExrChannel> ch;
    auto add = [&](std::string name, const std::vector<float>& data) { ch.push_back({std::move(name), data, {}}); };
    auto add_u = [&](std::string name, const std::vector<std::uint32_t>& data) {
        ch.push_back({std::move(name), {}, data});
    };
    add("A", f.A);
    add_u("prim", f.prim);
    for (std::size_t li = 0; li < f.lights.size(); ++li) {
        const RasterLightImage& img = f.lights[li];
        std::string p = fmt::format("light{}.", li);
        add(p + "V", img.V);
        if (!img.lookups) continue;
        const DepthMapLookups& lk = *img.lookups;
        add(p + "ref_depth", lk.ref_depth);
        add(p + "stored_depth", lk.stored_depth);
        add_u(p + "stored_prim", lk.stored_prim);
        add(p + "footprint_m", lk.footprint_m);
        add(p + "texel_slope", lk.texel_slope);
        add(p + "bias_m", lk.bias_m);
        add(p + "depth_to_m", lk.depth_to_m);
        add_u(p + "flags", lk.flags);
        if (lk.layer.size() == lk.flags.size()) add_u(p + "layer", lk.layer);
    }
    return ch;
}

}  // namespace

std::shared_future<void> start_oracle_exr(OutputTransaction& out, const OracleFrame& f, double& seconds) {
    // Data race free by construction: the boundary phase writes U and boundary_m alone (and reads
    // the rest), and the views below read every channel but those two, whose pixels come from
    // `placeholder`. The views hold the arrays' data pointers, not `f`, which run_oracle's result
    // moves; the arrays stay put.
    auto placeholder = std::make_shared<const std::vector<float>>(static_cast<std::size_t>(f.width), 0.0f);
    std::vector<ExrChannelView> channels = oracle_channels(f);
    for (ExrChannelView& c : channels)
        if (boundary_channel(c.name)) {
            c.data = placeholder->data();
            c.stride = 1;
            c.same_row = true;
        }
    auto write = [&out, &seconds, width = f.width, height = f.height, channels = std::move(channels), placeholder] {
        auto t0 = SteadyClock::now();
        write_exr(out, "oracle.exr", width, height, channels, ExrCompression::none);
        seconds = seconds_since(t0);
    };
    return std::async(std::launch::async, std::move(write)).share();
}

double write_oracle_images(OutputTransaction& out, const OracleFrame& f, OracleTimings* parts,
                           const std::shared_future<void>& early_exr) {
    auto t0 = SteadyClock::now();
    // Uncompressed: zip costs ~3 CPU-seconds for a 2048^2 frame, more than tracing it (docs/oracle.md section 9).
    // The preview (its rows and its zlib stream in pieces, on the command's threads) is written
    // while the EXR is.
    double png_s = 0;
    auto png = std::async(std::launch::async, [&] {
        const VisibilityPreview preview = oracle_preview(f);
        write_png(
            out, "oracle.png", f.width, f.height, [&](int y, float* rgb) { preview.row(y, rgb); },
            PngRows::parallel_deflate);
        png_s = seconds_since(t0);
    });
    if (early_exr.valid()) {
        early_exr.get();
        std::vector<ExrChannelView> boundary = oracle_channels(f);
        std::erase_if(boundary, [](const ExrChannelView& c) { return !boundary_channel(c.name); });
        patch_exr_channels(out, "oracle.exr", f.width, f.height, boundary);
    } else {
        write_exr(out, "oracle.exr", f.width, f.height, oracle_channels(f), ExrCompression::none);
    }
    const double exr_s = seconds_since(t0);
    png.get();
    const double total = seconds_since(t0);
    if (parts) {
        parts->write_s = total;
        parts->write_exr_s = exr_s;
        parts->write_png_s = png_s;
    }
    return total;
}

void write_oracle_outputs(OutputTransaction& out, const Scenario& scenario, const OracleResult& result,
                          const OracleTimings& timings, const std::shared_future<void>& early_exr) {
    OracleTimings images;
    write_oracle_images(out, result.frame, &images, early_exr);
    // Read only now: an early write (start_oracle_exr) sets its seconds in `timings` when it ends.
    OracleTimings t = timings;
    t.write_s = images.write_s;
    t.write_exr_s = images.write_exr_s;
    t.write_png_s = images.write_png_s;
    out.write_json("oracle.json", oracle_json(scenario, result, t));
}

void write_raster_outputs(OutputTransaction& out, const Scenario& scenario, const raster::Technique& technique,
                          const raster::RasterResult& result, const raster::RasterTimings& timings) {
    const RasterFrame& f = result.frame;
    auto t0 = SteadyClock::now();
    write_exr(out, "raster.exr", f.width, f.height, raster_channels(f));
    VisibilityPreview preview{f.width, &f.A, nullptr, {}};
    for (const auto& l : f.lights) preview.lights.push_back({&l.V, nullptr});
    // Its zlib stream in pieces too: on the 2-core VM a 1280x720 preview took 0.71-0.81x the
    // serial stream's time at 2 threads and 1.00-1.01x at 1 (docs/oracle.md section 9).
    write_png(
        out, "raster.png", f.width, f.height, [&](int y, float* rgb) { preview.row(y, rgb); },
        PngRows::parallel_deflate);
    nlohmann::json j = raster_json(scenario, technique, result, timings);
    j["seconds"]["write"] = seconds_since(t0);
    out.write_json("raster.json", j);
}

}  // namespace penumbra::report
