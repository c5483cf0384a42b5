// Ray traversal of the GPU BVH (src/rt/tri_bvh.h documents the layout and the algorithm; the
// CPU traversal there is this code line for line, and tests/test_gpu_rays.c compares the two).
// Include it after choosing the bindings of its four storage buffers (set 0; these are the
// defaults):
//   #define BVH_NODES_BINDING 0   // pgi__tri_bvh_node[]
//   #define BVH_TRIS_BINDING 1    // pgi__tri_bvh_tri[]
//   #define BVH_MASKS_BINDING 2   // pgi__tri_bvh_mask[] (cut-out triangles; one dummy entry when none)
//   #define BVH_ALPHA_BINDING 3   // uint32 alpha words of the cut-out textures (idem)
//   #include "bvh.glsl"
// then call bvh_trace(origin, direction, tnear, tfar, any_hit, hit). Hits on cut-out triangles
// where their mask is open are refused, as the renderer's Embree filter does.
#ifndef PGIS_BVH_GLSL
#define PGIS_BVH_GLSL

#ifndef BVH_NODES_BINDING
#define BVH_NODES_BINDING 0
#endif
#ifndef BVH_TRIS_BINDING
#define BVH_TRIS_BINDING 1
#endif
#ifndef BVH_MASKS_BINDING
#define BVH_MASKS_BINDING 2
#endif
#ifndef BVH_ALPHA_BINDING
#define BVH_ALPHA_BINDING 3
#endif

#define BVH_EMPTY 0xFFFFFFFFu
#define BVH_LEAF 0x80000000u
#define BVH_LEAF_SHIFT 27
#define BVH_FIRST_MASK 0x07FFFFFFu
#define BVH_STACK 64
// 1 + 2 gamma(3): the far distance of a box test is widened by this (tri_bvh.c's BOX_WIDEN).
#define BVH_BOX_WIDEN 1.00000036
// Embree's rcp_safe: smaller direction components become +-this.
#define BVH_MIN_RCP 1e-18
// +infinity (GLSL leaves 1.0 / 0.0 undefined)
#define BVH_INF uintBitsToFloat(0x7F800000u)

struct BvhNode {
    vec4 lo_x, hi_x, lo_y, hi_y, lo_z, hi_z;
    uvec4 child;
};

struct BvhTri {
    vec4 v0_prim;  // v0; w: the scene triangle (floatBitsToUint)
    vec4 e1_flags; // v0 - v1; w: flags (bit 0: cut-out material; bits 1..31 its bvh_masks entry)
    vec4 e2;       // v2 - v0
};

struct BvhMask {
    vec4 uv01; // texture coordinates of vertices 0 and 1
    vec2 uv2;  // of vertex 2
    float cutoff;
    uint texel0;         // first texel in bvh_alpha
    uint width, height;  // width 0: no texture, alpha 1
    uint pad0, pad1;
};

layout(std430, set = 0, binding = BVH_NODES_BINDING) readonly restrict buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, set = 0, binding = BVH_TRIS_BINDING) readonly restrict buffer BvhTris { BvhTri bvh_tris[]; };
layout(std430, set = 0, binding = BVH_MASKS_BINDING) readonly restrict buffer BvhMasks { BvhMask bvh_masks[]; };
layout(std430, set = 0, binding = BVH_ALPHA_BINDING) readonly restrict buffer BvhAlpha { uint bvh_alpha[]; };

struct BvhHit {
    float t, u, v; // u, v: barycentrics of vertices 1 and 2
    uint prim;     // scene triangle, 0xFFFFFFFF: none
};

// Embree's Moeller-Trumbore on the triangle4 layout; `precise` keeps every product and sum
// unfused, as the CPU build (-ffp-contract=off), so that both round alike.
bool bvh_tri_hit(BvhTri tr, vec3 o, vec3 d, float tnear, float tfar, out float t, out float u, out float v) {
    precise vec3 e1 = tr.e1_flags.xyz;
    precise vec3 e2 = tr.e2.xyz;
    precise vec3 C = tr.v0_prim.xyz - o;
    precise vec3 R = vec3(C.y * d.z - C.z * d.y, C.z * d.x - C.x * d.z, C.x * d.y - C.y * d.x);
    precise vec3 Ng = vec3(e2.y * e1.z - e2.z * e1.y, e2.z * e1.x - e2.x * e1.z, e2.x * e1.y - e2.y * e1.x);
    precise float den = Ng.x * d.x + Ng.y * d.y + Ng.z * d.z;
    float absden = abs(den);
    float sgn = den < 0.0 ? -1.0 : 1.0;
    precise float U = (R.x * e2.x + R.y * e2.y + R.z * e2.z) * sgn;
    precise float V = (R.x * e1.x + R.y * e1.y + R.z * e1.z) * sgn;
    t = 0.0;
    u = 0.0;
    v = 0.0;
    precise float UV = U + V;
    if (!(den != 0.0 && U >= 0.0 && V >= 0.0 && UV <= absden)) return false;
    precise float T = (Ng.x * C.x + Ng.y * C.y + Ng.z * C.z) * sgn;
    precise float lo = absden * tnear;
    precise float hi = absden * tfar;
    if (!(lo < T && T <= hi)) return false;
    precise float rcp = 1.0 / absden;
    t = T * rcp;
    u = U * rcp;
    v = V * rcp;
    return true;
}

int bvh_wrap(int i, int n) { return i < 0 ? i + n : i >= n ? i - n : i; }

// The taps of a bilinear, wrapping lookup at (u, v) on w x h texels (texture.c: v = 0 the bottom
// row, texel centres at half-integers, a NaN or infinite coordinate read as 0): columns x0, x1 and
// rows y0, y1 in xy, the weights of x1 and y1 in t. Shared by the cut-out test and tex_bilinear.
void bilinear_taps(float u, float v, int w, int h, out ivec4 xy, out vec2 t) {
    if (isnan(u) || isinf(u)) u = 0.0;
    if (isnan(v) || isinf(v)) v = 0.0;
    precise float fu = u - floor(u);
    precise float fv = v - floor(v);
    precise float x = fu * float(w) - 0.5;
    precise float y = (1.0 - fv) * float(h) - 0.5;
    const float x0f = floor(x), y0f = floor(y);
    precise float tx = x - x0f;
    precise float ty = y - y0f;
    xy = ivec4(bvh_wrap(int(x0f), w), bvh_wrap(int(x0f) + 1, w), bvh_wrap(int(y0f), h), bvh_wrap(int(y0f) + 1, h));
    t = vec2(tx, ty);
}

float bvh_texel(BvhMask m, int x, int y) {
    const uint k = m.texel0 + uint(y) * m.width + uint(x);
    return float((bvh_alpha[k >> 2] >> (8u * (k & 3u))) & 0xFFu);
}

// Whether the cut-out triangle of `flags` is open at barycentrics (b1, b2): pgi__scene_cut_out
// (texture coordinates, then pgi__texture_alpha's bilinear wrapping lookup) operation for
// operation, as tri_bvh.c's pgi__tri_bvh_mask_filter.
bool bvh_cut_out(uint flags, float b1, float b2) {
    const BvhMask m = bvh_masks[flags >> 1];
    precise float bw = 1.0 - b1 - b2;
    precise float u = bw * m.uv01.x + b1 * m.uv01.z + b2 * m.uv2.x;
    precise float v = bw * m.uv01.y + b1 * m.uv01.w + b2 * m.uv2.y;
    float alpha = 1.0;
    if (m.width > 0u) {
        ivec4 q;
        vec2 wt;
        bilinear_taps(u, v, int(m.width), int(m.height), q, wt);
        const float tx = wt.x, ty = wt.y;
        const float a = bvh_texel(m, q.x, q.z), b = bvh_texel(m, q.y, q.z);
        const float c = bvh_texel(m, q.x, q.w), d = bvh_texel(m, q.y, q.w);
        precise float top = a + (b - a) * tx;
        precise float bot = c + (d - c) * tx;
        precise float al = (top + (bot - top) * ty) * (1.0 / 255.0);
        alpha = al;
    }
    return alpha < m.cutoff;
}

// Compare-and-swap of (distance, reference) pairs: only when a is strictly farther, so that the
// adjacent-pair network below is a stable sort (ties keep slot order, as tri_bvh.c's insertion).
void bvh_cswap(inout float da, inout uint ra, inout float db, inout uint rb) {
    if (da > db) {
        float td = da;
        da = db;
        db = td;
        uint tr = ra;
        ra = rb;
        rb = tr;
    }
}

// Closest hit in (tnear, tfar] (any_hit: the first hit found). Returns whether there is one.
bool bvh_trace(vec3 o, vec3 d, float tnear, float tfar, bool any_hit, out BvhHit hit) {
    hit.t = tfar;
    hit.u = 0.0;
    hit.v = 0.0;
    hit.prim = 0xFFFFFFFFu;
    vec3 dd = d;
    if (abs(dd.x) < BVH_MIN_RCP) dd.x = dd.x < 0.0 ? -BVH_MIN_RCP : BVH_MIN_RCP;
    if (abs(dd.y) < BVH_MIN_RCP) dd.y = dd.y < 0.0 ? -BVH_MIN_RCP : BVH_MIN_RCP;
    if (abs(dd.z) < BVH_MIN_RCP) dd.z = dd.z < 0.0 ? -BVH_MIN_RCP : BVH_MIN_RCP;
    const vec3 rd = vec3(1.0) / dd;
    const bool nx = rd.x < 0.0, ny = rd.y < 0.0, nz = rd.z < 0.0;
    uint stack[BVH_STACK];
    int sp = 0;
    uint ref = 0u;
    bool found = false;
    for (;;) {
        if ((ref & BVH_LEAF) == 0u) {
            const BvhNode nd = bvh_nodes[ref];
            const vec4 n0 = ((nx ? nd.hi_x : nd.lo_x) - o.x) * rd.x, f0 = ((nx ? nd.lo_x : nd.hi_x) - o.x) * rd.x;
            const vec4 n1 = ((ny ? nd.hi_y : nd.lo_y) - o.y) * rd.y, f1 = ((ny ? nd.lo_y : nd.hi_y) - o.y) * rd.y;
            const vec4 n2 = ((nz ? nd.hi_z : nd.lo_z) - o.z) * rd.z, f2 = ((nz ? nd.lo_z : nd.hi_z) - o.z) * rd.z;
            const vec4 tn = max(max(n0, n1), max(n2, vec4(tnear)));
            const vec4 tf = min(min(f0, f1), min(f2, vec4(tfar)));
            const bvec4 in_box = lessThanEqual(tn, tf * BVH_BOX_WIDEN);
            float d0 = in_box.x ? tn.x : BVH_INF, d1 = in_box.y ? tn.y : BVH_INF;
            float d2 = in_box.z ? tn.z : BVH_INF, d3 = in_box.w ? tn.w : BVH_INF;
            uint r0 = in_box.x ? nd.child.x : BVH_EMPTY, r1 = in_box.y ? nd.child.y : BVH_EMPTY;
            uint r2 = in_box.z ? nd.child.z : BVH_EMPTY, r3 = in_box.w ? nd.child.w : BVH_EMPTY;
            const int cnt = int(in_box.x) + int(in_box.y) + int(in_box.z) + int(in_box.w);
            // Odd-even transposition: stable, and the missed slots (infinitely far) go last.
            bvh_cswap(d0, r0, d1, r1);
            bvh_cswap(d2, r2, d3, r3);
            bvh_cswap(d1, r1, d2, r2);
            bvh_cswap(d0, r0, d1, r1);
            bvh_cswap(d2, r2, d3, r3);
            bvh_cswap(d1, r1, d2, r2);
            // Entered children whose distance is +inf would sort among the missed ones; a box the
            // ray enters has a finite entry distance, so the first cnt slots are the entered ones.
            if (cnt > 0) {
                if (cnt > 3) stack[sp++] = r3;
                if (cnt > 2) stack[sp++] = r2;
                if (cnt > 1) stack[sp++] = r1;
                ref = r0;
                continue;
            }
        } else {
            const uint first = ref & BVH_FIRST_MASK, last = first + ((ref >> BVH_LEAF_SHIFT) & 15u);
            for (uint i = first; i <= last; i++) {
                const BvhTri tr = bvh_tris[i];
                float t, u, v;
                if (!bvh_tri_hit(tr, o, d, tnear, tfar, t, u, v)) continue;
                const uint flags = floatBitsToUint(tr.e1_flags.w);
                if ((flags & 1u) != 0u && bvh_cut_out(flags, u, v)) continue;
                found = true;
                tfar = t;
                hit.t = t;
                hit.u = u;
                hit.v = v;
                hit.prim = floatBitsToUint(tr.v0_prim.w);
                if (any_hit) return true;
            }
        }
        if (sp == 0) break;
        ref = stack[--sp];
    }
    return found;
}

#endif
