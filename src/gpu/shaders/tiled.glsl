// GPU tiled (gpu_tiled.c): the push constants of every tl_* kernel, the view transform and the
// photon-to-list test of src/estimators/est_tiled.c (FOR_EACH_TILE: the photon's screen rectangle,
// each tile's view-space box and frustum planes, then the mirror-seen samples' cells), operation
// for operation where the C does it (`precise`: the build uses -ffp-contract=off).
#ifndef PGIS_TILED_GLSL
#define PGIS_TILED_GLSL

#include "photon.glsl"

layout(push_constant) uniform Push {
    float ex, ey, ez, rx, ry, rz, ux, uy, uz, fx, fy, fz; // eye, right, up, forward
    float sx, sy;                                         // tan(fov/2) * aspect, tan(fov/2)
    float r, r2;
    uint width, height, T, ntx, nty, ntiles, nlists;
    uint n;       // photons
    uint chunk;   // photons a count/copy invocation (fixed: the list order is photon order)
    uint nchunks; // count/copy invocations
    uint kernel;  // pgi_kernel
    float scale;  // kernel normalisation (pgi__kernel_norm)
    uint G;       // mirror cells: at most G a side (G^3 lists after the tiles')
    uint mode;    // kernel-specific
} pc;

// The mirror-seen samples' cells (tl_cells.comp): a dense grid of at most G x G x G cells of edge
// at least 2r over the samples' view-space box, each with the box of its samples.
struct CellGrid {
    float lo[3], hi[3]; // box of every mirror-seen sample
    float o[3];         // grid origin
    float inv_h;        // 1 / cell edge
    int dim[3];         // cells a side
    uint n;             // cells (dim[0] dim[1] dim[2]); 0: no mirror-seen sample
};

vec3 to_view(vec3 p) {
    precise vec3 d = p - vec3(pc.ex, pc.ey, pc.ez);
    precise float x = d.x * pc.rx + d.y * pc.ry + d.z * pc.rz;
    precise float y = d.x * pc.ux + d.y * pc.uy + d.z * pc.uz;
    precise float z = d.x * pc.fx + d.y * pc.fy + d.z * pc.fz;
    return vec3(x, y, z);
}

// screen.h pgi__pad_radius, with a larger relative term (the margin the host's lists use); a looser
// bound only adds photons to a list, never drops one the gather accepts.
float pad_radius(vec3 c, float r) {
    precise float p = r + 1e-4 * r + 4e-6 * (abs(c.x) + abs(c.y) + abs(c.z));
    return p;
}

float box_d2(vec3 lo, vec3 hi, vec3 c) {
    precise float d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        precise float a = lo[k] - c[k], b = c[k] - hi[k];
        float e = a > b ? a : b;
        if (e > 0.0) d2 += e * e;
    }
    return d2;
}

// est_tiled.c silhouette
void silhouette(float a, float z, float r, out float u0, out float u1) {
    precise float den = z * z - r * r;
    precise float disc = sqrt(max(0.0, a * a + den));
    u0 = (a * z - r * disc) / den;
    u1 = (a * z + r * disc) / den;
}

#endif
