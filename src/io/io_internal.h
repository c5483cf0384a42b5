/* Internal I/O helpers shared by the compare tool, the CLI, the benchmark and tests. */
#ifndef PGI__IO_INTERNAL_H
#define PGI__IO_INTERNAL_H

#include "photongi/photongi.h"

#include <stdio.h>

/* Reads an image into linear RGB floats (`out` receives a new image; free with
 * pgi_image_free). The format comes from the file's content, not its name:
 * OpenEXR (scanline, R,G,B channels of any pixel type) and Radiance HDR give
 * linear values as stored (*is_hdr = 1); PNG and other 8/16-bit formats stb
 * reads are decoded from sRGB to linear (*is_hdr = 0), so that tone mapping an
 * 8-bit PNG with exposure 1 gives back its bytes exactly. `is_hdr` may be NULL.
 * Missing/unopenable file: PGI_ERR_IO; unreadable content: PGI_ERR_PARSE. */
pgi_status pgi__image_read(const char *path, pgi_image *out, int *is_hdr);

/* Guards stb_image's decoders: its Radiance HDR decoder hangs on some corrupt run-length data (a
 * run of length 0, or a truncated file), and its PNG decoder grows its buffer to a chunk's
 * declared length before reading it (2 GiB for a 227-byte file). PGI_ERR_PARSE naming `what` if
 * the file `f` (read from its position, which is restored) or the buffer `data` of `size` bytes
 * holds such data or a PNG chunk longer than what is left, else PGI_OK (also for anything that is
 * neither). Call it before any stbi_load* of a file or buffer. */
pgi_status pgi__hdr_check(const char *what, FILE *f, const void *data, size_t size);

/* The frame statistics as a JSON document (the format pgi_stats_write_json
 * writes). Returns a malloc'd string the caller frees, or NULL when out of memory. */
char *pgi__stats_to_json(const pgi_frame_stats *st);

/* Atomic output (image_io.c): pgi__out_begin decides where a write of `path` goes (a temporary
 * file beside the file it replaces, the file a symlink names; a path that is not a regular file,
 * such as /dev/null, directly), pgi__out_path is the name to write, pgi__out_commit flushes it to
 * the disk and renames it over the target, pgi__out_abort removes it. Whatever fails, the previous
 * file is kept. Messages name `path`. */
typedef struct pgi__out {
    char final[4096], tmp[4096];
    int direct;
    unsigned mode;
} pgi__out;
pgi_status pgi__out_begin(const char *path, pgi__out *o);
const char *pgi__out_path(const pgi__out *o, const char *path);
pgi_status pgi__out_commit(pgi__out *o, const char *path); /* pgi__out_sync, then pgi__out_rename */
pgi_status pgi__out_sync(pgi__out *o, const char *path);   /* fsync and the mode; abort on failure */
pgi_status pgi__out_rename(pgi__out *o, const char *path); /* over the target; abort on failure */
/* pgi_image_write's encoders: `img` (valid) to the file wpath, messages naming path (whose extension,
 * .png or .exr, chooses the format). */
pgi_status pgi__image_write_to(const pgi_image *img, const char *path, const char *wpath, float exposure);
void pgi__out_abort(pgi__out *o);

#endif
