// GPU directional irradiance (gpu_cluster.c): per view sample, the octant buckets of its nodes from
// level D down to its cluster (added top-down, as est_directional.c), each octant o weighted by
// K(n) max(0, n.d_o) (n: the normal in view space, d_o: the octant's diagonal, K: the CPU's table
// of normalisations, bilinear on its cube map, est_directional.c knorm), over pi r^2. Writes the
// irradiance planes (3 x pixels; 0 where invalid) that cl_dir_blur blurs and shades.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 1) readonly buffer PixNode { uint pix_node[]; };
layout(std430, binding = 2) readonly buffer Buckets { float buckets[]; };
layout(std430, binding = 3) readonly buffer Tab { float tab[]; }; // axes [0, 9), K [12, 12 + 6 KRES^2)
layout(std430, binding = 4) writeonly buffer Planes { float planes[]; };
#define KRES 16

float knorm(float x, float y, float z) {
    const vec3 v = vec3(x, y, z), a = abs(v);
    const int ax = a[0] >= a[1] ? (a[0] >= a[2] ? 0 : 2) : (a[1] >= a[2] ? 1 : 2);
    if (!(a[ax] > 0.0)) return 1.0;
    const int f = 2 * ax + (v[ax] < 0.0 ? 1 : 0);
    precise float fu = (v[(ax + 1) % 3] / a[ax] + 1.0) * 0.5 * float(KRES) - 0.5;
    precise float fv = (v[(ax + 2) % 3] / a[ax] + 1.0) * 0.5 * float(KRES) - 0.5;
    fu = clamp(fu, 0.0, float(KRES - 1));
    fv = clamp(fv, 0.0, float(KRES - 1));
    int i0 = int(fu), j0 = int(fv);
    int i1 = min(i0 + 1, KRES - 1), j1 = min(j0 + 1, KRES - 1);
    precise float du = fu - float(i0), dv = fv - float(j0);
    const int b = 12 + f * KRES * KRES;
    precise float k = (1.0 - du) * ((1.0 - dv) * tab[b + i0 * KRES + j0] + dv * tab[b + i0 * KRES + j1]) +
                      du * ((1.0 - dv) * tab[b + i1 * KRES + j0] + dv * tab[b + i1 * KRES + j1]);
    return k;
}

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
        float b[24];
        for (int k = 0; k < 24; k++) b[k] = 0.0;
        for (uint l = pc.D; l < 4u; l++)
            for (uint k = 0u; k < 24u; k++) {
                precise float t = b[k] + buckets[24u * ids[l] + k];
                b[k] = t;
            }
        const vec3 R = vec3(tab[0], tab[1], tab[2]), U = vec3(tab[3], tab[4], tab[5]), F = vec3(tab[6], tab[7], tab[8]);
        precise float vx = v.nx * R.x + v.ny * R.y + v.nz * R.z;
        precise float vy = v.nx * U.x + v.ny * U.y + v.nz * U.z;
        precise float vz = v.nx * F.x + v.ny * F.y + v.nz * F.z;
        precise float kn = 0.57735026919 * knorm(vx, vy, vz);
        for (uint o = 0u; o < 8u; o++) {
            const float sx = (o & 1u) != 0u ? -1.0 : 1.0, sy = (o & 2u) != 0u ? -1.0 : 1.0,
                        sz = (o & 4u) != 0u ? -1.0 : 1.0;
            precise float w = kn * (sx * vx + sy * vy + sz * vz);
            w = 0.5 * (w + abs(w));
            e += w * vec3(b[3u * o], b[3u * o + 1u], b[3u * o + 2u]);
        }
        precise float inv_area = 1.0 / (3.14159265358979 * pc.r * pc.r);
        e *= inv_area;
    }
    planes[i] = e.x;
    planes[np + i] = e.y;
    planes[2u * np + i] = e.z;
}
