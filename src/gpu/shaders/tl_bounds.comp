// GPU tiled, pass 1 (gpu_tiled.c): the view-space box of each tile's valid primary samples (as
// est_tiled.c tiled_build), one invocation a tile; min/max do not depend on the order.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Samples { uint vsw[]; }; // gather.glsl ViewSample: 16 words
layout(std430, binding = 1) writeonly buffer Bounds { vec4 bounds[]; }; // lo.xyz valid, hi.xyz 0
void main() {
    uint t = linear_group() * 64u + gl_LocalInvocationID.x;
    if (t >= pc.ntiles) return;
    uint tx = t % pc.ntx, ty = t / pc.ntx;
    vec3 lo = vec3(uintBitsToFloat(0x7f800000u)), hi = vec3(uintBitsToFloat(0xff800000u));
    float valid = 0.0;
    for (uint py = ty * pc.T; py < (ty + 1u) * pc.T && py < pc.height; py++)
        for (uint px = tx * pc.T; px < (tx + 1u) * pc.T && px < pc.width; px++) {
            uint i = py * pc.width + px;
            uint f = vsw[16u * i + 13u];
            if ((f & 3u) != 3u) continue; // PGI_VS_VALID | PGI_VS_PRIMARY
            vec3 q = to_view(vec3(uintBitsToFloat(vsw[16u * i]), uintBitsToFloat(vsw[16u * i + 1u]),
                                  uintBitsToFloat(vsw[16u * i + 2u])));
            lo = min(lo, q);
            hi = max(hi, q);
            valid = 1.0;
        }
    bounds[2u * t] = vec4(lo, valid);
    bounds[2u * t + 1u] = vec4(hi, 0.0);
}
