// Test kernel (tests/test_gpu_frame.c): the surface scene.glsl computes at given hits, to compare
// with the CPU's pgi__scene_surface. Buffers: 0..10 the scene (gpu_scene.h), 11 queries (uvec4:
// triangle, barycentric u and v as float bits), 12 results (3 vec4 a query: ng, ns, textured kd).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 11) readonly buffer Queries { uvec4 q[]; };
layout(std430, binding = 12) writeonly buffer Results { vec4 res[]; };
layout(push_constant) uniform Push {
    SceneInfo scene;
    uint count;
} pc;

void main() {
    const uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    const uvec4 a = q[i];
    const Surf s = scene_surface(pc.scene, a.x, uintBitsToFloat(a.y), uintBitsToFloat(a.z));
    res[3u * i] = vec4(s.ng, 0.0);
    res[3u * i + 1u] = vec4(s.ns, 0.0);
    res[3u * i + 2u] = vec4(surface_kd(s), 0.0);
}
