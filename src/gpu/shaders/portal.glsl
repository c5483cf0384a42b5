// Portals on the GPU: the sky's direct light through the scene's portals (windows, skylights)
// for direct.comp, as src/scene/portal.c's pgi__portal_direct_weights, pgi__portal_direct_sample
// and pgi__portal_direct_pdf (portal.h; docs/emission.md "Direct light from the sky through
// portals"): the same operations in the same order (precise: no contraction), with one
// difference of bookkeeping: the CPU keeps 2 n floats a point (each portal's pick probability and
// solid angle); an invocation here keeps the first PORTAL_LOCAL portals' and works out the others'
// again where it needs them (portal_w_at: the same function of the same inputs, so the same
// numbers). A rectangular portal's spherical rectangle (Ureña, Fajardo and King 2013) is set up
// again at each sample towards it (the CPU keeps the first four).
//
// The portals (pgi__gpu_portal, gpu_scene.h) are buffer PGIS_PORTAL_BINDING, which the includer
// defines. Include after scene.glsl.
#ifndef PGIS_PORTAL_GLSL
#define PGIS_PORTAL_GLSL

struct Portal { // pgi__gpu_portal, 112 bytes: portal.h pgi__portal
    vec3 o;
    float area;
    vec3 e1;
    uint rect; // e1 and e2 at right angles: sampled by solid angle
    vec3 e2;
    float pad0;
    vec3 n; // unit, into the interior
    float pad1;
    vec3 centre;
    float pad2;
    vec3 d1; // dual vectors: a = (x - o) . d1, b = (x - o) . d2 for x in its plane
    float pad3;
    vec3 d2;
    float pad4;
};
layout(std430, set = 0, binding = PGIS_PORTAL_BINDING) readonly restrict buffer Portals { Portal portals[]; };

#define PORTAL_ONE_MINUS uintBitsToFloat(0x3F7FFFFFu) // nextafterf(1, 0)

// portal.h pgi__portal_hit: where the line o + t d meets portal i (any t), within its edges.
bool portal_hit(uint i, vec3 o, vec3 d, out float t) {
    t = 0.0;
    const vec3 n = portals[i].n;
    const float dn = v3_dot(d, n);
    if (!(abs(dn) > 1e-12)) return false;
    precise vec3 po = portals[i].o - o;
    precise float tt = v3_dot(po, n) / dn;
    precise vec3 q = (o + d * tt) - portals[i].o;
    const float a = v3_dot(q, portals[i].d1), b = v3_dot(q, portals[i].d2);
    const float lo = -1e-6, hi = 1.0 + 1e-6;
    if (!(a >= lo && a <= hi && b >= lo && b <= hi)) return false;
    t = tt;
    return true;
}

// portal.h pgi__portal_point
vec3 portal_point(uint i, float a, float b) {
    precise vec3 p = portals[i].o + (portals[i].e1 * a + portals[i].e2 * b);
    return p;
}

// portal.c fast_acos: Abramowitz and Stegun 4.4.46 (within 1e-7 rad), c clamped to [-1, 1].
float fast_acos(float c) {
    const float a = c < 0.0 ? -c : c, m = a < 1.0 ? a : 1.0;
    precise float p =
        ((((((-0.0012624911 * m + 0.0066700901) * m - 0.0170881256) * m + 0.0308918810) * m - 0.0501743046) * m +
          0.0889789874) *
             m -
         0.2145988016) *
            m +
        1.5707963050;
    precise float r = sqrt(1.0 - m) * p;
    return c < 0.0 ? float(PGIS_PI) - r : r;
}

// portal.h pgi__portal_sph: a rectangle seen from a point, in a frame at the point.
struct SphRect {
    vec3 x, y, z;
    float x0, y0, z0, x1, y1, b0, b1, k, S;
};

// portal.c sph_rect_init: false where o is in the portal's plane or its solid angle is tiny.
bool sph_rect_init(uint i, vec3 o, out SphRect r) {
    const vec3 e1 = portals[i].e1, e2 = portals[i].e2;
    const float l1 = v3_len(e1), l2 = v3_len(e2);
    r.x = e1 * (1.0 / l1);
    r.y = e2 * (1.0 / l2);
    r.z = v3_cross(r.x, r.y);
    precise vec3 d = portals[i].o - o;
    r.x0 = v3_dot(d, r.x);
    r.y0 = v3_dot(d, r.y);
    r.z0 = v3_dot(d, r.z);
    r.x1 = r.y1 = r.b0 = r.b1 = r.k = r.S = 0.0;
    if (r.z0 > 0.0) {
        r.z0 = -r.z0;
        r.z = -r.z;
    }
    if (!(-r.z0 > 1e-5 * max(l1, l2))) return false; // o in the portal's plane
    precise float x1 = r.x0 + l1, y1 = r.y0 + l2;
    r.x1 = x1;
    r.y1 = y1;
    const vec3 v00 = vec3(r.x0, r.y0, r.z0), v01 = vec3(r.x0, r.y1, r.z0), v10 = vec3(r.x1, r.y0, r.z0),
               v11 = vec3(r.x1, r.y1, r.z0);
    const vec3 n0 = v3_norm(v3_cross(v00, v10)), n1 = v3_norm(v3_cross(v10, v11)), n2 = v3_norm(v3_cross(v11, v01)),
               n3 = v3_norm(v3_cross(v01, v00));
    const float g0 = fast_acos(-v3_dot(n0, n1)), g1 = fast_acos(-v3_dot(n1, n2)), g2 = fast_acos(-v3_dot(n2, n3)),
                g3 = fast_acos(-v3_dot(n3, n0));
    r.b0 = n0.z;
    r.b1 = n2.z;
    precise float k = 2.0 * float(PGIS_PI) - g2 - g3;
    precise float S = g0 + g1 - k;
    r.k = k;
    r.S = S;
    // a tiny solid angle is lost to rounding (the angles' sum cancels): area sampling then
    return !isinf(S) && !isnan(S) && S > 1e-3;
}

// portal.c sph_rect_sample: the point (u, v) of the spherical rectangle, uniform in solid angle.
vec3 sph_rect_sample(SphRect r, vec3 o, float u, float v) {
    precise float au = u * r.S + r.k;
    precise float fu = (cos(au) * r.b0 - r.b1) / sin(au);
    precise float cu = (fu > 0.0 ? 1.0 : -1.0) / sqrt(fu * fu + r.b0 * r.b0);
    cu = cu < -1.0 ? -1.0 : cu > 1.0 ? 1.0 : cu;
    precise float s2 = 1.0 - cu * cu;
    precise float xu = -(cu * r.z0) / sqrt(s2 > 1e-12 ? s2 : 1e-12);
    xu = xu < r.x0 ? r.x0 : xu > r.x1 ? r.x1 : xu;
    precise float d = sqrt(xu * xu + r.z0 * r.z0);
    precise float h0 = r.y0 / sqrt(d * d + r.y0 * r.y0), h1 = r.y1 / sqrt(d * d + r.y1 * r.y1);
    precise float hv = h0 + v * (h1 - h0), hv2 = hv * hv;
    precise float yv = hv2 < 1.0 - 1e-6 ? hv * d / sqrt(1.0 - hv2) : r.y1;
    precise vec3 y = o + ((r.x * xu + r.y * yv) + r.z * r.z0);
    return y;
}

// Portal i's weight seen from x of shading normal ns before normalisation, and its solid angle sa
// where it is sampled by solid angle (else 0): one term of pgi__portal_direct_weights.
float portal_weight(uint i, vec3 x, vec3 ns, out float sa) {
    precise vec3 v = x - portals[i].centre; // from the portal to x
    const float r2 = v3_dot(v, v), cp = v3_dot(portals[i].n, v);
    float wi = 0.0;
    sa = 0.0;
    // a portal wholly below x's horizon (its four corners) lights nothing: not picked
    precise vec3 d0 = portals[i].o - x;
    const float h0 = v3_dot(ns, d0), h1 = v3_dot(ns, portals[i].e1), h2 = v3_dot(ns, portals[i].e2);
    precise float h01 = h0 + h1, h02 = h0 + h2, h012 = h0 + h1 + h2;
    const bool above = h0 > 0.0 || h01 > 0.0 || h02 > 0.0 || h012 > 0.0;
    if (cp > 0.0 && r2 > 0.0 && above) {
        const float r = sqrt(r2);
        precise float cr = -v3_dot(ns, v) / r;
        SphRect sr;
        if (portals[i].rect != 0u && sph_rect_init(i, x, sr)) sa = sr.S; // its solid angle, sampled exactly
        precise float omega = sa > 0.0 ? sa : portals[i].area * (cp / r) / r2;
        precise float w = omega * (0.1 + (cr > 0.0 ? cr : 0.0));
        wi = w;
        if (isinf(wi) || isnan(wi)) wi = sa = 0.0;
    }
    return wi;
}

// The first PORTAL_LOCAL portals' pick probabilities and solid angles at the current point, and
// the weights' sum (portal_direct_weights).
#define PORTAL_LOCAL 8
float portal_w[PORTAL_LOCAL], portal_sa[PORTAL_LOCAL];
float portal_sum;

// pgi__portal_direct_weights over the np portals at x: the sum of the weights (0: no portal
// lights x); the pick probabilities (weights over the sum) follow from portal_w_at.
float portal_direct_weights(uint np, vec3 x, vec3 ns) {
    float sum = 0.0;
    for (uint i = 0u; i < np; i++) {
        float sa;
        const float wi = portal_weight(i, x, ns, sa);
        if (i < PORTAL_LOCAL) {
            portal_w[i] = wi;
            portal_sa[i] = sa;
        }
        precise float s = sum + wi;
        sum = s;
    }
    portal_sum = sum;
    if (sum > 0.0)
        for (uint i = 0u; i < min(np, uint(PORTAL_LOCAL)); i++) portal_w[i] = portal_w[i] / sum;
    return sum;
}

// Portal i's pick probability (w[i] of pgi__portal_direct_weights) and solid angle (w[n + i]) at
// the point of the last portal_direct_weights.
float portal_w_at(uint i, vec3 x, vec3 ns, out float sa) {
    if (i < PORTAL_LOCAL) {
        sa = portal_sa[i];
        return portal_w[i];
    }
    const float wi = portal_weight(i, x, ns, sa);
    return wi / portal_sum;
}

// pgi__portal_direct_sample: a direction from x towards a portal picked with u0 (its place within
// the portal's share the point's first number), u2 the second; false when it is degenerate.
bool portal_direct_sample(uint np, vec3 x, vec3 ns, float u0, float u2, out vec3 dir) {
    dir = vec3(0.0, 0.0, 1.0);
    uint k = np, last = np;
    float acc = 0.0, lo = 0.0, wk = 0.0, sak = 0.0, lastw = 0.0, lastsa = 0.0;
    for (uint i = 0u; i < np; i++) {
        float sa;
        const float w = portal_w_at(i, x, ns, sa);
        lo = acc;
        precise float a = acc + w;
        acc = a;
        if (w > 0.0) {
            last = i;
            lastw = w;
            lastsa = sa;
            if (u0 < acc) {
                k = i;
                wk = w;
                sak = sa;
                break;
            }
        }
    }
    if (k == np) { // rounding: the last portal with weight
        if (last == np) return false;
        k = last;
        wk = lastw;
        sak = lastsa;
        precise float l = acc - wk;
        lo = l;
    }
    // u0's place within the portal's share is the point's first number: stratified picks then
    // stratify the points across each portal too
    precise float u1 = (u0 - lo) / wk;
    u1 = u1 > 0.0 ? (u1 < 1.0 ? u1 : PORTAL_ONE_MINUS) : 0.0;
    vec3 y;
    SphRect sr;
    if (sak > 0.0 && sph_rect_init(k, x, sr)) y = sph_rect_sample(sr, x, u1, u2);
    else y = portal_point(k, u1, u2);
    precise vec3 v = y - x;
    const float l = v3_len(v);
    if (!(l > 0.0)) return false;
    precise vec3 d = v * (1.0 / l);
    dir = d;
    return true;
}

// pgi__portal_direct_pdf: the solid-angle density of portal_direct_sample for direction dir from
// x (every portal the ray x + t dir, t > 0, crosses inwards).
float portal_direct_pdf(uint np, vec3 x, vec3 ns, vec3 dir) {
    float pdf = 0.0;
    for (uint i = 0u; i < np; i++) {
        const float cn = -v3_dot(portals[i].n, dir); // light travels -dir
        float t;
        if (!(cn > 0.0) || !portal_hit(i, x, dir, t) || !(t > 0.0)) continue;
        float sa;
        const float w = portal_w_at(i, x, ns, sa);
        if (!(w > 0.0)) continue;
        precise float p = pdf + w * (sa > 0.0 ? 1.0 / sa : t * t / (portals[i].area * cn));
        pdf = p;
    }
    return pdf;
}

// view.c permute (Kensler 2013): element i of a pseudo-random permutation of 0..l-1 chosen by p.
uint permute(uint i, uint l, uint p) {
    uint w = l - 1u;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    do {
        i ^= p;
        i *= 0xe170893du;
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i *= 0x0929eb3fu;
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i *= 1u | p >> 27;
        i *= 0x6935fa69u;
        i ^= (i & w) >> 11;
        i *= 0x74dcb303u;
        i ^= (i & w) >> 2;
        i *= 0x9e501cc3u;
        i ^= (i & w) >> 2;
        i *= 0xc860a3dfu;
        i &= w;
        i ^= i >> 5;
    } while (i >= l);
    return (i + p) % l;
}

#endif
