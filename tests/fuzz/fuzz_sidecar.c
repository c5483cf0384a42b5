/* libFuzzer target: a reference's sidecar (REF.exr.json, include/photongi/reference.h) through
 * pgi_reference_meta_read, as `photongi reference --continue` and `--merge` and `compare` read it.
 * A read that fails must say why; one that succeeds must hold values in their documented ranges
 * and survive a write and a second read unchanged (else abort: a finding). */
#include <photongi/photongi.h>
#include <photongi/reference.h>

#include "fuzz_util.h"

static int same(const pgi_reference_meta *a, const pgi_reference_meta *b) {
    return strcmp(a->scene, b->scene) == 0 && a->width == b->width && a->height == b->height &&
           a->bounces == b->bounces && a->camera == b->camera && a->seed == b->seed && a->spp == b->spp &&
           a->jitter == b->jitter && a->specular == b->specular;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[512], again[512];
    fuzz_write("r.exr.json", data, size, path, sizeof path);
    pgi_reference_meta m, m2;
    if (pgi_reference_meta_read(path, &m) != PGI_OK) {
        if (!pgi_last_error()[0]) {
            fprintf(stderr, "pgi_reference_meta_read failed without a message\n");
            abort();
        }
        return 0;
    }
    if (!memchr(m.scene, 0, sizeof m.scene)) {
        fprintf(stderr, "pgi_reference_meta_read: the scene is not a string\n");
        abort();
    }
    snprintf(again, sizeof again, "%s/w.exr.json", g_fuzz_dir);
    if (pgi_reference_meta_write(&m, again) != PGI_OK) return 0; /* e.g. a name the writer refuses */
    if (pgi_reference_meta_read(again, &m2) != PGI_OK || !same(&m, &m2)) {
        fprintf(stderr, "a sidecar does not read back as written: %s\n", pgi_last_error());
        abort();
    }
    return 0;
}
