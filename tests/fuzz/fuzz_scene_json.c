/* libFuzzer target: a scene description (.json) through pgi_scene_load, as
 * `photongi render --scene x.json` reads it. Mesh paths resolve against the
 * description's folder (a fresh temporary one) and then $PHOTONGI_SCENES: run.sh points
 * that at a folder of small meshes, so that a description may load a real one. */
#include <photongi/photongi.h>

#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[512];
    fuzz_write("scene.json", data, size, path, sizeof path);
    fuzz_load_scene(path);
    return 0;
}
