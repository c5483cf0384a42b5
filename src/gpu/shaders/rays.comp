// Intersects a buffer of rays with the GPU BVH (src/gpu/gpu_rays.c): one invocation a ray.
// Buffers (set 0): 0 BVH nodes, 1 BVH triangles, 2 cut-out masks, 3 alpha texels (bvh.glsl),
// 4 rays, 5 hits.
// Ray i = first + gl_GlobalInvocationID.x (< first + count): the segment org + t dir, tnear < t <= tfar.
// Its hit: closest (flags bit 0 clear) or any (set: shadow rays; prim is then the blocker found
// first, 0xFFFFFFFF when unoccluded); t, u, v as Embree's (barycentrics of vertices 1 and 2).
#version 450
layout(local_size_x = 64) in;

#define BVH_NODES_BINDING 0
#define BVH_TRIS_BINDING 1
#define BVH_MASKS_BINDING 2
#define BVH_ALPHA_BINDING 3
#include "bvh.glsl"

struct Ray {
    vec4 org_tnear;
    vec4 dir_tfar;
};

layout(std430, set = 0, binding = 4) readonly restrict buffer Rays { Ray rays[]; };
layout(std430, set = 0, binding = 5) writeonly restrict buffer Hits { BvhHit hits[]; };

layout(push_constant) uniform Push {
    uint first; // ray offset of this dispatch (dispatches are split at the device's group limit)
    uint count; // rays in this dispatch
    uint flags; // bit 0: any hit
} pc;

void main() {
    const uint k = gl_GlobalInvocationID.x;
    if (k >= pc.count) return;
    const uint i = pc.first + k;
    const Ray r = rays[i];
    BvhHit h;
    bvh_trace(r.org_tnear.xyz, r.dir_tfar.xyz, r.org_tnear.w, r.dir_tfar.w, (pc.flags & 1u) != 0u, h);
    hits[i] = h;
}
