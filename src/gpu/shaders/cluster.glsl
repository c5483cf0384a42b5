// The GPU cluster-trivial estimator's shared definitions (gpu_cluster.c, docs/gpu.md): the push
// constants of every cl_*.comp kernel, the node record, the photon record, and the CPU clustering's
// depth slices (src/estimators/cluster_build.c fast_log2 / slice_of, operation for operation).
//
// Nodes (one array, four levels, fixed layout; `kind` 0: primary samples, 1: samples seen through
// mirrors or glass, which have their own nodes at every level as the CPU gives them their subtree):
//   [0, NS0)           roots: 2 x (R x R supertiles), index 2 r + kind (r row-major)
//   [NS0, NT0)         supertiles: 2 x R^2 per root, index NS0 + 2 (r R^2 + ly R + lx) + kind
//   [NT0, NL0)         tiles: 2 x G^2 per supertile slot s (as above), NT0 + 2 (s G^2 + ly G + lx) + kind
//   [NL0, nnodes)      clusters (leaves): T^2 slots per tile (row-major tile t), NL0 + t T^2 + k
// A tile's clusters are its primary clusters (by depth slice) then its mirror-seen ones (by cell).
#ifndef PGIS_CLUSTER_GLSL
#define PGIS_CLUSTER_GLSL

#include "photon.glsl"

// 64 bytes. World-space box of the samples, normal cone (axis; dot(axis, w) > acc: the photon
// direction is above every normal, < rej: below every one), all samples Lambertian, children.
struct Node {
    float lox, loy, loz, hix, hiy, hiz;
    float ax, ay, az, acc, rej;
    uint lambert;
    uint first; // leaf: unused; tile: first cluster node; supertile, root: first child (stride 2)
    uint count; // samples (leaf) / clusters (tile) / samples (supertile, root); 0: empty node
    uint pad0, pad1;
};

layout(push_constant) uniform Push {
    float r, r2;     // radius, r^2
    float inv_step;  // 1 / log2(1 + 2 tan(fov_y / 2) / tiles_y) (cluster_build.c scan_samples)
    float slack;     // culling margin
    uint n;          // photons (scan kernels: elements)
    uint width, height;
    uint T, G;       // tile edge (pixels), supertile edge (tiles)
    uint ntx, nty;   // tiles
    uint nrx, nry;   // roots (R x R supertiles each)
    uint mode;       // kernel-specific
    uint bits;       // mirror-seen samples: grid bits a side
    uint NS0, NT0;   // first supertile node, first tile node
    uint NL0;        // first leaf node
    uint nnodes;     // NL0 + tiles * T^2
    uint npairs;     // splat outputs
    uint R;          // root edge (supertiles)
    uint D;          // directional: the level (0 roots .. 3 clusters) from which photons deposit
    uint blur;       // directional: blur radius (pixels; 0: off)
    uint variant;    // est_cluster.c's V_*: 1 normal cones (§4.5), 2 trivial accept (§4.6), 4 directional
} pc;

#define VS_PRIMARY 2u // PGI_VS_PRIMARY
#define V_CONE 1u     // Push variant (est_cluster.c V_*)
#define V_TRIVIAL 2u
#define V_DIR 4u

// Kernels without the gather (CL_WITH_GATHER undefined) declare the view sample here; those with it
// include gather.glsl after this file, which declares it (the same 64 bytes) and the VS_* flags.
#ifndef CL_WITH_GATHER
#define VS_VALID 1u
#define VS_LAMBERT 4u
struct ViewSample {
    float px, py, pz, nx, ny, nz;
    float wox, woy, woz, kdx, kdy, kdz;
    float one_m_eo;
    uint flags;
    uint lobe;
    uint pad;
};
#endif

// The nodes above pixel (x, y)'s leaf: root, supertile, tile (kind 0 or 1).
void node_path(uint x, uint y, uint kind, out uint ids[3]) {
    const uint G = pc.G, R = pc.R, tx = x / pc.T, ty = y / pc.T, sx = tx / G, sy = ty / G;
    const uint r = (sy / R) * pc.nrx + sx / R, s = r * R * R + (sy % R) * R + sx % R;
    ids[0] = 2u * r + kind;
    ids[1] = pc.NS0 + 2u * s + kind;
    ids[2] = pc.NT0 + 2u * (s * G * G + (ty % G) * G + tx % G) + kind;
}

#define KEY_NONE 0xffffffffu
#define KEY_SEC 0x80000000u

// cluster_build.c fast_log2: a monotone stand-in for log2
float fast_log2(float x) {
    uint u = floatBitsToUint(x);
    float e = float(int((u >> 23) & 255u) - 127);
    float m = uintBitsToFloat((u & 0x007fffffu) | 0x3f800000u) - 1.0;
    precise float r = e + m * (1.3465 - 0.3465 * m);
    return r;
}

// cluster_build.c slice_of
uint slice_of(float z, float near, float log_near, float inv_step) {
    precise float k = 0.0;
    if (z > near) k = (fast_log2(z) - log_near) * inv_step;
    if (!(k >= 0.0)) return k < 0.0 ? 0u : 65535u;
    return k < 65535.0 ? uint(int(k)) : 65535u;
}

// Order-preserving float <-> uint (for atomicMin / atomicMax of floats).
uint f2ord(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float ord2f(uint u) { return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7fffffffu : ~u); }

// Spreads the low 10 bits of v to every third bit.
uint spread3(uint v) {
    v &= 0x3ffu;
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

// Cone thresholds from the axis and the smallest cosine between it and the samples' normals
// (trig-free, cluster_build.c's cone_thresholds in another form): with cos(alpha) >= cm for every
// normal, dot(axis, w) > sin(alpha) puts w within pi/2 - alpha of the axis, so above every normal;
// < -sin(alpha) below every one. sin(alpha) = sqrt((1 - cm)(1 + cm)) (no cancellation near 1);
// the margins cover the float dot products (< 1e-6). A cone of half-angle near pi/2 or more, a
// vanishing normal sum or a NaN normal is open (never accepts, never rejects). cone_axis: false
// when open; then cone_thresholds with the smallest dot(axis, n) of the samples.
bool cone_axis(inout Node nd, vec3 sum, uint count, bool bad) {
    precise float l = sqrt(sum.x * sum.x + sum.y * sum.y + sum.z * sum.z);
    nd.acc = 2.0;
    nd.rej = -2.0;
    if (bad || !(l > 1e-6 * float(count))) {
        nd.ax = 0.0;
        nd.ay = 0.0;
        nd.az = 1.0;
        return false;
    }
    nd.ax = sum.x / l;
    nd.ay = sum.y / l;
    nd.az = sum.z / l;
    return true;
}
void cone_thresholds(inout Node nd, float cmin, bool bad) {
    precise float cm = cmin - 1e-6;
    if (bad || !(cm > 1e-3)) return;
    precise float s = sqrt((1.0 - cm) * (1.0 + cm)) + 1e-4;
    nd.acc = s;
    nd.rej = -s;
}

#endif
