// GPU tiled, pass 2 (gpu_tiled.c): the box of all tiles' boxes (est_tiled.c frame_lo/frame_hi),
// one invocation, tiles in order.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "tiled.glsl"
layout(local_size_x = 1) in;
layout(std430, binding = 0) readonly buffer Bounds { vec4 bounds[]; };
layout(std430, binding = 1) writeonly buffer Frame { vec4 frame[2]; };
void main() {
    vec3 lo = vec3(uintBitsToFloat(0x7f800000u)), hi = vec3(uintBitsToFloat(0xff800000u));
    for (uint t = 0u; t < pc.ntiles; t++)
        if (bounds[2u * t].w != 0.0) {
            lo = min(lo, bounds[2u * t].xyz);
            hi = max(hi, bounds[2u * t + 1u].xyz);
        }
    frame[0] = vec4(lo, 0.0);
    frame[1] = vec4(hi, 0.0);
}
