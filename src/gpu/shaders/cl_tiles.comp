// GPU cluster build 2/3 (gpu_cluster.c): one workgroup a screen tile of T x T pixels (T <= 16). As
// cluster_build.c sort_tiles / sort_secondary: each valid primary sample is keyed by its depth
// slice, each sample seen through a mirror or glass by the Morton code of its cell in a uniform
// grid over those samples' box (their own clusters, under a key bit of their own); the tile's
// samples are sorted by (key, pixel) and each run of one key is a cluster (a leaf). Per leaf: the
// world-space box of its samples, its normal cone, whether all are Lambertian (summed in pixel
// order: the same result every run). Each pixel gets its leaf, each tile its cluster counts.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 1) readonly buffer Depth { float depth[]; };
layout(std430, binding = 2) readonly buffer Frame { uint frame[8]; };
layout(std430, binding = 3) writeonly buffer Nodes { Node nodes[]; };
layout(std430, binding = 4) writeonly buffer PixNode { uint pix_node[]; };
layout(std430, binding = 5) writeonly buffer TileNcl { uint tile_ncl[]; }; // primary, mirror-seen clusters
shared uint skey[256], okey[256], oj[256], cid[256], cbeg[257];
shared uint s_m, s_ncl, s_nprim;

uint pixel_of(uint t, uint j) {
    uint tx = t % pc.ntx, ty = t / pc.ntx;
    return (ty * pc.T + j / pc.T) * pc.width + tx * pc.T + j % pc.T;
}

void main() {
    const uint t = linear_group(), lid = gl_LocalInvocationID.x, T = pc.T, TT = T * T;
    if (t >= pc.ntx * pc.nty) return;
    const uint tx = t % pc.ntx, ty = t / pc.ntx;
    float near = uintBitsToFloat(frame[0]);
    if (!(near < 1.0 / 0.0)) near = 1.0;
    const float log_near = fast_log2(near);
    // the grid of the mirror-seen samples
    vec3 lo = vec3(ord2f(frame[1]), ord2f(frame[2]), ord2f(frame[3]));
    vec3 hi = vec3(ord2f(frame[4]), ord2f(frame[5]), ord2f(frame[6]));
    float ext = max(max(hi.x - lo.x, hi.y - lo.y), hi.z - lo.z);
    const float cells = float(1u << pc.bits);
    const float inv = ext > 0.0 && ext < 1.0 / 0.0 ? cells / ext : 0.0;
    for (uint j = lid; j < TT; j += 64u) {
        uint x = tx * T + j % T, y = ty * T + j / T, key = KEY_NONE;
        if (x < pc.width && y < pc.height) {
            uint i = y * pc.width + x, f = vs[i].flags;
            if ((f & VS_VALID) != 0u) {
                if ((f & VS_PRIMARY) != 0u) {
                    key = slice_of(depth[i], near, log_near, pc.inv_step);
                } else {
                    vec3 p = vec3(vs[i].px, vs[i].py, vs[i].pz);
                    key = KEY_SEC;
                    for (int d = 0; d < 3; d++) {
                        precise float fc = (p[d] - lo[d]) * inv;
                        uint c = fc >= 1.0 ? (fc < cells ? uint(fc) : uint(cells) - 1u) : 0u; // NaN: 0
                        key |= spread3(c) << uint(2 - d);
                    }
                }
            } else {
                pix_node[i] = KEY_NONE;
            }
        }
        skey[j] = key;
    }
    barrier();
    // rank sort by (key, pixel): stable, the same order on every run
    for (uint j = lid; j < TT; j += 64u) {
        uint k = skey[j];
        if (k == KEY_NONE) continue;
        uint rank = 0u;
        for (uint e = 0u; e < TT; e++) {
            uint ke = skey[e];
            rank += (ke < k || (ke == k && e < j)) ? 1u : 0u;
        }
        okey[rank] = k;
        oj[rank] = j;
    }
    barrier();
    if (lid == 0u) {
        uint m = 0u;
        for (uint j = 0u; j < TT; j++) m += skey[j] != KEY_NONE ? 1u : 0u;
        uint ncl = 0u, nprim = 0u;
        for (uint p = 0u; p < m; p++) {
            if (p == 0u || okey[p] != okey[p - 1u]) {
                cbeg[ncl] = p;
                ncl++;
                if (okey[p] < KEY_SEC) nprim = ncl;
            }
            cid[p] = ncl - 1u;
        }
        cbeg[ncl] = m;
        s_m = m;
        s_ncl = ncl;
        s_nprim = nprim;
        tile_ncl[2u * t] = nprim;
        tile_ncl[2u * t + 1u] = ncl - nprim;
    }
    barrier();
    const uint m = s_m, ncl = s_ncl;
    for (uint p = lid; p < m; p += 64u) pix_node[pixel_of(t, oj[p])] = pc.NL0 + t * TT + cid[p];
    // leaves: one invocation a cluster, its samples in pixel order
    for (uint c = lid; c < ncl; c += 64u) {
        Node nd;
        vec3 blo = vec3(1.0 / 0.0), bhi = vec3(-1.0 / 0.0), sum = vec3(0.0);
        uint lam = 1u;
        const uint p0 = cbeg[c], p1 = cbeg[c + 1u];
        for (uint p = p0; p < p1; p++) {
            uint i = pixel_of(t, oj[p]);
            vec3 q = vec3(vs[i].px, vs[i].py, vs[i].pz);
            blo = min(blo, q);
            bhi = max(bhi, q);
            precise vec3 s2 = sum + vec3(vs[i].nx, vs[i].ny, vs[i].nz);
            sum = s2;
            lam &= (vs[i].flags & VS_LAMBERT) != 0u ? 1u : 0u;
        }
        nd.lox = blo.x, nd.loy = blo.y, nd.loz = blo.z;
        nd.hix = bhi.x, nd.hiy = bhi.y, nd.hiz = bhi.z;
        nd.lambert = lam;
        nd.first = t * TT + p0;
        nd.count = p1 - p0;
        nd.pad0 = 0u, nd.pad1 = 0u;
        if (cone_axis(nd, sum, p1 - p0, false)) {
            float cmin = 1.0;
            bool bad = false;
            for (uint p = p0; p < p1; p++) {
                uint i = pixel_of(t, oj[p]);
                precise float d = nd.ax * vs[i].nx + nd.ay * vs[i].ny + nd.az * vs[i].nz;
                bad = bad || !(d == d);
                cmin = min(cmin, d);
            }
            cone_thresholds(nd, cmin, bad);
        }
        nodes[pc.NL0 + t * TT + c] = nd;
    }
}
