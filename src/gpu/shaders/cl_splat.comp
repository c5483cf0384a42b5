// GPU cluster-trivial splat (gpu_cluster.c), one invocation a photon, as est_cluster.c's walk and
// decide (Moreau et al. 2016 §4.3-4.6) over the three fixed levels: a node the photon's sphere
// cannot reach (its box farther than r plus a margin) or that lies below the photon (normal cone)
// is skipped; an enclosed node takes the photon, as trivially accepted flux (all samples
// Lambertian and the photon above every normal: each sample would accept it) or else into its
// list; an intersected leaf takes it into its list; other nodes are descended.
// mode 0 counts each photon's outputs (and the node tests); mode 1 writes them, (node entry,
// photon) pairs from the photon's offset (the exclusive sum of the counts): entry 2 node is the
// node's list, 2 node + 1 its trivially accepted photons. No atomics on the outputs.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) readonly buffer Nodes { Node nodes[]; };
layout(std430, binding = 2) buffer Count { uint out_cnt[]; }; // mode 0: written; mode 1: offsets
layout(std430, binding = 3) writeonly buffer Pairs { uint pairs[]; };
layout(std430, binding = 4) buffer Counters { uint counters[6]; };
shared uint wg_visited;

vec3 c, w;
float rr2, re2;
uint outs, base, j;
uint visited;

void emit(uint entry) {
    if (pc.mode == 1u) {
        pairs[2u * (base + outs)] = entry;
        pairs[2u * (base + outs) + 1u] = j;
    }
    outs++;
}

// 0: skipped or taken; 1: descend
uint decide(uint id, bool leaf) {
    visited++;
    Node nd = nodes[id];
    if (nd.count == 0u) return 0u;
    precise float ex = max(max(nd.lox - c.x, c.x - nd.hix), 0.0);
    precise float ey = max(max(nd.loy - c.y, c.y - nd.hiy), 0.0);
    precise float ez = max(max(nd.loz - c.z, c.z - nd.hiz), 0.0);
    precise float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 <= rr2)) return 0u;
    precise float dw = nd.ax * w.x + nd.ay * w.y + nd.az * w.z;
    if (!(dw >= nd.rej)) return 0u; // below every surface in the node (§4.5)
    precise float fx = max(c.x - nd.lox, nd.hix - c.x);
    precise float fy = max(c.y - nd.loy, nd.hiy - c.y);
    precise float fz = max(c.z - nd.loz, nd.hiz - c.z);
    precise float f2 = fx * fx + fy * fy + fz * fz;
    if (f2 < re2) {
        emit(nd.lambert != 0u && dw > nd.acc ? 2u * id + 1u : 2u * id); // §4.6
        return 0u;
    }
    if (leaf) {
        emit(2u * id);
        return 0u;
    }
    return 1u;
}

void main() {
    const uint lid = gl_LocalInvocationID.x;
    if (lid == 0u) wg_visited = 0u;
    barrier();
    j = linear_group() * 64u + lid;
    visited = 0u;
    if (j < pc.n) {
        Photon q = ph[j];
        c = vec3(q.px, q.py, q.pz);
        w = vec3(q.dx, q.dy, q.dz);
        // est_cluster.c load_photon's margin (here for world-space boxes)
        const float r = pc.r;
        precise float slack = 1e-4 * r + 1e-5 * (abs(c.x) + abs(c.y) + abs(c.z) + r);
        precise float rp = r + slack, rm = r - slack;
        rr2 = rp * rp;
        re2 = rm > 0.0 ? rm * rm : -1.0;
        outs = 0u;
        base = pc.mode == 1u ? out_cnt[j] : 0u;
        const uint GG = pc.G * pc.G;
        for (uint s = 0u; s < pc.NS; s++) {
            if (decide(s, false) == 0u) continue;
            const uint f = nodes[s].first;
            for (uint l = 0u; l < GG; l++) {
                const uint tn = f + 2u * l;
                if (decide(tn, false) == 0u) continue;
                const uint f2 = nodes[tn].first, n2 = nodes[tn].count;
                for (uint k = 0u; k < n2; k++) decide(f2 + k, true);
            }
        }
        if (pc.mode == 0u) out_cnt[j] = outs;
    }
    if (pc.mode == 0u) {
        atomicAdd(wg_visited, visited);
        barrier();
        if (lid == 0u) {
            uint old = atomicAdd(counters[4], wg_visited);
            if (old + wg_visited < old) atomicAdd(counters[5], 1u);
        }
    }
}
