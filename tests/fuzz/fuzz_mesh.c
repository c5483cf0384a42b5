/* libFuzzer target: a mesh file through pgi_scene_load (mesh_check.c's checks, Assimp, the
 * scene's validation), as `photongi render --scene m.obj` reads it. The input picks its format
 * by its first bytes, as a file of that type would start:
 *   "ply"             -> m.ply
 *   "glTF"            -> m.glb (binary glTF)
 *   '{' (after space) -> m.gltf
 *   anything else     -> m.obj; a line starting with "#MTL" splits it: the lines after it are
 *                        m.mtl, beside it (the convention of ../shared/bad-inputs/\*.bin).
 * Everything is written to a private temporary folder, so relative texture and buffer
 * names resolve there (and find nothing). */
#include <photongi/photongi.h>

#include "fuzz_util.h"

/* Offset of the first line that starts with "#MTL", or n. */
static size_t find_mtl_line(const uint8_t *d, size_t n) {
    for (size_t i = 0; i + 4 <= n; i++) {
        if ((i == 0 || d[i - 1] == '\n') && memcmp(d + i, "#MTL", 4) == 0) return i;
    }
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[512], mtl[512];
    size_t k = 0;
    while (k < size && (data[k] == ' ' || data[k] == '\t' || data[k] == '\r' || data[k] == '\n')) k++;
    if (size >= 3 && memcmp(data, "ply", 3) == 0) {
        fuzz_write("m.ply", data, size, path, sizeof path);
    } else if (size >= 4 && memcmp(data, "glTF", 4) == 0) {
        fuzz_write("m.glb", data, size, path, sizeof path);
    } else if (k < size && data[k] == '{') {
        fuzz_write("m.gltf", data, size, path, sizeof path);
    } else {
        size_t split = find_mtl_line(data, size);
        if (split < size) {
            const uint8_t *eol = memchr(data + split, '\n', size - split);
            size_t from = eol ? (size_t)(eol - data) + 1 : size;
            fuzz_write("m.mtl", data + from, size - from, mtl, sizeof mtl);
        } else {
            fuzz_unlink("m.mtl");
        }
        fuzz_write("m.obj", data, split, path, sizeof path);
    }
    fuzz_load_scene(path);
    return 0;
}
