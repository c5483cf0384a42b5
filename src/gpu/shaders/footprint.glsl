// A photon's footprint on the device (gpu_estimator.h pgi__gpu_footprint, 48 bytes): a sphere of
// radius r (a and b zero), or the ellipsoid {p + u a + v b + w r n : u^2 + v^2 + w^2 < 1} with
// r = sqrt(|a x b|) (radius policies `path` and `differentials`).
#ifndef PGIS_FOOTPRINT_GLSL
#define PGIS_FOOTPRINT_GLSL

struct Footprint {
    float r, ax, ay, az, bx, by, bz, nx, ny, nz, pad0, pad1;
};

#endif
