// A photon's footprint on the device (gpu_estimator.h pgi__gpu_footprint, 48 bytes): a sphere of
// radius r (a and b zero), or the ellipsoid {p + u a + v b + w r n : u^2 + v^2 + w^2 < 1} with
// r = sqrt(|a x b|) (radius policies `path` and `differentials`). The functions mirror
// src/estimators/footprint.h operation for operation (`precise`: the C does not contract).
#ifndef PGIS_FOOTPRINT_GLSL
#define PGIS_FOOTPRINT_GLSL

struct Footprint {
    float r, ax, ay, az, bx, by, bz, nx, ny, nz, pad0, pad1;
};

// pgi__footprint_weight: 1 / (pi r^2), the weight folded into the photon's flux
float footprint_weight(float r) {
    precise float w = 1.0 / (3.14159265358979323846 * r * r);
    return w;
}

// pgi__ellipsoid_inverse for the frame [a | b | r n]: the row-major inverse; false (and zeros: nothing
// is inside) when degenerate
bool ellipsoid_inverse(Footprint f, out float inv[9]) {
    precise float cx = f.r * f.nx, cy = f.r * f.ny, cz = f.r * f.nz;
    precise float r0x = f.by * cz - f.bz * cy, r0y = f.bz * cx - f.bx * cz, r0z = f.bx * cy - f.by * cx;
    precise float r1x = cy * f.az - cz * f.ay, r1y = cz * f.ax - cx * f.az, r1z = cx * f.ay - cy * f.ax;
    precise float r2x = f.ay * f.bz - f.az * f.by, r2y = f.az * f.bx - f.ax * f.bz, r2z = f.ax * f.by - f.ay * f.bx;
    precise float det = f.ax * r0x + f.ay * r0y + f.az * r0z;
    bool ok = abs(det) > 0.0 && (floatBitsToUint(det) & 0x7f800000u) != 0x7f800000u; // nonzero, finite
    precise float id = ok ? 1.0 / det : 0.0;
    precise float m[9] = float[9](r0x * id, r0y * id, r0z * id, r1x * id, r1y * id, r1z * id, r2x * id, r2y * id,
                                  r2z * id);
    inv = m;
    return ok;
}

// pgi__ellipsoid_contains: e = x - p strictly inside (|u|^2 < 1); a zero inverse accepts nothing
bool ellipsoid_contains(float inv[9], vec3 e) {
    precise float u = inv[0] * e.x + inv[1] * e.y + inv[2] * e.z;
    precise float w = inv[3] * e.x + inv[4] * e.y + inv[5] * e.z;
    precise float t = inv[6] * e.x + inv[7] * e.y + inv[8] * e.z;
    precise float q = u * u + w * w + t * t;
    return q < 1.0 && (inv[0] != 0.0 || inv[1] != 0.0 || inv[2] != 0.0);
}

// pgi__ellipsoid_extent: the axis-aligned half extents of the ellipsoid [a | b | r n]
vec3 ellipsoid_extent(Footprint f) {
    precise float cx = f.r * f.nx, cy = f.r * f.ny, cz = f.r * f.nz;
    precise float hx = f.ax * f.ax + f.bx * f.bx + cx * cx;
    precise float hy = f.ay * f.ay + f.by * f.by + cy * cy;
    precise float hz = f.az * f.az + f.bz * f.bz + cz * cz;
    return vec3(sqrt(hx), sqrt(hy), sqrt(hz));
}

#endif
