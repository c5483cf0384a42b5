/* libFuzzer target: a scene description (.json) through pgi_scene_load, as
 * `photongi render --scene x.json` reads it. Mesh paths resolve against the
 * description's folder (a fresh temporary one) and then $PHOTONGI_SCENES: run.sh points
 * that at a folder of small meshes, so that a description may load a real one. */
#include <photongi/photongi.h>

#include "fuzz_util.h"

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    fuzz_dir_init();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[512];
    fuzz_write("scene.json", data, size, path, sizeof path);
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
    return 0;
}
