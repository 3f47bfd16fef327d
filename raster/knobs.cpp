#include "raster/knobs.h"

namespace penumbra::raster {

namespace {

// A bias knob whose value is the bias field `field` as it is, with the override `over`.
KnobDecl bias_field(const char* name, const char* unit, double lower, double upper, double Bias::*field,
                    std::optional<double> BiasOverride::*over) {
    KnobDecl k;
    k.name = name;
    k.key = std::string("bias.") + name;
    k.unit = unit;
    k.lower = lower;
    k.upper = upper;
    k.read_bias = [field](const Bias& b, double) { return b.*field; };
    k.write_bias = [field](Bias& b, double v, double) { b.*field = v; };
    k.set_override = [field, over](BiasOverride& o, const Bias* from) {
        if (from)
            o.*over = from->*field;
        else
            (o.*over).reset();
    };
    return k;
}

}  // namespace

const char* to_string(KnobScale s) {
    return s == KnobScale::log ? "log" : "on_off";
}

std::vector<KnobDecl> depth_map_bias_knobs() {
    // Ranges wide enough for a 1 m room and a 10 km terrain (docs/tune.md, "Knobs").
    std::vector<KnobDecl> k;
    k.push_back(bias_field("constant", "r", 1e-1, 1e6, &Bias::constant, &BiasOverride::constant));
    k.push_back(bias_field("slope", "factor", 1e-2, 1e2, &Bias::slope, &BiasOverride::slope));
    k.push_back(bias_field("clamp", "depth units", 1e-7, 1e-1, &Bias::clamp, &BiasOverride::clamp));
    k[0].by_default = k[1].by_default = true;
    k[2].caps = true;
    // The world bias in texel footprints of the reference footprint: it scales with the map
    // and the scene. The bias holds metres.
    KnobDecl world = bias_field("world", "texel footprints", 1e-2, 1e2, &Bias::world, &BiasOverride::world);
    world.read_bias = [](const Bias& b, double footprint_m) { return footprint_m > 0 ? b.world / footprint_m : 0.0; };
    world.write_bias = [](Bias& b, double v, double footprint_m) { b.world = v * footprint_m; };
    k.push_back(std::move(world));
    k.push_back(bias_field("normal_offset", "texels", 1e-2, 1e1, &Bias::normal_offset, &BiasOverride::normal_offset));
    KnobDecl plane;
    plane.name = "receiver_plane";
    plane.key = "bias.receiver_plane";
    plane.unit = "on/off";
    plane.scale = KnobScale::on_off;
    plane.read_bias = [](const Bias& b, double) { return b.receiver_plane ? 1.0 : 0.0; };
    plane.write_bias = [](Bias& b, double v, double) { b.receiver_plane = v != 0; };
    plane.set_override = [](BiasOverride& o, const Bias* from) {
        if (from)
            o.receiver_plane = from->receiver_plane;
        else
            o.receiver_plane.reset();
    };
    k.push_back(std::move(plane));
    return k;
}

}  // namespace penumbra::raster
