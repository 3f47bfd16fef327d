#version 460
// Shadow volumes: drawn where the stencil test (count == 0) passes, so V = 1 outside every
// volume and the cleared 0 inside one.
layout(location = 0) out float lit;
void main() { lit = 1.0; }
