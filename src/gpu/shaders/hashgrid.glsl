// The GPU hash grid's cells (gpu_hashgrid.c): the cell coordinate of est_hashgrid.c's cell_coord
// (floor(x / cell), clamped to the 21-bit field the CPU keys use), and the bucket of a cell in the
// bucket table (a 32-bit hash; the table layout is the GPU's own, only the cells mirror the CPU).
#ifndef PGI_HASHGRID_GLSL
#define PGI_HASHGRID_GLSL

#define FIELD_BIAS 1048576 // 1 << (21 - 1), as est_hashgrid.c

struct Photon { // pgi__packed_photon (src/estimators/packed.h): 36 bytes
    float px, py, pz, dx, dy, dz, fr, fg, fb;
};

// est_hashgrid.c cell_coord: floorf(x * inv), NaN and out of range clamped.
int cell_coord(float x, float inv) {
    precise float c = floor(x * inv);
    if (!(c > float(-FIELD_BIAS))) c = float(-FIELD_BIAS);
    if (c > float(FIELD_BIAS - 1)) c = float(FIELD_BIAS - 1);
    return int(c);
}

uint cell_bucket(ivec3 c, uint mask) {
    uint h = uint(c.x) * 73856093u ^ uint(c.y) * 19349663u ^ uint(c.z) * 83492791u;
    // murmur3's finaliser
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    return h & mask;
}

// All hash-grid kernels take the same push constants (gpu_hashgrid.c hg_push).
layout(push_constant) uniform Push {
    float inv_cell; // 1 / cell edge
    float r;        // radius
    float r2;       // r * r
    uint n;         // photons (scan kernels: elements)
    uint mask;      // buckets - 1 (a power of two)
    uint width;     // image
    uint height;
    uint kernel;    // pgi_kernel
    float scale;    // kernel normalisation (pgi__kernel_norm)
    uint pad0, pad1, pad2;
} pc;

#endif
