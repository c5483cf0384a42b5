// View samples on the GPU (src/gpu/gpu_view.c): one invocation a pixel, 8x8 pixels a group.
// Mirrors src/view/view.c: the primary ray through the pixel centre or the jittered point
// (view.h pgi__pixel_jitter bit for bit, pgi__camera_dir_at operation for operation), the eye path
// through mirrors and glass (bsdf.c pgi__bsdf_sample's specular cases; up to 8 specular bounces;
// glass picks reflection or refraction by Fresnel with the pixel's own random numbers, scene.glsl's
// counter-based hash, not the CPU's PCG32) to the first non-specular hit, and writes the view
// sample (gather.glsl ViewSample, lobe = the material) and PixelExtra, as shade_eye_path.
// Buffers: 0..10 the scene, 11..14 frame.glsl.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "frame.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant) uniform Push {
    SceneInfo scene;
} pc;

#define MAX_SPECULAR_DEPTH 8

// view.h pgi__camera_dir_at
vec3 camera_dir_at(uint x, uint y, float jx, float jy) {
    precise float u = (2.0 * (float(x) + jx) / float(fp.width) - 1.0) * fp.eye_tan.w * fp.fwd_aspect.w;
    precise float v = (1.0 - 2.0 * (float(y) + jy) / float(fp.height)) * fp.eye_tan.w;
    precise vec3 d = fp.fwd_aspect.xyz + (fp.right.xyz * u + fp.up.xyz * v);
    return v3_norm(d);
}

// bsdf.c pgi__bsdf_sample, the mirror and glass cases (the eye path stops at anything else).
bool specular_sample(Surf sf, Mat m, vec3 wi, float u1, out vec3 wo, out vec3 weight) {
    const float side = v3_dot(wi, sf.ng) >= 0.0 ? 1.0 : -1.0;
    const vec3 ng = sf.ng * side, ns = sf.ns * side;
    if (m.type == MAT_MIRROR) {
        wo = reflect_v(wi, ns);
        weight = m.ks;
        return v3_dot(wo, ng) > 0.0;
    }
    const float eta_i = side > 0.0 ? 1.0 : m.ior, eta_t = side > 0.0 ? m.ior : 1.0;
    const float ci = min(1.0, max(0.0, v3_dot(wi, ns)));
    const float F = fresnel_dielectric(ci, eta_i, eta_t);
    if (u1 < F) {
        wo = reflect_v(wi, ns);
        weight = vec3(1.0);
        return v3_dot(wo, ng) > 0.0;
    }
    precise float eta = eta_i / eta_t;
    precise float st2 = eta * eta * (1.0 - ci * ci);
    const float ct = sqrt(max(0.0, 1.0 - st2));
    precise vec3 t = (-wi) * eta - ns * (ct - eta * ci);
    wo = v3_norm(t);
    weight = m.ks;
    return v3_dot(wo, ng) < 0.0;
}

// view.c cone_lookup: the texture of sf (material textured) for a ray cone of `width` along d,
// its elliptical footprint's axes mapped into texels through the triangle's uv Jacobian, up to
// TEX_ANISO_MAX trilinear probes along the major one (docs/design.md "Textures"). The same
// operations in float; log2 and the probe count may differ from the CPU's in the last bits.
#define TEX_ANISO_MAX 8
#define TEX_LOD_BIAS (-0.79248125)
vec3 cone_tex(int tex, Surf sf, uint prim, float width, vec3 d) {
    const float W = float(texw[257u + 4u * uint(tex)]), H = float(texw[258u + 4u * uint(tex)]);
    const uvec4 t = tris[prim];
    const vec3 p0 = verts[t.x].pos_u.xyz;
    precise vec3 e1 = verts[t.y].pos_u.xyz - p0;
    precise vec3 e2 = verts[t.z].pos_u.xyz - p0;
    const float u0 = verts[t.x].pos_u.w, v0 = verts[t.x].nrm_v.w;
    precise float du1 = verts[t.y].pos_u.w - u0, dv1 = verts[t.y].nrm_v.w - v0;
    precise float du2 = verts[t.z].pos_u.w - u0, dv2 = verts[t.z].nrm_v.w - v0;
    const float cosine = v3_dot(d, sf.ng);
    precise float g11 = v3_dot(e1, e1), g12 = v3_dot(e1, e2), g22 = v3_dot(e2, e2);
    precise float det = g11 * g22 - g12 * g12;
    precise vec3 t1 = d - sf.ng * cosine;
    const float s1 = v3_len(t1);
    if (!(det > 0.0) || !(s1 > 1e-4) || !(abs(cosine) > 0.0) || !(width > 0.0)) {
        // texture.c pgi__texture_cone_lod with trace.c's pgi__tri_uv_lod
        const float pa = v3_len(v3_cross(e1, e2)), ta = abs(du1 * dv2 - du2 * dv1);
        const float tri_lod = !(ta > 0.0) ? -PGIS_INF : !(pa > 0.0) ? PGIS_INF : 0.5 * log2(ta / pa);
        return tex_lookup_lod(tex, sf.u, sf.v,
                              tri_lod + 0.5 * log2(W * H) + log2(width / abs(cosine)) + TEX_LOD_BIAS);
    }
    t1 = t1 * (1.0 / s1);
    const vec3 t2 = v3_cross(sf.ng, t1);
    vec2 uv[2];
    float len[2];
    const vec3 ax[2] = vec3[2](t1 * (width / abs(cosine)), t2 * width);
    for (int k = 0; k < 2; k++) {
        const float r1 = v3_dot(ax[k], e1), r2 = v3_dot(ax[k], e2);
        precise float a = (g22 * r1 - g12 * r2) / det, b = (g11 * r2 - g12 * r1) / det;
        uv[k] = vec2(a * du1 + b * du2, a * dv1 + b * dv2);
        len[k] = sqrt((uv[k].x * W) * (uv[k].x * W) + (uv[k].y * H) * (uv[k].y * H));
    }
    const int M = len[0] >= len[1] ? 0 : 1;
    const float major = len[M], minor = len[1 - M];
    if (!(minor > 0.0) || isinf(major) || isnan(major)) return tex_lookup(tex, sf.u, sf.v);
    const float ratio = major / minor;
    const int n = ratio >= float(TEX_ANISO_MAX) ? TEX_ANISO_MAX : ratio > 1.001 ? int(ceil(ratio - 0.001)) : 1;
    const float lod = log2(major / float(n)) + TEX_LOD_BIAS;
    if (n == 1) return tex_lookup_lod(tex, sf.u, sf.v, lod);
    vec3 sum = vec3(0.0);
    for (int i = 0; i < n; i++) {
        const float o = (float(i) + 0.5) / float(n) - 0.5;
        sum = sum + tex_lookup_lod(tex, sf.u + o * uv[M].x, sf.v + o * uv[M].y, lod);
    }
    return sum * (1.0 / float(n));
}

void main() {
    if (gl_LocalInvocationIndex == 0u) wg_rays = 0u;
    barrier();
    const uint x = gl_GlobalInvocationID.x, y = gl_GlobalInvocationID.y;
    uint rays = 0u;
    if (x < fp.width && y < fp.height) {
        const uint i = y * fp.width + x;
        float jx = 0.5, jy = 0.5;
        if (fp.jitter != 0u) { // view.h pgi__pixel_jitter
            const uvec2 h = mix64(u64_add(uvec2(fp.key_lo, fp.key_hi), u64_mul(uvec2(0x7f4a7c15u, 0x9e3779b9u),
                                                                                uvec2(i + 1u, i == 0xFFFFFFFFu ? 1u : 0u))));
            const uint ux = h.y + fp.index * 0xc13fa9a9u, uy = h.x + fp.index * 0x91e10da6u;
            jx = float(ux >> 8) * (1.0 / 16777216.0);
            jy = float(uy >> 8) * (1.0 / 16777216.0);
        }
        const vec3 eye = fp.eye_tan.xyz;
        vec3 o = eye, d = camera_dir_at(x, y, jx, jy);
        BvhHit h;
        bvh_trace(o, d, 0.0, PGIS_INF, false, h);
        rays++;
        vec3 weight = vec3(1.0), e = vec3(0.0);
        float depth_v = 0.0, width = 0.0; // the ray cone's width (view.c tex_cone)
        bool found = false;
        Rng rng = rng_seed(fp.seed_lo, fp.seed_hi, 0x5eed0f1eu, i);
        ViewSample vs = ViewSample(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u, 0u, 0u);
        PixelExtra px = PixelExtra(vec4(0.0), vec4(0.0), vec4(0.0));
        for (int depth = 0; h.prim != 0xFFFFFFFFu; depth++) {
            precise vec3 p = o + d * h.t;
            if (depth == 0) depth_v = v3_dot(p - eye, fp.fwd_aspect.xyz);
            const Surf sf = scene_surface(pc.scene, h.prim, h.u, h.v);
            const Mat m = mats[sf.mat];
            const vec3 wo = -d;
            const float side = v3_dot(wo, sf.ng) >= 0.0 ? 1.0 : -1.0;
            if (side > 0.0) e = e + weight * m.ke; // one-sided emitters
            precise float wn = width + fp.spread * h.t;
            width = wn;
            if (m.type != MAT_MIRROR && m.type != MAT_GLASS) {
                vec3 kd = surface_kd(sf);
                if (fp.tex_filter != 0u && m.tex_kd >= 0 && (pc.scene.flags & SCENE_UVS) != 0u) {
                    precise vec3 kf = (sf.colored ? m.kd * sf.col : m.kd) * cone_tex(m.tex_kd, sf, h.prim, width, d);
                    kd = kf;
                }
                const vec3 ng = sf.ng * side, ns = sf.ns * side;
                const uint model = lobes[sf.mat].model;
                vs = ViewSample(p.x, p.y, p.z, ns.x, ns.y, ns.z, wo.x, wo.y, wo.z, kd.x, kd.y, kd.z,
                                model == LOBE_GGX ? 1.0 - lobe_E(sf.mat, v3_dot(ns, wo)) : 0.0,
                                VS_VALID | (depth == 0 ? VS_PRIMARY : 0u) | (model == 0u ? VS_LAMBERT : 0u) |
                                    (model == LOBE_GGX ? VS_GGX : 0u),
                                sf.mat, 0u);
                px.ngeo_depth.xyz = ng;
                px.weight.xyz = weight;
                found = true;
                break;
            }
            if (depth + 1 >= MAX_SPECULAR_DEPTH) break;
            const float u1 = rng_f(rng);
            vec3 nd, w;
            if (!specular_sample(sf, m, wo, u1, nd, w)) break;
            weight = weight * w;
            const vec3 ngo = v3_dot(nd, sf.ng) >= 0.0 ? sf.ng : -sf.ng;
            precise vec3 on = p + ngo * pc.scene.eps;
            o = on;
            d = nd;
            rays++;
            if (!bvh_trace(o, d, 0.0, PGIS_INF, false, h)) break;
        }
        // an eye path that leaves the scene sees the sky
        if (!found && h.prim == 0xFFFFFFFFu) e = e + weight * sky_eval(pc.scene, d);
        px.ngeo_depth.w = depth_v;
        px.emit.xyz = e;
        vsamp[i] = vs;
        extra[i] = px;
    }
    atomicAdd(wg_rays, rays);
    barrier();
    if (gl_LocalInvocationIndex == 0u) counter_add64(0u, wg_rays);
}
