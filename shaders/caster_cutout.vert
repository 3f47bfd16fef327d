#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow pass with caster offsets of a scene with cut-outs: cutout_vertex.glsl, unprojected.
#define CASTER
#include "cutout_vertex.glsl"
