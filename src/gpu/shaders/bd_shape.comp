// GPU bounds3d / bounds25d, pass 1 (gpu_bounds.c): each photon's screen bound (bounds.glsl
// make_shape), one invocation a photon, into its own shape record.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "tiled.glsl"
#define BD_PARAMS_BINDING 1
#define BD_SHAPES_BINDING 2
#include "bounds.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
void main() {
    uint j = linear_group() * 64u + gl_LocalInvocationID.x;
    if (j >= pc.n) return;
    make_shape(to_view(vec3(ph[j].px, ph[j].py, ph[j].pz)), pc.r, j * prm.stride);
}
