/* libFuzzer target: a glTF with an external buffer through pgi_scene_load, as `photongi render
 * --scene m.gltf` reads it. The input is the glTF's JSON; a line "#BIN" splits it: the bytes after
 * that line are b.bin beside it, the file a buffer's "uri": "b.bin" names (the seeds do). So the
 * fuzzer reaches the accessors, buffer views and sparse accessors over real buffer bytes, which
 * the mesh target's self-contained glTF (data: URIs) reaches only through base64. */
#include <photongi/photongi.h>

#include "fuzz_util.h"

/* Offset of the first line that starts with "#BIN", or n. */
static size_t find_bin_line(const uint8_t *d, size_t n) {
    for (size_t i = 0; i + 4 <= n; i++)
        if ((i == 0 || d[i - 1] == '\n') && memcmp(d + i, "#BIN", 4) == 0) return i;
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[512], bin[512];
    const size_t split = find_bin_line(data, size);
    if (split < size) {
        const uint8_t *eol = memchr(data + split, '\n', size - split);
        const size_t from = eol ? (size_t)(eol - data) + 1 : size;
        fuzz_write("b.bin", data + from, size - from, bin, sizeof bin);
    } else {
        fuzz_unlink("b.bin");
    }
    fuzz_write("m.gltf", data, split, path, sizeof path);
    fuzz_load_scene(path);
    return 0;
}
