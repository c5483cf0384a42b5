// Lights on the GPU: src/scene/light.h's per-type functions for the shaders. The four numbers of
// an emission (light_draw), the start of a photon path from a point, spot, sun or area light
// (light_emit) or from the sky (light_emit_sky, from the values trace.glsl keeps in its emission
// records), a point of an area light (light_area_point) and the light a delta light sends towards
// a point (light_delta), and with differentials.glsl included first, a photon's emission
// differentials (light_emit_pd, differentials.c pgi__pd_emit). The same operations as light.h in
// the same order (precise: no contraction), so a light type changes in these two files together.
// Include after scene.glsl (verts, tris).
#ifndef PGIS_LIGHT_GLSL
#define PGIS_LIGHT_GLSL

// pgi__light_type (light.h)
#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_SUN 2u
#define LIGHT_AREA 3u
#define LIGHT_ENV 4u // the sky (its emission record only, never in lights[])

vec3 sample_sphere(float u1, float u2) {
    float z = 1.0 - 2.0 * u1, r = sqrt(max(0.0, 1.0 - z * z)), phi = float(2.0 * PGIS_PI) * u2;
    return vec3(r * cos(phi), r * sin(phi), z);
}
vec3 sample_cone(float u1, float u2, float cos_max) {
    float z = 1.0 - u1 * (1.0 - cos_max), r = sqrt(max(0.0, 1.0 - z * z)), phi = float(2.0 * PGIS_PI) * u2;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// light.h pgi__light_draw: u1, u2, then an area light's u4 before its u3 (the CPU's historical
// order), the sky's u3, u4; zeros for the rest.
vec4 light_draw(inout Rng rng, uint type) {
    const float u1 = rng_f(rng), u2 = rng_f(rng);
    float u3 = 0.0, u4 = 0.0;
    if (type == LIGHT_AREA) {
        u4 = rng_f(rng);
        u3 = rng_f(rng);
    } else if (type == LIGHT_ENV) {
        u3 = rng_f(rng);
        u4 = rng_f(rng);
    }
    return vec4(u1, u2, u3, u4);
}

// scene_internal.h pgi__triangle_sample on area light L's triangle.
vec3 light_area_point(Light L, float u1, float u2) {
    const uvec4 t = tris[L.tri];
    const float su = sqrt(u1);
    precise float b1 = 1.0 - su, b2 = u2 * su;
    precise vec3 q = verts[t.x].pos_u.xyz * (1.0 - b1 - b2) + verts[t.y].pos_u.xyz * b1 + verts[t.z].pos_u.xyz * b2;
    return q;
}

// light.h pgi__light_emit for a point, spot, sun or area light: origin and direction from the
// numbers u; the sun's photons leave a disk covering the bounding sphere (centre, radius), an area
// light's start eps off its triangle.
void light_emit(Light L, vec4 u, vec3 centre, float radius, float eps, out vec3 o, out vec3 d) {
    const float u1 = u.x, u2 = u.y, u3 = u.z, u4 = u.w;
    if (L.type == LIGHT_POINT) {
        o = L.pos;
        d = sample_sphere(u1, u2);
    } else if (L.type == LIGHT_SPOT) {
        o = L.pos;
        d = to_world(sample_cone(u1, u2, L.cos_cutoff), L.dir);
    } else if (L.type == LIGHT_SUN) {
        d = L.dir;
        float r = radius * sqrt(u1), phi = 2.0 * float(PGIS_PI) * u2;
        vec3 disk = to_world(vec3(r * cos(phi), r * sin(phi), 0.0), d);
        precise vec3 c = centre - d * (1.01 * radius) + disk;
        o = c;
    } else { // area: a uniform point of the triangle, the cosine lobe about its normal
        precise vec3 q2 = light_area_point(L, u1, u2) + L.normal * eps;
        o = q2;
        d = to_world(sample_cosine(u3, u4), L.normal);
    }
}

#ifdef PGIS_DIFFERENTIALS_GLSL
// differentials.c pgi__pd_emit (differentials.glsl, included before this file): the emission
// differentials of a photon leaving L (type LIGHT_ENV: the sky) in direction d, picked with
// probability pl, scaled so that the global Delta gives it its share of the light's solid angle
// (or area): |Delta dd|^2 = Omega / (n pl); radius: the sun's and the sky's disk.
void light_emit_pd(Light L, float pl, vec3 d, float radius, inout PDiff pd) {
    pl = max(pl, 1e-12);
    if (L.type == LIGHT_POINT) {
        pd_emit_dir(pd, d, vec3(0.0, 0.0, 1.0), sqrt(1.0 / pl));
    } else if (L.type == LIGHT_SPOT) {
        const float omega = 2.0 * float(PGIS_PI) * (1.0 - L.cos_cutoff);
        pd_emit_dir(pd, d, L.dir, sqrt(omega / (4.0 * float(PGIS_PI) * pl)));
    } else if (L.type == LIGHT_SUN || L.type == LIGHT_ENV) {
        // parallel light over a disk of radius R: positional differentials only
        vec3 t, b;
        basis(d, t, b);
        const float f = sqrt(float(PGIS_PI) * radius * radius / (4.0 * float(PGIS_PI) * pl));
        pd.dp[0] = t * f;
        pd.dp[1] = b * f;
        pd.dd[0] = pd.dd[1] = vec3(0.0);
    } else { // area: the cosine lobe's solid angle per photon, the origin offset back (eq. 13)
        const float ct = max(v3_dot(d, L.normal), 0.05);
        pd_emit_dir(pd, d, L.normal, sqrt(1.0 / (4.0 * pl * ct)));
        const float B = v3_len(v3_cross(pd.dd[0], pd.dd[1]));
        const float A = L.area / (4.0 * float(PGIS_PI) * pl);
        const float v = B > 0.0 ? sqrt(A / B) : 0.0;
        pd.dp[0] = pd.dd[0] * v;
        pd.dp[1] = pd.dd[1] * v;
    }
}
#endif

// light.h pgi__light_emit for the sky (env.c pgi__env_sample, constant sky: radiance `sky` above
// the horizon, `ground` below): a hemisphere by luminance (ps: the upper one's probability, fx, up,
// fz the sky's frame), uniform in it; then a uniform point of the disk of radius R across w
// outside the bounding sphere, the flux L(w) pi R^2 / (pdf(w) pl). false where the density is 0.
bool light_emit_sky(vec4 u, vec3 fx, vec3 up, vec3 fz, float ps, vec3 sky, vec3 ground, vec3 centre, float radius,
                    float pl, inout vec3 o, inout vec3 d, inout vec3 flux) {
    const float u1 = u.x, u2 = u.y, u3 = u.z, u4 = u.w;
    float y;
    if (u1 < ps) y = 1.0 - min(u1 / ps, 1.0);
    else y = -(u1 - ps) / max(1.0 - ps, 1e-30);
    y = min(1.0, max(-1.0, y));
    float r = sqrt(max(0.0, 1.0 - y * y)), phi = 2.0 * float(PGIS_PI) * u2;
    precise vec3 w = fx * (r * cos(phi)) + up * y + fz * (r * sin(phi));
    const bool upper = v3_dot(w, up) > 0.0;
    const float pdf = (upper ? ps : 1.0 - ps) * float(0.5 * PGIS_INV_PI);
    if (!(pdf > 0.0)) return false;
    const vec3 L = upper ? sky : ground;
    flux = L * (float(PGIS_PI) * radius * radius / (pdf * pl));
    d = -w;
    float rr = radius * sqrt(u3), ph = 2.0 * float(PGIS_PI) * u4;
    vec3 disk = to_world(vec3(rr * cos(ph), rr * sin(ph), 0.0), d);
    precise vec3 c = centre + w * (1.01 * radius) + disk;
    o = c;
    return true;
}

// light.h pgi__light_delta: a delta light's unit direction wi from x, its unshadowed radiance Li,
// cs = ns.wi and the shadow ray's far end; false where it cannot reach x.
bool light_delta(Light lt, vec3 x, vec3 ns, vec3 ng, out vec3 wi, out vec3 Li, out float cs, out float tmax) {
    wi = vec3(0.0);
    Li = vec3(0.0);
    cs = 0.0;
    tmax = 0.0;
    if (lt.type == LIGHT_AREA) return false;
    float dist;
    if (lt.type == LIGHT_SUN) {
        wi = -lt.dir;
        dist = PGIS_INF;
        Li = lt.color;
    } else {
        precise vec3 dv = lt.pos - x;
        const float d2 = v3_dot(dv, dv);
        if (!(d2 > 0.0)) return false;
        dist = sqrt(d2);
        precise vec3 w = dv * (1.0 / dist);
        wi = w;
        if (lt.type == LIGHT_SPOT && -v3_dot(wi, lt.dir) < lt.cos_cutoff) return false;
        precise vec3 li = lt.color * (1.0 / d2);
        Li = li;
    }
    cs = v3_dot(ns, wi);
    if (!(cs > 0.0) || !(v3_dot(ng, wi) > 0.0)) return false;
    precise float tm = dist * (1.0 - 1e-4);
    tmax = tm;
    if (isinf(dist)) tmax = PGIS_INF;
    return true;
}

#endif
