// GPU cluster build 3/3 (gpu_cluster.c): the tile nodes (mode 1), the supertile nodes (mode 0) and
// the roots (mode 2), one workgroup a node: the world-space box, normal cone and Lambert flag of
// every sample of the node's kind (primary / seen through a mirror or glass) in its pixel
// rectangle, reduced in a fixed order (the same result every run), and its children.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Samples { ViewSample vs[]; };
layout(std430, binding = 1) buffer Nodes { Node nodes[]; };
layout(std430, binding = 2) readonly buffer TileNcl { uint tile_ncl[]; };
shared vec3 r_lo[64], r_hi[64], r_sum[64];
shared uint r_lam[64], r_cnt[64];
shared float r_min[64];
shared bool r_bad[64];

void main() {
    const uint g = linear_group(), lid = gl_LocalInvocationID.x, G = pc.G, GG = G * G, R = pc.R, RR = R * R;
    const uint T = pc.T, kind = g & 1u, slot = g >> 1, nroots = pc.nrx * pc.nry;
    uint x0, y0, ext, id, first = 0u, count = 0u;
    bool tile_level = pc.mode == 1u;
    if (pc.mode == 2u) { // root
        if (slot >= nroots) return;
        id = g;
        x0 = (slot % pc.nrx) * R * G * T, y0 = (slot / pc.nrx) * R * G * T, ext = R * G * T;
        first = pc.NS0 + 2u * slot * RR + kind;
    } else {
        // supertile slot s (root-major) and its position in supertiles
        const uint s = pc.mode == 1u ? slot / GG : slot;
        if (s >= nroots * RR) return;
        const uint r = s / RR, l1 = s % RR;
        const uint sx = (r % pc.nrx) * R + l1 % R, sy = (r / pc.nrx) * R + l1 / R;
        if (pc.mode == 0u) { // supertile
            id = pc.NS0 + g;
            x0 = sx * G * T, y0 = sy * G * T, ext = G * T;
            first = pc.NT0 + 2u * s * GG + kind;
        } else { // tile
            const uint l = slot % GG, tx = sx * G + l % G, ty = sy * G + l / G;
            id = pc.NT0 + g;
            x0 = tx * T, y0 = ty * T, ext = T;
            if (tx < pc.ntx && ty < pc.nty) {
                uint t = ty * pc.ntx + tx;
                count = tile_ncl[2u * t + kind];
                first = pc.NL0 + t * T * T + (kind == 1u ? tile_ncl[2u * t] : 0u);
            }
        }
    }
    vec3 lo = vec3(1.0 / 0.0), hi = vec3(-1.0 / 0.0), sum = vec3(0.0);
    uint lam = 1u, cnt = 0u;
    for (uint q = lid; q < ext * ext; q += 64u) {
        uint x = x0 + q % ext, y = y0 + q / ext;
        if (x >= pc.width || y >= pc.height) continue;
        uint i = y * pc.width + x, f = vs[i].flags;
        if ((f & VS_VALID) == 0u || ((f & VS_PRIMARY) != 0u ? 0u : 1u) != kind) continue;
        vec3 p = vec3(vs[i].px, vs[i].py, vs[i].pz);
        lo = min(lo, p);
        hi = max(hi, p);
        precise vec3 s2 = sum + vec3(vs[i].nx, vs[i].ny, vs[i].nz);
        sum = s2;
        lam &= (f & VS_LAMBERT) != 0u ? 1u : 0u;
        cnt++;
    }
    r_lo[lid] = lo, r_hi[lid] = hi, r_sum[lid] = sum, r_lam[lid] = lam, r_cnt[lid] = cnt;
    barrier();
    for (uint s = 32u; s > 0u; s >>= 1) {
        if (lid < s) {
            r_lo[lid] = min(r_lo[lid], r_lo[lid + s]);
            r_hi[lid] = max(r_hi[lid], r_hi[lid + s]);
            precise vec3 s2 = r_sum[lid] + r_sum[lid + s];
            r_sum[lid] = s2;
            r_lam[lid] &= r_lam[lid + s];
            r_cnt[lid] += r_cnt[lid + s];
        }
        barrier();
    }
    Node nd;
    nd.lox = r_lo[0].x, nd.loy = r_lo[0].y, nd.loz = r_lo[0].z;
    nd.hix = r_hi[0].x, nd.hiy = r_hi[0].y, nd.hiz = r_hi[0].z;
    nd.lambert = r_lam[0];
    nd.first = first;
    nd.pad0 = 0u, nd.pad1 = 0u;
    const uint nsamples = r_cnt[0];
    bool open = !cone_axis(nd, r_sum[0], max(nsamples, 1u), nsamples == 0u);
    // the smallest cosine between the axis and the samples' normals
    float cmin = 1.0;
    bool bad = false;
    if (!open)
        for (uint q = lid; q < ext * ext; q += 64u) {
            uint x = x0 + q % ext, y = y0 + q / ext;
            if (x >= pc.width || y >= pc.height) continue;
            uint i = y * pc.width + x, f = vs[i].flags;
            if ((f & VS_VALID) == 0u || ((f & VS_PRIMARY) != 0u ? 0u : 1u) != kind) continue;
            precise float d = nd.ax * vs[i].nx + nd.ay * vs[i].ny + nd.az * vs[i].nz;
            bad = bad || !(d == d);
            cmin = min(cmin, d);
        }
    r_min[lid] = cmin;
    r_bad[lid] = bad;
    barrier();
    for (uint s = 32u; s > 0u; s >>= 1) {
        if (lid < s) {
            r_min[lid] = min(r_min[lid], r_min[lid + s]);
            r_bad[lid] = r_bad[lid] || r_bad[lid + s];
        }
        barrier();
    }
    if (lid != 0u) return;
    if (!open) cone_thresholds(nd, r_min[0], r_bad[0]);
    nd.count = nsamples == 0u ? 0u : tile_level ? count : nsamples;
    nodes[id] = nd;
}
