// Direct light on the GPU and the frame's sum (src/gpu/gpu_view.c): one invocation a pixel, 8x8
// pixels a group. Mirrors src/view/view.c pgi__direct: from x = p + eps ng, one shadow ray a delta
// light (light.glsl light_delta), `direct_samples` area-light samples (the light stratified and
// picked by power with the CDF pgi__direct builds, a uniform point on its triangle, weight
// c cl / d^2 area / p_light, shadow ray to 0.999 of the distance), and for a constant sky
// `direct_samples` cosine-weighted directions (env.c pgi__env_sample_direct, first number
// stratified), each by the BRDF (bsdf.h pgi__brdf_eval: kd / pi + the lobe); the sum times the
// view sample's weight. In a scene with portals (nportals > 0) the sky's directions are view.c
// env_direct_portals': ceil(n/4) cosine-weighted and the rest towards the portals (portal.glsl),
// each strategy a Latin hypercube (permute), combined by the balance heuristic; a pixel that sees
// no portal takes all n from the cosine. No MIS for the area lights (the CPU has none). Random
// numbers: scene.glsl's counter-based hash, one stream a pixel and purpose (area lights, sky), not
// the CPU's PCG32.
// Then the sum, as the renderer's composite: emit + direct + weight * indirect (output 0), the
// indirect term alone (1) or emit + direct (2).
// Buffers: 0..10 the scene, 11 the estimator's radiance (3 floats a pixel), 12..14 frame.glsl,
// 15 the image (3 floats a pixel), 16 the portals (gpu_scene.h pgi__gpu_portal; nportals of them).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "scene.glsl"
#include "light.glsl"
#define PGIS_PORTAL_BINDING 16
#include "portal.glsl"
#define FRAME_NO_PARAMS
#include "frame.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, set = 0, binding = 11) readonly restrict buffer Indirect { float indirect[]; };
layout(std430, set = 0, binding = 15) writeonly restrict buffer Image { float image[]; };
layout(push_constant) uniform Push {
    SceneInfo scene;
    uint width, height, seed_lo, seed_hi;
    uint direct_samples, output_mode, has_indirect, nportals;
} pc;

// bsdf.h pgi__brdf_eval: kd / pi plus the lobe (one_m_eo: the sample's 1 - E(n.wo))
vec3 brdf(ViewSample v, vec3 kd, vec3 ns, vec3 wi, vec3 wo) {
    precise vec3 f = kd * float(PGIS_INV_PI);
    if ((v.flags & VS_LAMBERT) == 0u) f = f + lobe_eval(v.lobe, kd, ns, wi, wo, v.one_m_eo);
    return f;
}

bool occluded(vec3 x, vec3 wi, float tmax) {
    BvhHit h;
    return bvh_trace(x, wi, 0.0, tmax, true, h);
}

// scene_internal.h pgi__cdf_pick over the area lights
uint cdf_pick(float u, out float p) {
    uint lo = 0u, hi = pc.scene.narea - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (u < areas[mid].cdf) hi = mid;
        else lo = mid + 1u;
    }
    p = areas[lo].cdf - (lo > 0u ? areas[lo - 1u].cdf : 0.0);
    return areas[lo].light;
}

void main() {
    if (gl_LocalInvocationIndex == 0u) wg_rays = 0u;
    barrier();
    const uint px = gl_GlobalInvocationID.x, py = gl_GlobalInvocationID.y;
    uint rays = 0u;
    if (px < pc.width && py < pc.height) {
        const uint i = py * pc.width + px;
        const ViewSample v = vsamp[i];
        const PixelExtra ex = extra[i];
        vec3 L = vec3(0.0);
        if ((v.flags & VS_VALID) != 0u && pc.output_mode != 1u) { // the indirect light alone: no shadow ray
            const vec3 p = vec3(v.px, v.py, v.pz), ns = vec3(v.nx, v.ny, v.nz), ng = ex.ngeo_depth.xyz;
            const vec3 wo = vec3(v.wox, v.woy, v.woz), kd = vec3(v.kdx, v.kdy, v.kdz);
            precise vec3 x = p + ng * pc.scene.eps;
            for (uint l = 0u; l < pc.scene.nlights; l++) { // light.h pgi__light_delta
                vec3 wi, Li;
                float cs, tmax;
                if (!light_delta(lights[l], x, ns, ng, wi, Li, cs, tmax)) continue;
                rays++;
                if (occluded(x, wi, tmax)) continue;
                precise vec3 c = (brdf(v, kd, ns, wi, wo) * Li) * cs;
                L = L + c;
            }
            const uint n = pc.direct_samples;
            if (pc.scene.narea > 0u && n > 0u) {
                Rng rng = rng_seed(pc.seed_lo, pc.seed_hi, 0xd15ec7u, i);
                vec3 La = vec3(0.0);
                for (uint j = 0u; j < n; j++) {
                    precise float u = (float(j) + rng_f(rng)) / float(n); // stratified light pick
                    float pl;
                    const Light lt = lights[cdf_pick(u, pl)];
                    const float u1 = rng_f(rng), u2 = rng_f(rng);
                    precise vec3 dv = light_area_point(lt, u1, u2) - x;
                    const float d2 = v3_dot(dv, dv);
                    if (!(d2 > 0.0) || !(pl > 0.0)) continue;
                    const float dist = sqrt(d2);
                    precise vec3 wi = dv * (1.0 / dist);
                    const float cl = -v3_dot(wi, lt.normal), c = v3_dot(ns, wi);
                    if (!(cl > 0.0) || !(c > 0.0) || !(v3_dot(ng, wi) > 0.0)) continue;
                    precise float tmax = dist * (1.0 - 1e-3);
                    precise float g = c * cl / d2 * lt.area / pl;
                    rays++;
                    if (occluded(x, wi, tmax)) continue;
                    precise vec3 a = (brdf(v, kd, ns, wi, wo) * lt.color) * g;
                    La = La + a;
                }
                precise vec3 s = La * (1.0 / float(n));
                L = L + s;
            }
            if ((pc.scene.flags & SCENE_SKY) != 0u && n > 0u && pc.nportals > 0u) {
                // view.c env_direct_portals, constant sky: the cosine's pdf and radiance of a
                // portal's direction, and the portals' pdf of both, only where the ray escapes
                Rng rng = rng_seed(pc.seed_lo, pc.seed_hi, 0x736b79u, i);
                vec3 Le = vec3(0.0);
                const float sum = portal_direct_weights(pc.nportals, x, ns);
                const uint na = sum > 0.0 ? (n + 3u) / 4u : n, nb = n - na;
                const uint perm0 = rng_u32(rng), perm1 = rng_u32(rng); // the second numbers' permutations
                for (uint j = 0u; j < n; j++) {
                    const bool portal = j >= na;
                    vec3 d;
                    float pa = 0.0;
                    vec3 le = vec3(0.0);
                    if (!portal) { // the sky's sampler
                        precise float u1 = (float(j) + rng_f(rng)) / float(na);
                        precise float u2 = (float(permute(j, na, perm0)) + rng_f(rng)) / float(na);
                        d = to_world(sample_cosine(u1, u2), ns);
                        pa = max(0.0, v3_dot(ns, d)) * float(PGIS_INV_PI);
                        if (!(pa > 0.0)) continue;
                        le = sky_eval(pc.scene, d);
                    } else { // a portal
                        const uint jb = j - na;
                        precise float u0 = (float(jb) + rng_f(rng)) / float(nb);
                        precise float u2 = (float(permute(jb, nb, perm1)) + rng_f(rng)) / float(nb);
                        if (!portal_direct_sample(pc.nportals, x, ns, u0, u2, d)) continue;
                    }
                    const float c = v3_dot(ns, d);
                    if (!(c > 0.0) || !(v3_dot(ng, d) > 0.0)) continue;
                    rays++;
                    if (occluded(x, d, PGIS_INF)) continue;
                    const float pb = nb > 0u ? portal_direct_pdf(pc.nportals, x, ns, d) : 0.0;
                    if (portal) {
                        if (!(pb > 0.0)) continue; // lost to rounding at a portal's edge
                        pa = max(0.0, c) * float(PGIS_INV_PI);
                        le = sky_eval(pc.scene, d);
                    }
                    precise float den = float(na) * pa + float(nb) * pb;
                    if (!(den > 0.0) || isinf(den)) continue;
                    precise vec3 a = brdf(v, kd, ns, d, wo) * (le * (c / den));
                    Le = Le + a;
                }
                L = L + Le;
            } else if ((pc.scene.flags & SCENE_SKY) != 0u && n > 0u) { // view.c env_direct, constant sky
                Rng rng = rng_seed(pc.seed_lo, pc.seed_hi, 0x736b79u, i);
                vec3 Le = vec3(0.0);
                for (uint j = 0u; j < n; j++) {
                    precise float u1 = (float(j) + rng_f(rng)) / float(n);
                    const float u2 = rng_f(rng);
                    const vec3 wi = to_world(sample_cosine(u1, u2), ns);
                    precise float pdf = max(0.0, v3_dot(ns, wi)) * float(PGIS_INV_PI);
                    const float c = v3_dot(ns, wi);
                    if (!(pdf > 0.0) || !(c > 0.0) || !(v3_dot(ng, wi) > 0.0)) continue;
                    precise vec3 w = sky_eval(pc.scene, wi) * (c / pdf);
                    rays++;
                    if (occluded(x, wi, PGIS_INF)) continue;
                    precise vec3 a = brdf(v, kd, ns, wi, wo) * w;
                    Le = Le + a;
                }
                precise vec3 s = Le * (1.0 / float(n));
                L = L + s;
            }
            precise vec3 lw = L * ex.weight.xyz;
            L = lw;
        }
        // the renderer's composite
        vec3 ind = vec3(0.0);
        if (pc.has_indirect != 0u) {
            precise vec3 iw = ex.weight.xyz * vec3(indirect[3u * i], indirect[3u * i + 1u], indirect[3u * i + 2u]);
            ind = iw;
        }
        precise vec3 dir = ex.emit.xyz + L;
        const vec3 o = pc.output_mode == 1u ? ind : pc.output_mode == 2u ? dir : dir + ind;
        image[3u * i] = o.x;
        image[3u * i + 1u] = o.y;
        image[3u * i + 2u] = o.z;
    }
    atomicAdd(wg_rays, rays);
    barrier();
    if (gl_LocalInvocationIndex == 0u) counter_add64(1u, wg_rays);
}
