// GPU directional blur and shading (gpu_cluster.c): est_directional.c's depth- and normal-aware blur
// along one axis (tent weights in pixels times max(0, 1 - |dz| / (0.05 |z|)) times max(0, n.n')^8,
// taps in the order -R..R, those outside the image skipped; invalid samples neither give nor
// receive). mode 0: horizontal, planes [0, 3) -> [3, 6); mode 1: vertical, planes [3, 6) (or [0, 3)
// when pc.blur is 0: no blur, R = 0) -> the radiance kd / pi E of valid samples (0 elsewhere).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 1) readonly buffer Depth { float depth[]; };
layout(std430, binding = 2) buffer Planes { float planes[]; };
layout(std430, binding = 3) writeonly buffer Out { float out_rgb[]; };

bool valid(uint j) { return (vs[j].flags & VS_VALID) != 0u; }

void main() {
    uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    if (x >= pc.width || y >= pc.height) return;
    const uint W = pc.width, H = pc.height, i = y * W + x, np = W * H;
    const int R = int(pc.blur);
    const uint src = pc.mode == 1u && R > 0 ? 3u : 0u;
    const bool ok = valid(i);
    const float z = ok ? depth[i] : 1e30;
    const vec3 n = ok ? vec3(vs[i].nx, vs[i].ny, vs[i].nz) : vec3(0.0);
    precise float iz = 1.0 / (0.05 * abs(z) + 1e-12);
    precise vec3 a = vec3(planes[src * np + i], planes[(src + 1u) * np + i], planes[(src + 2u) * np + i]);
    precise float ws = 1.0;
    for (int k = -R; k <= R; k++) {
        if (k == 0) continue;
        int xx = int(x) + (pc.mode == 0u ? k : 0), yy = int(y) + (pc.mode == 0u ? 0 : k);
        if (xx < 0 || xx >= int(W) || yy < 0 || yy >= int(H)) continue;
        const uint j = uint(yy) * W + uint(xx);
        const bool okj = valid(j);
        const float zj = okj ? depth[j] : 1e30;
        const vec3 nj = okj ? vec3(vs[j].nx, vs[j].ny, vs[j].nz) : vec3(0.0);
        precise float tent = 1.0 - float(abs(k)) / float(R + 1);
        precise float wz = 1.0 - abs(zj - z) * iz;
        wz = 0.5 * (wz + abs(wz));
        precise float c = n.x * nj.x + n.y * nj.y + n.z * nj.z;
        c = 0.5 * (c + abs(c));
        c *= c;
        c *= c;
        c *= c;
        precise float w = tent * wz * c;
        a += w * vec3(planes[src * np + j], planes[(src + 1u) * np + j], planes[(src + 2u) * np + j]);
        ws += w;
    }
    precise vec3 r = a * (1.0 / ws);
    if (pc.mode == 0u) {
        planes[3u * np + i] = r.x;
        planes[4u * np + i] = r.y;
        planes[5u * np + i] = r.z;
        return;
    }
    precise vec3 o = ok ? vec3(vs[i].kdx, vs[i].kdy, vs[i].kdz) * 0.31830988618379067 * r : vec3(0.0);
    out_rgb[3u * i] = o.x;
    out_rgb[3u * i + 1u] = o.y;
    out_rgb[3u * i + 2u] = o.z;
}
