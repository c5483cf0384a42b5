/* libFuzzer target: an image file through pgi_image_read (EXR through OpenEXRCore; PNG,
 * PGM/PPM, TGA, HDR, BMP, JPEG ... through stb), as `photongi compare a b` reads it. The
 * reader sniffs the content, so the file name does not matter. A decoded image must have
 * the size it claims (every pixel is read, so ASan sees a short buffer). */
#include <photongi/metrics.h>
#include <photongi/photongi.h>

#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[512];
    fuzz_write("image", data, size, path, sizeof path);
    pgi_image img = {0};
    int is_hdr = -1;
    pgi_status st = pgi_image_read(path, &img, &is_hdr);
    if (st == PGI_OK) {
        if (!img.rgb || img.width < 1 || img.height < 1 || (is_hdr != 0 && is_hdr != 1)) {
            fprintf(stderr, "pgi_image_read: OK but %dx%d, rgb %p, is_hdr %d\n", img.width, img.height, (void *)img.rgb,
                    is_hdr);
            abort();
        }
        volatile float sum = 0.f;
        for (size_t i = 0, n = (size_t)img.width * (size_t)img.height * 3; i < n; i++) sum += img.rgb[i];
        (void)sum;
        pgi_image_free(&img);
    } else if (img.rgb || !pgi_last_error()[0]) {
        fprintf(stderr, "pgi_image_read failed (%d) %s\n", (int)st, img.rgb ? "but left pixels" : "without a message");
        abort();
    }
    return 0;
}
