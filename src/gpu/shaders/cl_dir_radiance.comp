// GPU directional irradiance (gpu_cluster.c): per view sample, the octant buckets of its nodes from
// level D down to its cluster (added top-down, as est_directional.c), a bucket taken whole when its
// summed direction lies above the surface (n.m > 0, world space; est_directional.c dir_block), over
// pi r^2. Writes the irradiance planes (3 x pixels; 0 where invalid) that cl_dir_blur blurs and shades.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 1) readonly buffer PixNode { uint pix_node[]; };
layout(std430, binding = 2) readonly buffer Buckets { float buckets[]; };
layout(std430, binding = 3) writeonly buffer Planes { float planes[]; };

void main() {
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    if (x >= pc.width || y >= pc.height) return;
    const uint i = y * pc.width + x, np = pc.width * pc.height;
    ViewSample v = vs[i];
    precise vec3 e = vec3(0.0);
    if ((v.flags & VS_VALID) != 0u && pix_node[i] != KEY_NONE) {
        const uint kind = (v.flags & VS_PRIMARY) != 0u ? 0u : 1u;
        uint up[3], ids[4];
        node_path(x, y, kind, up);
        ids[0] = up[0], ids[1] = up[1], ids[2] = up[2], ids[3] = pix_node[i];
        float b[48];
        for (int k = 0; k < 48; k++) b[k] = 0.0;
        for (uint l = pc.D; l < 4u; l++)
            for (uint k = 0u; k < 48u; k++) {
                precise float t = b[k] + buckets[48u * ids[l] + k];
                b[k] = t;
            }
        for (uint o = 0u; o < 8u; o++) {
            precise float c = v.nx * b[6u * o + 3u] + v.ny * b[6u * o + 4u] + v.nz * b[6u * o + 5u];
            if (c > 0.0) e += vec3(b[6u * o], b[6u * o + 1u], b[6u * o + 2u]);
        }
        precise float inv_area = 1.0 / (3.14159265358979 * pc.r * pc.r);
        e *= inv_area;
    }
    planes[i] = e.x;
    planes[np + i] = e.y;
    planes[2u * np + i] = e.z;
}
