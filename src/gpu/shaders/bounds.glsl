// GPU bounds3d / bounds25d (gpu_bounds.c): a photon sphere's screen bound, as est_bounds.c
// make_shape, operation for operation where the C does it in float (`precise`: the build uses
// -ffp-contract=off): the projected circumscribed icosahedron's convex hull (3D) or the tight N-gon
// and the depth range (2.5D), then the rectangle and half-planes a X + b Y <= c in pixel
// coordinates, widened by 0.05 pixel and the view samples' jitter. The clipped case (a sphere
// reaching the eye plane) is est_bounds.c clipped_shape without double precision or trigonometric
// functions (a device may have neither, or only coarse ones): each slice's wedge ends as directions
// computed algebraically from a slightly larger radius, and a wedge end's bound taken only when it
// is clearly in front of the eye; a looser bound only adds tests.
// The including shader defines BD_PARAMS_BINDING and BD_SHAPES_BINDING before including it.
#ifndef PGIS_BOUNDS_GLSL
#define PGIS_BOUNDS_GLSL

#define BD_MARGIN 0.05             // est_bounds.c PIX_MARGIN (pixels)
#define BD_ICO_INRADIUS 1.5115226  // of the icosahedron below: phi^2 / sqrt(3)
#define BD_ICO_CIRCUM 1.9021130    // its circumradius
#define BD_HEAD 12u                // a shape's header floats, then its edges (a, b, c)

// The frame's bounds parameters (gpu_bounds.c bd_params).
struct BdParams {
    float jitter;           // pgi_view_samples.jitter: how far a primary sample projects from its pixel centre
    uint mode3d;            // 1: bounds3d, 0: bounds25d
    uint nverts;            // bounds25d: the polygon's vertices (--polygon)
    uint stride;            // floats a shape
    float cs[32], sn[32];   // bounds25d: cosf, sinf of pi k / (N / 2) (make_shape's slices)
    float ccs[32], csn[32]; // clipped case: cos, sin of pi k / m in double, to float (m = 2 for 3D, N / 2)
};

// A shape (shp[j * stride ...]): x0, x1, y0, y1 (pixel rectangle), zlo, zhi (view depth), edges
// (uint bits), valid (1.0: a primary sample may lie inside), the view-space centre, the padded
// radius; then edges x (a, b, c).
layout(std430, binding = BD_PARAMS_BINDING) readonly buffer Params { BdParams prm; };
layout(std430, binding = BD_SHAPES_BINDING) buffer Shapes { float shp[]; };

const vec3 BD_ICO[12] = vec3[12](vec3(0, 1, 1.6180340), vec3(0, -1, 1.6180340), vec3(0, 1, -1.6180340),
                                 vec3(0, -1, -1.6180340), vec3(1, 1.6180340, 0), vec3(-1, 1.6180340, 0),
                                 vec3(1, -1.6180340, 0), vec3(-1, -1.6180340, 0), vec3(1.6180340, 0, 1),
                                 vec3(-1.6180340, 0, 1), vec3(1.6180340, 0, -1), vec3(-1.6180340, 0, -1));

uint g_base, g_n; // the shape being made, its edges
float g_x0, g_x1, g_y0, g_y1;

float px_of(float xi) {
    precise float v = (xi / pc.sx + 1.0) * 0.5 * float(pc.width) - 0.5;
    return v;
}
float py_of(float yi) {
    precise float v = (1.0 - yi / pc.sy) * 0.5 * float(pc.height) - 0.5;
    return v;
}

// est_bounds.c add_edge
void add_edge(float a, float b, float c) {
    precise float l = sqrt(a * a + b * b);
    if (!(l > 0.0) || g_n >= (prm.stride - BD_HEAD) / 3u) return;
    uint o = g_base + BD_HEAD + 3u * g_n;
    precise float na = a / l, nb = b / l, nc = c / l + BD_MARGIN + prm.jitter * (abs(a) + abs(b)) / l;
    shp[o] = na;
    shp[o + 1u] = nb;
    shp[o + 2u] = nc;
    g_n++;
}

// est_bounds.c silhouette: tangent slopes of the planes through the eye touching the circle (a, z, r), z > r
void bd_silhouette(float a, float z, float r, out float u0, out float u1) {
    precise float den = (z - r) * (z + r);
    precise float disc = sqrt(max(0.0, a * a + den));
    precise float v0 = (a * z - r * disc) / den, v1 = (a * z + r * disc) / den;
    u0 = v0;
    u1 = v1;
}

float cross2(vec2 o, vec2 a, vec2 b) {
    precise float v = (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    return v;
}

// est_bounds.c clipped_shape: slices theta_k = pi k / m; in each, the circle (a, z, ri) seen from the
// eye spans a wedge of directions whose ends (x', z) = (a L -+ z q, z L +- a q) (q = ri x 1.0001, L =
// sqrt(a^2 + z^2 - q^2)) bound x' = tan(psi) in front of the eye. False: no point in front.
bool clipped_shape(vec3 c, float ri, uint m) {
    const float W = float(pc.width), H = float(pc.height);
    precise float ax = 2.0 * pc.sx / W, bx = pc.sx * (1.0 / W - 1.0);
    precise float ay = -2.0 * pc.sy / H, by = pc.sy * (1.0 - 1.0 / H);
    g_n = 0u;
    g_x0 = -1.0;
    g_y0 = -1.0;
    g_x1 = W;
    g_y1 = H;
    precise float q = ri * 1.0001;
    for (uint k = 0u; k < m; k++) {
        const float cs = prm.ccs[k], sn = prm.csn[k];
        precise float a = c.x * cs + c.y * sn, z = c.z;
        precise float d2 = a * a + z * z, q2 = q * q;
        if (!(d2 > q2 * 1.0001)) continue; // the eye inside the circle (or nearly): no bound
        precise float L = sqrt(d2 - q2);
        precise float lx = a * L - z * q, lz = z * L + a * q, hx = a * L + z * q, hz = z * L - a * q;
        precise float eps = 1e-5 * d2;
        // both ends behind the eye: the wedge (narrower than pi) is wholly behind it
        if (lz < -eps && hz < -eps) return false;
        bool has_lo = lz > eps, has_hi = hz > eps;
        precise float tlo = has_lo ? lx / lz : 0.0, thi = has_hi ? hx / hz : 0.0;
        precise float C0 = cs * bx + sn * by;
        if (k == 0u) {
            if (has_lo) g_x0 = max(g_x0, px_of(tlo));
            if (has_hi) g_x1 = min(g_x1, px_of(thi));
        } else if (2u * k == m) {
            if (has_hi) g_y0 = max(g_y0, py_of(thi));
            if (has_lo) g_y1 = min(g_y1, py_of(tlo));
        } else {
            precise float A = cs * ax, B = sn * ay;
            if (has_hi) add_edge(A, B, thi - C0);
            if (has_lo) add_edge(-A, -B, C0 - tlo);
        }
    }
    return true;
}

// est_bounds.c make_shape for the sphere (view-space centre c, radius r) into shape `base`; false
// (and valid 0) when no primary sample can be inside it.
bool make_shape(vec3 c, float r, uint base) {
    g_base = base;
    g_n = 0u;
    const float ri = pad_radius(c, r);
    precise float zlo = c.z - ri, zhi = c.z + ri;
    const float W = float(pc.width), H = float(pc.height);
    bool valid = zhi > 0.0; // primary samples have positive depth
    if (valid) {
        bool fallback = false;
        if (prm.mode3d != 0u) {
            precise float scale = ri / BD_ICO_INRADIUS * 1.00001;
            vec2 p[12];
            int idx[12];
            for (int k = 0; k < 12; k++) {
                precise float vx = c.x + scale * BD_ICO[k].x, vy = c.y + scale * BD_ICO[k].y;
                precise float vz = c.z + scale * BD_ICO[k].z;
                if (!(vz > 1e-3 * ri)) {
                    fallback = true;
                    break;
                }
                p[k] = vec2(px_of(vx / vz), py_of(vy / vz));
                idx[k] = k;
            }
            if (!fallback) {
                // Andrew's monotone chain on 12 points (insertion sort by x, y)
                for (int i = 1; i < 12; i++) {
                    int t = idx[i], j = i - 1;
                    while (j >= 0 && (p[idx[j]].x > p[t].x || (p[idx[j]].x == p[t].x && p[idx[j]].y > p[t].y))) {
                        idx[j + 1] = idx[j];
                        j--;
                    }
                    idx[j + 1] = t;
                }
                int hull[25], h = 0;
                for (int i = 0; i < 12; i++) {
                    while (h >= 2 && cross2(p[hull[h - 2]], p[hull[h - 1]], p[idx[i]]) <= 0.0) h--;
                    hull[h++] = idx[i];
                }
                for (int i = 10, lo = h + 1; i >= 0; i--) {
                    while (h >= lo && cross2(p[hull[h - 2]], p[hull[h - 1]], p[idx[i]]) <= 0.0) h--;
                    hull[h++] = idx[i];
                }
                h--; // the last point repeats the first
                g_x0 = g_y0 = uintBitsToFloat(0x7f800000u);
                g_x1 = g_y1 = uintBitsToFloat(0xff800000u);
                for (int i = 0; i < h; i++) {
                    vec2 a = p[hull[i]], b = p[hull[(i + 1) % h]];
                    precise float dx = b.x - a.x, dy = b.y - a.y;
                    precise float cc = dy * a.x - dx * a.y;
                    add_edge(dy, -dx, cc);
                    g_x0 = min(g_x0, a.x);
                    g_x1 = max(g_x1, a.x);
                    g_y0 = min(g_y0, a.y);
                    g_y1 = max(g_y1, a.y);
                }
            }
        } else if (c.z - ri > 1e-3 * ri) {
            float u0, u1, w0, w1;
            bd_silhouette(c.x, c.z, ri, u0, u1);
            bd_silhouette(c.y, c.z, ri, w0, w1);
            g_x0 = px_of(u0);
            g_x1 = px_of(u1);
            g_y0 = py_of(w1);
            g_y1 = py_of(w0);
            precise float ax = 2.0 * pc.sx / W, bx = pc.sx * (1.0 / W - 1.0);
            precise float ay = -2.0 * pc.sy / H, by = pc.sy * (1.0 - 1.0 / H);
            const uint m = prm.nverts / 2u;
            for (uint k = 1u; k < m; k++) {
                if (2u * k == m) continue; // the axis directions are the rectangle
                const float cs = prm.cs[k], sn = prm.sn[k];
                float t0, t1;
                precise float a = c.x * cs + c.y * sn;
                bd_silhouette(a, c.z, ri, t0, t1);
                precise float A = cs * ax, B = sn * ay, C0 = cs * bx + sn * by;
                precise float e1 = t1 - C0, e0 = C0 - t0;
                add_edge(A, B, e1);
                add_edge(-A, -B, e0);
            }
        } else
            fallback = true;
        if (fallback) // 3D: the icosahedron's circumsphere by the two axis slices; 2.5D: the sphere, N/2 slices
            valid = prm.mode3d != 0u ? clipped_shape(c, ri * (BD_ICO_CIRCUM / BD_ICO_INRADIUS) * 1.00001, 2u)
                                     : clipped_shape(c, ri, prm.nverts / 2u);
        if (valid) {
            precise float m = BD_MARGIN + prm.jitter;
            g_x0 -= m;
            g_y0 -= m;
            g_x1 += m;
            g_y1 += m;
            valid = g_x1 >= 0.0 && g_x0 <= W - 1.0 && g_y1 >= 0.0 && g_y0 <= H - 1.0;
        }
    }
    shp[base] = g_x0;
    shp[base + 1u] = g_x1;
    shp[base + 2u] = g_y0;
    shp[base + 3u] = g_y1;
    shp[base + 4u] = zlo;
    shp[base + 5u] = zhi;
    shp[base + 6u] = uintBitsToFloat(valid ? g_n : 0u);
    shp[base + 7u] = valid ? 1.0 : 0.0;
    shp[base + 8u] = c.x;
    shp[base + 9u] = c.y;
    shp[base + 10u] = c.z;
    shp[base + 11u] = ri;
    return valid;
}

// est_bounds.c row_span at row Y, for column X: whether pixel (X, Y) lies inside shape `base`.
bool shape_covers(uint base, float X, float Y) {
    if (!(shp[base + 2u] <= Y && Y <= shp[base + 3u])) return false;
    float xl = shp[base], xr = shp[base + 1u];
    const uint n = floatBitsToUint(shp[base + 6u]);
    for (uint e = 0u; e < n; e++) {
        uint o = base + BD_HEAD + 3u * e;
        precise float t = shp[o + 2u] - shp[o + 1u] * Y;
        float a = shp[o];
        if (a > 1e-6) xr = min(xr, t / a);
        else if (a < -1e-6) xl = max(xl, t / a);
        else if (t < 0.0) return false;
    }
    return xl <= X && X <= xr;
}

// est_bounds.c clip_lo / clip_hi: pixel rows or columns of the rectangle, clipped to [lo, hi]
int clip_lo(float v, int lo) { return v <= float(lo) ? lo : int(ceil(v)); }
int clip_hi(float v, int hi) { return v >= float(hi) ? hi : int(floor(v)); }

#endif
