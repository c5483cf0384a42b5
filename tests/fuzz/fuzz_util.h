/* Shared by the libFuzzer targets (docs/testing.md, "Fuzzing"): a private temporary folder per
 * process, removed at exit, and whole-file writes into it. The loaders take paths, so each
 * input becomes a file there, named as the loader's own path would be. */
#ifndef PGI__FUZZ_UTIL_H
#define PGI__FUZZ_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <photongi/photongi.h>

static char g_fuzz_dir[256];

static inline void fuzz_dir_remove(void) {
    static const char *const names[] = {"scene.json", "m.obj",      "m.mtl",      "m.ply", "m.gltf", "m.glb",
                                        "b.bin",      "r.exr.json", "w.exr.json", "image", NULL};
    char p[512];
    for (int i = 0; names[i]; i++) {
        snprintf(p, sizeof p, "%s/%s", g_fuzz_dir, names[i]);
        unlink(p);
    }
    rmdir(g_fuzz_dir);
}

/* Creates the folder once (call from LLVMFuzzerInitialize). */
static inline void fuzz_dir_init(void) {
    const char *tmp = getenv("TMPDIR");
    snprintf(g_fuzz_dir, sizeof g_fuzz_dir, "%s/pgi-fuzz-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(g_fuzz_dir)) {
        perror("pgi fuzz: mkdtemp");
        abort();
    }
    atexit(fuzz_dir_remove);
}

/* Writes `n` bytes to <dir>/<name> and returns the full path (static buffer `path`). */
static inline void fuzz_write(const char *name, const uint8_t *data, size_t n, char *path, size_t cap) {
    snprintf(path, cap, "%s/%s", g_fuzz_dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || (n && fwrite(data, 1, n, f) != n) || fclose(f) != 0) {
        perror("pgi fuzz: write");
        abort();
    }
}

/* Every target's libFuzzer initialisation: the folder. */
int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    fuzz_dir_init();
    /* Run by hand without run.sh: a description's meshes are looked up in the empty temporary
     * folder only, never in ../shared/scenes, where naming Sponza would spend seconds importing. */
    if (!getenv("PHOTONGI_SCENES")) setenv("PHOTONGI_SCENES", g_fuzz_dir, 1);
    return 0;
}

/* Loads a scene from `path` as `photongi render --scene` would; a failure must come with a
 * message and no scene (else abort: a finding). */
static inline void fuzz_load_scene(const char *path) {
    pgi_scene *s = NULL;
    pgi_status st = pgi_scene_load(path, &s);
    if (st == PGI_OK) {
        pgi_scene_info info;
        pgi_scene_get_info(s, &info);
        pgi_scene_destroy(s);
    } else if (s || !pgi_last_error()[0]) {
        fprintf(stderr, "pgi_scene_load failed (%d) %s\n", (int)st, s ? "but returned a scene" : "without a message");
        abort();
    }
}

/* Removes <dir>/<name> (a file another input may have left). */
static inline void fuzz_unlink(const char *name) {
    char p[512];
    snprintf(p, sizeof p, "%s/%s", g_fuzz_dir, name);
    unlink(p);
}

#endif
