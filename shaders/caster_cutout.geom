#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow pass with caster offsets of a scene with cut-outs: caster.glsl, passing on the
// texture coordinates and COLOR_0 alpha the alpha test reads.
#define CUTOUT
#include "caster.glsl"
