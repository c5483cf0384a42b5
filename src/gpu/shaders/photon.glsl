// The photon record the GPU estimators read and the photon tracer writes: pgi__packed_photon
// (src/estimators/packed.h), 36 bytes: position, direction of travel, flux.
#ifndef PGIS_PHOTON_GLSL
#define PGIS_PHOTON_GLSL

struct Photon {
    float px, py, pz, dx, dy, dz, fr, fg, fb;
};

#endif
