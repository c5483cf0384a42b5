// GPU cluster-trivial splat (gpu_cluster.c), one invocation a photon, as est_cluster.c's walk and
// decide (Moreau et al. 2016 §4.3-4.6) over the four fixed levels: a node the photon's sphere
// cannot reach (its box farther than r plus a margin) or that lies below the photon (normal cone)
// is skipped; an enclosed node takes the photon, as trivially accepted flux (all samples
// Lambertian and the photon above every normal: each sample would accept it) or else into its
// list; an intersected leaf takes it into its list; other nodes are descended. Directional
// (V_DIR): the deposit rule of est_cluster.c's V_DIR instead (entry 2 node: the node's buckets).
// cluster (no V_CONE, no V_TRIVIAL) and cluster-cone (V_CONE) skip the cone test or trivial accept.
// Each output, a (node entry, photon) pair (entry 2 node: the node's list, 2 node + 1: its trivially
// accepted photons), is appended at an atomic counter, in whatever order the invocations run:
// cl_group and cl_rank then put every list in photon order, so the order here does not matter.
// Pairs past the capacity (pc.npairs) are counted, not written: the host grows the buffer and
// runs the splat again. The traversal is one flat loop over the four levels (one node test an
// iteration), so that SIMD lanes at different levels keep working.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "cluster.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Photons { Photon ph[]; };
layout(std430, binding = 1) readonly buffer Nodes { Node nodes[]; };
layout(std430, binding = 2) writeonly buffer Pairs { uint pairs[]; };
// [4, 5] node tests (64-bit), [6] pairs (may exceed the capacity)
layout(std430, binding = 3) buffer Counters { uint counters[8]; };
shared uint wg_visited;

vec3 c, w;
float rr2, re2;
uint j;
uint visited;

void emit(uint entry) {
    uint k = atomicAdd(counters[6], 1u);
    if (k < pc.npairs) {
        pairs[2u * k] = entry;
        pairs[2u * k + 1u] = j;
    }
}

// 0: skipped or taken; 1: descend (first, count: the node's)
uint decide(uint id, uint lvl, bool leaf, out uint first, out uint count) {
    visited++;
    Node nd = nodes[id];
    first = nd.first;
    count = nd.count;
    if (nd.count == 0u) return 0u;
    precise float ex = max(max(nd.lox - c.x, c.x - nd.hix), 0.0);
    precise float ey = max(max(nd.loy - c.y, c.y - nd.hiy), 0.0);
    precise float ez = max(max(nd.loz - c.z, c.z - nd.hiz), 0.0);
    precise float d2 = ex * ex + ey * ey + ez * ez;
    if (!(d2 <= rr2)) return 0u;
    if ((pc.variant & V_DIR) != 0u) {
        // directional (est_cluster.c decide, V_DIR: no cone test): from level D down, an enclosed
        // node or a leaf whose box centre lies in the sphere takes the photon (its buckets)
        if (lvl >= pc.D) {
            precise float gx = max(c.x - nd.lox, nd.hix - c.x);
            precise float gy = max(c.y - nd.loy, nd.hiy - c.y);
            precise float gz = max(c.z - nd.loz, nd.hiz - c.z);
            precise float g2 = gx * gx + gy * gy + gz * gz;
            if (g2 < re2) {
                emit(2u * id);
                return 0u;
            }
            if (leaf) {
                precise float mx = 0.5 * (nd.lox + nd.hix) - c.x, my = 0.5 * (nd.loy + nd.hiy) - c.y,
                              mz = 0.5 * (nd.loz + nd.hiz) - c.z;
                precise float m2 = mx * mx + my * my + mz * mz;
                if (m2 < pc.r2) emit(2u * id);
                return 0u;
            }
        }
        return leaf ? 0u : 1u;
    }
    precise float dw = nd.ax * w.x + nd.ay * w.y + nd.az * w.z;
    if ((pc.variant & V_CONE) != 0u && !(dw >= nd.rej)) return 0u; // below every surface in the node (§4.5)
    precise float fx = max(c.x - nd.lox, nd.hix - c.x);
    precise float fy = max(c.y - nd.loy, nd.hiy - c.y);
    precise float fz = max(c.z - nd.loz, nd.hiz - c.z);
    precise float f2 = fx * fx + fy * fy + fz * fz;
    if (f2 < re2) {
        emit((pc.variant & V_TRIVIAL) != 0u && nd.lambert != 0u && dw > nd.acc ? 2u * id + 1u : 2u * id); // §4.6
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
        // levels 0 roots, 1 supertiles, 2 tiles, 3 clusters: the next child k_l of the node being
        // descended at each level (first child f_l; stride 2 between the children of one kind), in
        // plain variables (an array indexed by the level was spilled to memory, lane by lane)
        const uint RR = pc.R * pc.R, GG = pc.G * pc.G;
        uint lv = 0u, k0 = 0u, f1 = 0u, k1 = 0u, f2 = 0u, k2 = 0u, f3 = 0u, n3 = 0u, k3 = 0u;
        for (;;) {
            uint id;
            if (lv == 3u) {
                if (k3 >= n3) {
                    lv = 2u;
                    continue;
                }
                id = f3 + k3++;
            } else if (lv == 2u) {
                if (k2 >= GG) {
                    lv = 1u;
                    continue;
                }
                id = f2 + 2u * k2++;
            } else if (lv == 1u) {
                if (k1 >= RR) {
                    lv = 0u;
                    continue;
                }
                id = f1 + 2u * k1++;
            } else {
                if (k0 >= pc.NS0) break;
                id = k0++;
            }
            uint first, count;
            if (decide(id, lv, lv == 3u, first, count) != 0u) {
                if (lv == 0u) {
                    f1 = first;
                    k1 = 0u;
                } else if (lv == 1u) {
                    f2 = first;
                    k2 = 0u;
                } else {
                    f3 = first;
                    n3 = count;
                    k3 = 0u;
                }
                lv++;
            }
        }
    }
    atomicAdd(wg_visited, visited);
    barrier();
    if (lid == 0u) {
        uint old = atomicAdd(counters[4], wg_visited);
        if (old + wg_visited < old) atomicAdd(counters[5], 1u);
    }
}
