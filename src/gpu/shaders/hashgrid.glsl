// The GPU hash grid's cells (gpu_hashgrid.c): the cell coordinate of est_hashgrid.c's cell_coord
// (floor(x / cell), clamped to the 21-bit field the CPU keys use), and the bucket of a cell in the
// bucket table (a 32-bit hash; the table layout is the GPU's own, only the cells mirror the CPU).
#ifndef PGIS_HASHGRID_GLSL
#define PGIS_HASHGRID_GLSL

#define FIELD_BIAS 1048576 // 1 << (21 - 1), as est_hashgrid.c

#include "photon.glsl"

// est_hashgrid.c cell_coord: floorf(x * inv), NaN and out of range clamped.
int cell_coord(float x, float inv) {
    precise float c = floor(x * inv);
    if (!(c > float(-FIELD_BIAS))) c = float(-FIELD_BIAS);
    if (c > float(FIELD_BIAS - 1)) c = float(FIELD_BIAS - 1);
    return int(c);
}

// lowbias32 (Chris Wellons' hash-prospector): a full-avalanche 32-bit mixer
uint mix32(uint v) {
    v ^= v >> 16;
    v *= 0x7feb352du;
    v ^= v >> 15;
    v *= 0x846ca68bu;
    v ^= v >> 16;
    return v;
}

// The three coordinates mixed in turn (XOR-ing prime multiples, Teschner et al.'s hash, put a third
// of Cornell's cells into shared buckets; this leaves about the birthday bound).
uint cell_bucket(ivec3 c, uint mask) {
    uint h = mix32(uint(c.x) + 0x9e3779b9u);
    h = mix32(h ^ uint(c.y));
    h = mix32(h ^ uint(c.z));
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
