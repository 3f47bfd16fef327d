#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow pass with caster offsets: caster.glsl.
#include "caster.glsl"
