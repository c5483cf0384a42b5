// The frame's per-pixel buffers and parameters (src/gpu/gpu_view.h documents them), shared by
// view.comp and direct.comp; include after scene.glsl. Bindings: 11 the frame parameters,
// 12 the view samples (gather.glsl ViewSample: what the GPU estimator reads), 13 the rest of the
// G-buffer (PixelExtra), 14 counters (primary rays, shadow rays: 64-bit sums as two words).
#ifndef PGIS_FRAME_GLSL
#define PGIS_FRAME_GLSL

#define VS_PRIMARY 2u
#define VS_GGX 8u

struct FrameParams { // pgi__gpu_frame_params
    vec4 eye_tan;     // eye, tan(fov_y / 2)
    vec4 fwd_aspect;  // forward, aspect
    vec4 right;
    vec4 up;
    uint width, height, jitter, index;    // jitter: 1 for the sub-pixel sequence; index: its point
    uint seed_lo, seed_hi, key_lo, key_hi; // the frame's seed; the jitter key (view.h pgi__pixel_jitter)
    uint direct_samples, output_mode, tex_filter; // tex_filter: view.c's ray cones (docs/design.md "Textures")
    float spread;                                 // the cone's spread, radians a unit distance
};

struct PixelExtra {
    vec4 ngeo_depth; // geometric normal on the eye's side; view-space depth of the primary hit
    vec4 weight;     // throughput of the specular chain (xyz)
    vec4 emit;       // emitted radiance seen along the eye path (xyz)
};

#ifndef FRAME_NO_PARAMS // direct.comp takes its few parameters as push constants, binding 11 its input
layout(std430, set = 0, binding = 11) readonly restrict buffer Frame { FrameParams fp; };
#endif
layout(std430, set = 0, binding = 12) restrict buffer Samples { ViewSample vsamp[]; };
layout(std430, set = 0, binding = 13) restrict buffer Extra { PixelExtra extra[]; };
layout(std430, set = 0, binding = 14) restrict buffer Counters { uint counters[4]; };

shared uint wg_rays;

void counter_add64(uint k, uint v) {
    uint old = atomicAdd(counters[2u * k], v);
    if (old + v < old) atomicAdd(counters[2u * k + 1u], 1u);
}

// ---- 64-bit arithmetic on (low, high) words, for pgi__pixel_jitter's SplitMix64 (core.h
// pgi__mix64), bit for bit: the device needs no shaderInt64.
uvec2 u64_add(uvec2 a, uvec2 b) {
    uint lo = a.x + b.x;
    return uvec2(lo, a.y + b.y + (lo < a.x ? 1u : 0u));
}
uvec2 u64_mul(uvec2 a, uvec2 b) {
    uint hi, lo;
    umulExtended(a.x, b.x, hi, lo);
    return uvec2(lo, hi + a.x * b.y + a.y * b.x);
}
uvec2 u64_xor_shr(uvec2 a, uint n) { // a ^ (a >> n), 0 < n < 32
    return a ^ uvec2((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}
uvec2 mix64(uvec2 z) {
    z = u64_mul(u64_xor_shr(z, 30u), uvec2(0x1ce4e5b9u, 0xbf58476du));
    z = u64_mul(u64_xor_shr(z, 27u), uvec2(0x133111ebu, 0x94d049bbu));
    return u64_xor_shr(z, 31u);
}

#endif
