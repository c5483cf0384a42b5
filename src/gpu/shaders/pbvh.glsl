// GPU bvh (gpu_pbvh.c): the photon BVH of src/estimators/est_bvh.c's linear builder (Fabianowski &
// Dingliana 2009 §5.2, §6.2) on the device: 30-bit Morton codes of the photons over their box,
// sorted (gpu_sort.h), and the binary radix tree of the sorted codes (Karras 2012): internal node
// i's range and split from the codes' common prefixes, the split at the range's highest differing
// bit, as the CPU splits; a node of at most `leaf` photons is walked as a leaf.
#ifndef PGIS_PBVH_GLSL
#define PGIS_PBVH_GLSL

#include "footprint.glsl"
#include "photon.glsl"

// 48 bytes. Box of the photons' footprints, the range of sorted photons [first, last], children
// (LEAF | photon, or an internal node).
struct Node {
    float lox, loy, loz, hix, hiy, hiz;
    uint first, last, left, right, pad0, pad1;
};
#define LEAF 0x80000000u

// pc.fp: the photons' footprints, and their shapes in the sorted order (shp[], written by pb_prep):
#define FP_FIXED 0u     // spheres of radius pc.r (no shapes)
#define FP_SPHERE 1u    // spheres of their own radius: 1 float a photon, r
#define FP_ELLIPSOID 2u // 12 floats a photon: the inverse of its frame (9, row-major), its box's half extents
#define ELL_FLOATS 12u

layout(push_constant) uniform Push {
    float r, r2;  // radius
    float scale;  // kernel normalisation (pgi__kernel_norm)
    float pad0;
    uint n;       // photons
    uint leaf;    // leaf threshold T
    uint width, height;
    uint kernel;  // pgi_kernel
    uint mode;    // kernel-specific
    uint fp;      // FP_*
    uint pad2;
} pc;

uint f2ord(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float ord2f(uint u) { return uintBitsToFloat((u & 0x80000000u) != 0u ? u & 0x7fffffffu : ~u); }

#endif
