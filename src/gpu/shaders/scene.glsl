// The scene on the GPU (src/gpu/gpu_scene.h documents the layouts and the bindings 0..10): the BVH
// (bvh.glsl), vertices, triangles, materials, lobes, lights, the area-light CDF and the textures,
// with the shading functions the frame's passes share, each mirroring a C function operation for
// operation (`precise` where the C does not contract: the build uses -ffp-contract=off):
//   scene_surface      bsdf.c   pgi__scene_surface_untextured
//   tex_lookup         texture.c pgi__texture_lookup (bilinear, wrapping, sRGB table)
//   surface_kd         bsdf.h   pgi__scene_kd (the vertex colour) and pgi__surface_texture
//   sky_eval           env.c    pgi__env_eval (constant sky only)
//   reflect_v, to_world, sample_cosine, basis: bsdf.h pgi__reflect, core.h pgi_to_world,
//                      pgi_sample_cosine, v3_basis
//   and through gather.glsl: lobe_eval (pgi__lobe_eval_o), lobe_E, fresnel_dielectric.
// The including kernel binds its own buffers from binding 11 and starts its push constants with
// `SceneInfo scene;`.
#ifndef PGIS_SCENE_GLSL
#define PGIS_SCENE_GLSL

#extension GL_GOOGLE_include_directive : require

#include "bvh.glsl"
#include "photon.glsl" // gather.glsl's gather() takes one
#define GATHER_LOBES_DECLARE layout(std430, set = 0, binding = 7) readonly restrict buffer Lobes { Lobe lobes[]; };
#include "gather.glsl"

#define MAT_LAMBERT 0u
#define MAT_PHONG 1u
#define MAT_MIRROR 2u
#define MAT_GLASS 3u
#define MAT_PLASTIC 4u

#define SCENE_NORMALS 1u
#define SCENE_UVS 2u
#define SCENE_SKY 4u
#define SCENE_COLORS 8u

#define PGIS_INF uintBitsToFloat(0x7F800000u) // +infinity (GLSL leaves 1.0 / 0.0 undefined)

struct SceneInfo { // pgi__gpu_scene_push, 64 bytes
    uint nlights, narea, flags, ntris;
    float eps, upx, upy, upz;
    vec4 sky;    // xyz
    vec4 ground; // xyz
};

struct Vert {
    vec4 pos_u;
    vec4 nrm_v;
    vec4 col; // xyz: the vertex colour (linear; 1 without colours)
};
struct Mat {
    vec3 kd;
    uint type;
    vec3 ks;
    float ior;
    vec3 ke;
    int tex_kd;
};
struct Light {
    vec3 pos;
    uint type;
    vec3 dir;
    float cos_cutoff;
    vec3 color;
    float area;
    vec3 normal;
    uint tri;
};
struct AreaPick {
    float cdf;
    uint light;
};

layout(std430, set = 0, binding = 4) readonly restrict buffer Verts { Vert verts[]; };
layout(std430, set = 0, binding = 5) readonly restrict buffer Tris { uvec4 tris[]; };
layout(std430, set = 0, binding = 6) readonly restrict buffer Mats { Mat mats[]; };
layout(std430, set = 0, binding = 8) readonly restrict buffer Lights { Light lights[]; };
layout(std430, set = 0, binding = 9) readonly restrict buffer Areas { AreaPick areas[]; };
layout(std430, set = 0, binding = 10) readonly restrict buffer Textures { uint texw[]; };

vec3 v3_norm(vec3 a) {
    float l = v3_len(a);
    precise vec3 r = a * (1.0 / l);
    return l > 0.0 ? r : vec3(0.0, 0.0, 1.0);
}
vec3 v3_cross(vec3 a, vec3 b) {
    precise vec3 r = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
    return r;
}
float v3_lum(vec3 a) {
    precise float l = 0.2126 * a.x + 0.7152 * a.y + 0.0722 * a.z;
    return l;
}

// core.h v3_basis (Duff et al.)
void basis(vec3 n, out vec3 t, out vec3 b) {
    float sign = n.z < 0.0 || (n.z == 0.0 && floatBitsToUint(n.z) != 0u) ? -1.0 : 1.0;
    precise float a = -1.0 / (sign + n.z);
    precise float bb = n.x * n.y * a;
    precise vec3 t0 = vec3(1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    precise vec3 b0 = vec3(bb, sign + n.y * n.y * a, -n.y);
    t = t0;
    b = b0;
}
vec3 to_world(vec3 l, vec3 n) {
    vec3 t, b;
    basis(n, t, b);
    precise vec3 r = t * l.x + b * l.y + n * l.z;
    return r;
}
vec3 sample_cosine(float u1, float u2) {
    float r = sqrt(u1), phi = 2.0 * float(PGIS_PI) * u2;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1)));
}
vec3 reflect_v(vec3 w, vec3 n) {
    precise vec3 r = n * (2.0 * v3_dot(w, n)) - w;
    return r;
}

// ---- textures (texture.c)
float tex_lut(uint c) { return uintBitsToFloat(texw[c]); }

vec3 tex_texel(uint first, int w, int x, int y) {
    const uint p = texw[first + uint(y) * uint(w) + uint(x)];
    return vec3(tex_lut(p & 0xFFu), tex_lut((p >> 8) & 0xFFu), tex_lut((p >> 16) & 0xFFu));
}

// texture.c pgi__texture_lookup: bilinear, wrapping, v = 0 the bottom row, texel centres at
// half-integers; a texture without texels gives 1.
// bilinear on w x h texels from word `first`
vec3 tex_bilinear(uint first, int w, int h, float u, float v) {
    ivec4 q;
    vec2 wt;
    bilinear_taps(u, v, w, h, q, wt); // bvh.glsl
    const float tx = wt.x, ty = wt.y;
    const vec3 a = tex_texel(first, w, q.x, q.z), b = tex_texel(first, w, q.y, q.z);
    const vec3 c = tex_texel(first, w, q.x, q.w), e = tex_texel(first, w, q.y, q.w);
    precise vec3 top = a * (1.0 - tx) + b * tx;
    precise vec3 bot = c * (1.0 - tx) + e * tx;
    precise vec3 r = top * (1.0 - ty) + bot * ty;
    return r;
}

vec3 tex_lookup(int tex, float u, float v) {
    const uvec4 d = uvec4(texw[256u + 4u * uint(tex)], texw[257u + 4u * uint(tex)], texw[258u + 4u * uint(tex)], 0u);
    if (d.y == 0u || d.z == 0u) return vec3(1.0);
    return tex_bilinear(d.x, int(d.y), int(d.z), u, v);
}

// texture.c pgi__texture_lookup_level: level l (its texels follow the levels before it, gpu_scene.c)
vec3 tex_level(int tex, float u, float v, int l) {
    const uint first = texw[256u + 4u * uint(tex)];
    const int w = int(texw[257u + 4u * uint(tex)]), h = int(texw[258u + 4u * uint(tex)]);
    uint at = first;
    for (int k = 0; k < l; k++) at += uint(max(1, w >> k)) * uint(max(1, h >> k));
    return tex_bilinear(at, max(1, w >> l), max(1, h >> l), u, v);
}

// texture.c pgi__texture_lookup_lod: trilinear between levels floor(lod) and floor(lod) + 1
vec3 tex_lookup_lod(int tex, float u, float v, float lod) {
    const uint w = texw[257u + 4u * uint(tex)], h = texw[258u + 4u * uint(tex)];
    const int levels = int(texw[259u + 4u * uint(tex)]);
    if (w == 0u || h == 0u) return vec3(1.0);
    if (!(lod > 0.0) || levels <= 1) return tex_lookup(tex, u, v);
    if (lod >= float(levels - 1)) return tex_level(tex, u, v, levels - 1);
    const int l = int(lod);
    precise float f = lod - float(l);
    const vec3 a = tex_level(tex, u, v, l), b = tex_level(tex, u, v, l + 1);
    precise vec3 r = a * (1.0 - f) + b * f;
    return r;
}

struct Surf {
    vec3 ng; // unit geometric normal (winding order)
    vec3 ns; // unit shading normal, same side as ng
    float u, v;
    uint mat;
    bool colored; // the scene has vertex colours: col multiplies kd
    vec3 col;     // the vertex colour at the hit (bsdf.h pgi__scene_col)
};

// bsdf.c pgi__scene_surface_untextured
Surf scene_surface(SceneInfo si, uint prim, float bu, float bv) {
    const uvec4 t = tris[prim];
    const vec3 a = verts[t.x].pos_u.xyz, b = verts[t.y].pos_u.xyz, c = verts[t.z].pos_u.xyz;
    precise float bw = 1.0 - bu - bv;
    Surf s;
    precise vec3 e1 = b - a;
    precise vec3 e2 = c - a;
    s.ng = v3_norm(v3_cross(e1, e2));
    s.ns = s.ng;
    if ((si.flags & SCENE_NORMALS) != 0u) {
        precise vec3 n = verts[t.x].nrm_v.xyz * bw + verts[t.y].nrm_v.xyz * bu + verts[t.z].nrm_v.xyz * bv;
        float l = v3_len(n);
        if (l > 0.0 && !isinf(l) && !isnan(l)) {
            precise vec3 nn = n * (1.0 / l);
            s.ns = v3_dot(nn, s.ng) < 0.0 ? -nn : nn;
        }
    }
    s.u = 0.0;
    s.v = 0.0;
    if ((si.flags & SCENE_UVS) != 0u) {
        precise float uu = bw * verts[t.x].pos_u.w + bu * verts[t.y].pos_u.w + bv * verts[t.z].pos_u.w;
        precise float vv = bw * verts[t.x].nrm_v.w + bu * verts[t.y].nrm_v.w + bv * verts[t.z].nrm_v.w;
        s.u = uu;
        s.v = vv;
    }
    s.mat = t.w;
    s.colored = (si.flags & SCENE_COLORS) != 0u;
    s.col = vec3(1.0);
    if (s.colored) {
        precise vec3 c = verts[t.x].col.xyz * bw + verts[t.y].col.xyz * bu + verts[t.z].col.xyz * bv;
        s.col = c;
    }
    return s;
}

// bsdf.h pgi__scene_kd and pgi__surface_texture: the material's kd times the vertex colour (where
// the scene has colours), times its texture
vec3 surface_kd(Surf s) {
    const Mat m = mats[s.mat];
    precise vec3 kd = m.kd;
    if (s.colored) kd = m.kd * s.col;
    if (m.tex_kd < 0) return kd;
    precise vec3 r = kd * tex_lookup(m.tex_kd, s.u, s.v);
    return r;
}

// env.c pgi__env_eval for a constant sky (an environment map is refused by gpu_scene.c)
vec3 sky_eval(SceneInfo si, vec3 w) {
    if ((si.flags & SCENE_SKY) == 0u) return vec3(0.0);
    return v3_dot(w, vec3(si.upx, si.upy, si.upz)) > 0.0 ? si.sky.xyz : si.ground.xyz;
}

// ---- random numbers: a counter-based hash (pcg4d, Jarzynski & Olano 2020, "Hash functions for
// GPU rendering"). A stream is (pixel, seed low word, seed high word ^ purpose); draw k hashes the
// stream with counter k, so each number depends on (seed, purpose, pixel, k) alone: deterministic
// whatever the dispatch order, and independent of the CPU's PCG32 numbers.
uvec4 pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}
struct Rng {
    uvec3 key;
    uint k;
};
Rng rng_seed(uint seed_lo, uint seed_hi, uint purpose, uint pixel) {
    return Rng(uvec3(pixel, seed_lo, seed_hi ^ purpose), 0u);
}
// Uniform in [0, 1), 24 bits as pgi_rng_f.
float rng_f(inout Rng r) {
    const uvec4 h = pcg4d(uvec4(r.key, r.k++));
    return float(h.x >> 8) * (1.0 / 16777216.0);
}
// 32 uniform bits (pgi_rng_u32's role: view.c's permutation keys), one draw.
uint rng_u32(inout Rng r) { return pcg4d(uvec4(r.key, r.k++)).x; }

#endif
