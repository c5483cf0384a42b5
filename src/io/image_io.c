/* Image output (PNG via stb, EXR via OpenEXRCore) and the internal reader.
 *
 * PNG is display-referred: tone mapped by pgi_tonemap_srgb8 (src/filter/tonemap.c:
 * exposure, clamp to [0,1], the exact sRGB OETF, and rounding to nearest).
 * The reader inverts that exactly (byte -> sRGB EOTF, pgi__srgb_to_linear in double),
 * so reading a PNG and tone mapping it at exposure 1 returns the same bytes.
 * EXR is scene-referred: 32-bit float R,G,B, scanline, ZIP (16 lines a chunk). */
#define _DEFAULT_SOURCE /* realpath, mkstemp, fsync */
#include "core/core.h"
#include "io/io_internal.h"

#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openexr.h>
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

void pgi_image_free(pgi_image *img) {
    if (!img) return;
    free(img->rgb);
    img->rgb = NULL;
    img->width = img->height = 0;
}

/* ----------------------------------------------------------------- helpers */

static int has_ext(const char *path, const char *ext) {
    size_t n = strlen(path), m = strlen(ext);
    if (n < m) return 0;
    const char *p = path + n - m;
    for (size_t i = 0; i < m; ++i)
        if (tolower((unsigned char)p[i]) != ext[i]) return 0;
    return 1;
}

static int image_valid(const pgi_image *img) { return img && img->rgb && img->width > 0 && img->height > 0; }

/* ------------------------------------------------------- atomic outputs */

/* The temporary files of `base`: ".BASE.pgi-tmp-HOST-" (BASE and HOST cut short), then the
 * writer's process id and mkstemp's six characters. */
static void tmp_prefix(const char *base, char *out, size_t size) {
    char host[64];
    if (gethostname(host, sizeof host) != 0) snprintf(host, sizeof host, "host");
    host[sizeof host - 1] = 0;
    for (char *c = host; *c; c++)
        if (*c == '/' || *c == '.') *c = '_';
    snprintf(out, size, ".%.120s.pgi-tmp-%.40s-", base, host);
}

/* Removes the temporary files of this output that a process of this machine left when it was
 * killed before renaming them (SIGKILL, a power cut): those whose writer's process id is no
 * longer running. A live writer's (another photongi writing the same file) are kept. */
static void remove_stale_tmps(const char *final, int dn, const char *prefix) {
    char dir[4096];
    snprintf(dir, sizeof dir, "%.*s", dn ? dn : 1, dn ? final : ".");
    DIR *d = opendir(dir);
    if (!d) return;
    const size_t pn = strlen(prefix);
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strncmp(e->d_name, prefix, pn) != 0) continue;
        char *end;
        errno = 0;
        long pid = strtol(e->d_name + pn, &end, 10);
        if (errno || pid <= 0 || *end != '.' || strlen(end) != 7) continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue;
        char name[4096 + 256];
        snprintf(name, sizeof name, "%s/%s", dir, e->d_name);
        struct stat sb;
        if (lstat(name, &sb) == 0 && S_ISREG(sb.st_mode)) unlink(name);
    }
    closedir(d);
}

/* An output is written to a temporary file in the folder of the file it replaces and renamed over
 * it once complete and flushed to the disk (fsync): a write that fails (disk full, a size limit) or a
 * process killed on the way leaves the previous file as it was, never a truncated one. A symlink is
 * followed (the file it names is replaced, the link stays); a path that names something other than a
 * regular file (/dev/null, a FIFO) is written directly and never removed. */
pgi_status pgi__out_begin(const char *path, pgi__out *o) {
    memset(o, 0, sizeof *o);
    o->direct = 0;
    o->tmp[0] = 0;
    struct stat sb;
    if (lstat(path, &sb) == 0 && S_ISLNK(sb.st_mode)) {
        char *real = realpath(path, NULL), link[4096];
        ssize_t ln = real ? 0 : readlink(path, link, sizeof link - 1);
        const char *slash = strrchr(path, '/');
        if (real) snprintf(o->final, sizeof o->final, "%s", real);
        else if (ln > 0) { /* a dangling link: the file it names is created */ link[ln] = 0;
            if (link[0] == '/' || !slash) snprintf(o->final, sizeof o->final, "%s", link);
            else if (snprintf(o->final, sizeof o->final, "%.*s/%.*s", (int)(slash - path), path, 2048, link) < 0)
                o->final[0] = 0;
        } else snprintf(o->final, sizeof o->final, "%s", path);
        free(real);
    } else snprintf(o->final, sizeof o->final, "%s", path);
    mode_t um = umask(0);
    umask(um);
    o->mode = 0666 & ~um;
    if (stat(o->final, &sb) == 0) {
        if (!S_ISREG(sb.st_mode)) {
            o->direct = 1;
            return PGI_OK;
        }
        o->mode = sb.st_mode & 07777;
        if (access(o->final, W_OK) != 0) { /* replacing it must not get round its permissions */
            int e = errno;
            return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, strerror(e));
        }
    }
    const char *slash = strrchr(o->final, '/');
    int dn = slash ? (int)(slash - o->final) + 1 : 0;
    char prefix[256];
    tmp_prefix(o->final + dn, prefix, sizeof prefix);
    remove_stale_tmps(o->final, dn, prefix);
    if (snprintf(o->tmp, sizeof o->tmp, "%.*s%s%ld.XXXXXX", dn, o->final, prefix, (long)getpid()) >= (int)sizeof o->tmp)
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: the name is too long", path);
    int fd = mkstemp(o->tmp);
    if (fd < 0) {
        int e = errno;
        o->tmp[0] = 0;
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: cannot create a file in its folder: %s", path, strerror(e));
    }
    close(fd);
    return PGI_OK;
}

const char *pgi__out_path(const pgi__out *o, const char *path) { return o->direct ? path : o->tmp; }

void pgi__out_abort(pgi__out *o) {
    if (!o->direct && o->tmp[0]) unlink(o->tmp);
    o->tmp[0] = 0;
}

pgi_status pgi__out_sync(pgi__out *o, const char *path) {
    if (o->direct) return PGI_OK;
    int fd = open(o->tmp, O_RDONLY);
    int e = 0;
    if (fd < 0 || fsync(fd) != 0) e = errno ? errno : EIO;
    if (fd >= 0) close(fd);
    if (!e && chmod(o->tmp, o->mode) != 0) e = errno;
    if (e) {
        pgi__out_abort(o);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s (the previous file, if any, is kept)", path, strerror(e));
    }
    return PGI_OK;
}

pgi_status pgi__out_rename(pgi__out *o, const char *path) {
    if (o->direct) return PGI_OK;
    if (rename(o->tmp, o->final) != 0) {
        int e = errno;
        pgi__out_abort(o);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s (the previous file, if any, is kept)", path, strerror(e));
    }
    o->tmp[0] = 0;
    return PGI_OK;
}

pgi_status pgi__out_commit(pgi__out *o, const char *path) {
    pgi_status s = pgi__out_sync(o, path);
    return s ? s : pgi__out_rename(o, path);
}

/* --------------------------------------------------------------- PNG write */

typedef struct png_sink {
    FILE *f;
    int err; /* errno of the first failed write, or -1 */
} png_sink;

static void png_write_cb(void *ctx, void *data, int size) {
    png_sink *s = ctx;
    if (s->err || size <= 0) return;
    if (fwrite(data, 1, (size_t)size, s->f) != (size_t)size) s->err = errno ? errno : -1;
}

static pgi_status write_png(const pgi_image *img, const char *path, const char *wpath, float exposure) {
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    if ((size_t)img->width * 3 > (size_t)0x7fffffff)
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: image too wide for PNG", path);
    unsigned char *px = malloc(n);
    if (!px) return pgi__fail(PGI_ERR_OOM, "%s: out of memory tone mapping %dx%d", path, img->width, img->height);
    pgi_tonemap_srgb8(img, exposure, px);

    errno = 0;
    FILE *f = fopen(wpath, "wb");
    if (!f) {
        int e = errno;
        free(px);
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, strerror(e));
    }
    /* Our own FILE and callback (not stbi_write_png) so that a failed write
     * (disk full) is noticed and reported with its reason. */
    png_sink sink = {f, 0};
    errno = 0;
    int ok = stbi_write_png_to_func(png_write_cb, &sink, img->width, img->height, 3, px, img->width * 3);
    free(px);
    int close_err = fflush(f) != 0 ? (errno ? errno : -1) : 0;
    if (fclose(f) != 0 && !close_err) close_err = errno ? errno : -1;
    if (!ok || sink.err || close_err) {
        if (!ok) return pgi__fail(PGI_ERR_IO, "%s: cannot write: PNG encoding failed", path);
        int e = sink.err ? sink.err : close_err;
        return pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, e > 0 ? strerror(e) : "write error");
    }
    return PGI_OK;
}

/* --------------------------------------------------------------------- EXR */

/* OpenEXRCore reports details through a callback (default: print to stderr).
 * Keep the last message of this thread for our own error text instead. */
static _Thread_local char g_exr_msg[512];

static void exr_error_cb(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
    (void)ctxt;
    snprintf(g_exr_msg, sizeof g_exr_msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

static const char *exr_reason(exr_result_t rv) { return g_exr_msg[0] ? g_exr_msg : exr_get_default_error_message(rv); }

static int rgb_offset(const char *name) {
    if (!name) return -1;
    if (strcmp(name, "R") == 0) return 0;
    if (strcmp(name, "G") == 0) return 1;
    if (strcmp(name, "B") == 0) return 2;
    return -1;
}

/* OpenEXRCore (3.1.5 here, Debian 12's, and later releases until the 2026 fix) stores a ZIP chunk's zlib stream when it is
 * exactly as long as the packed pixels ("compbufsz > packed_bytes" where ">=" was meant,
 * AcademySoftwareFoundation/openexr#2306, fixed by #2307), and every reader takes a chunk of the
 * packed size for uncompressed pixels: the chunk reads back as garbage (NaN, 1e38), silently.
 * Noisy float pixels (a path-traced reference) hit this about once in some hundreds of chunks. The
 * library's compressor runs as it is and, where its output is not shorter than the packed pixels,
 * the packed pixels are stored instead, as the file format says and the fixed library does: other
 * chunks keep their bytes. `encoding_user_data` holds the library's compressor. */
typedef struct exr_compress_hook {
    exr_result_t (*compress)(exr_encode_pipeline_t *enc);
} exr_compress_hook;

static exr_result_t exr_compress_not_longer(exr_encode_pipeline_t *enc) {
    const exr_compress_hook *hook = enc->encoding_user_data;
    exr_result_t rv = hook->compress(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes >= enc->packed_bytes && enc->compressed_buffer &&
        enc->compressed_buffer != enc->packed_buffer && enc->compressed_alloc_size >= enc->packed_bytes) {
        memcpy(enc->compressed_buffer, enc->packed_buffer, (size_t)enc->packed_bytes);
        enc->compressed_bytes = (size_t)enc->packed_bytes;
    }
    return rv;
}

static pgi_status write_exr(const pgi_image *img, const char *path, const char *wpath) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    exr_context_t ctxt = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int enc_init = 0, part = 0, spc = 1;
    exr_compress_hook hook = {NULL};
    const int w = img->width, h = img->height;
    g_exr_msg[0] = 0;

    exr_result_t rv = exr_start_write(&ctxt, wpath, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) {
        pgi_status s = pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, exr_reason(rv));
        if (ctxt) exr_finish(&ctxt);
        return s;
    }
    rv = exr_add_part(ctxt, "", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS) rv = exr_initialize_required_attr_simple(ctxt, part, w, h, EXR_COMPRESSION_ZIP);
    /* Added in any order; the library keeps the list sorted (B, G, R). */
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_channel(ctxt, part, "R", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_channel(ctxt, part, "G", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_channel(ctxt, part, "B", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS) rv = exr_write_header(ctxt);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_scanlines_per_chunk(ctxt, part, &spc);
    if (rv == EXR_ERR_SUCCESS && spc < 1) rv = EXR_ERR_INVALID_ARGUMENT;

    for (int y = 0; rv == EXR_ERR_SUCCESS && y < h; y += spc) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctxt, part, y, &cinfo);
        if (rv != EXR_ERR_SUCCESS) break;
        if (!enc_init) {
            rv = exr_encoding_initialize(ctxt, part, &cinfo, &enc);
            if (rv != EXR_ERR_SUCCESS) break;
            enc_init = 1;
        } else {
            rv = exr_encoding_update(ctxt, part, &cinfo, &enc);
            if (rv != EXR_ERR_SUCCESS) break;
        }
        for (int c = 0; c < enc.channel_count; ++c) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            int off = rgb_offset(ch->channel_name);
            PGI__ASSERT(off >= 0);
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = w * 3 * (int32_t)sizeof(float);
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->encode_from_ptr = (const uint8_t *)(img->rgb + ((size_t)cinfo.start_y * (size_t)w) * 3 + (size_t)off);
        }
        rv = exr_encoding_choose_default_routines(ctxt, part, &enc);
        if (rv == EXR_ERR_SUCCESS && enc.compress_fn) {
            hook.compress = enc.compress_fn;
            enc.encoding_user_data = &hook;
            enc.compress_fn = exr_compress_not_longer;
        }
        if (rv == EXR_ERR_SUCCESS) rv = exr_encoding_run(ctxt, part, &enc);
    }

    pgi_status s = PGI_OK;
    if (rv != EXR_ERR_SUCCESS) s = pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, exr_reason(rv));
    if (enc_init) exr_encoding_destroy(ctxt, &enc);
    exr_result_t frv = exr_finish(&ctxt);
    if (s == PGI_OK && frv != EXR_ERR_SUCCESS) s = pgi__fail(PGI_ERR_IO, "%s: cannot write: %s", path, exr_reason(frv));
    return s;
}

static pgi_status read_exr(const char *path, pgi_image *out) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_context_t ctxt = NULL;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int dec_init = 0, spc = 1, nparts = 0;
    float *rgb = NULL;
    pgi_status s = PGI_OK;
    g_exr_msg[0] = 0;

    exr_result_t rv = exr_start_read(&ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        s = pgi__fail(PGI_ERR_PARSE, "%s: not a readable EXR file: %s", path, exr_reason(rv));
        goto done;
    }
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    if (exr_get_count(ctxt, &nparts) != EXR_ERR_SUCCESS || nparts < 1 ||
        exr_get_storage(ctxt, 0, &storage) != EXR_ERR_SUCCESS || exr_get_data_window(ctxt, 0, &dw) != EXR_ERR_SUCCESS ||
        exr_get_channels(ctxt, 0, &chl) != EXR_ERR_SUCCESS || !chl) {
        s = pgi__fail(PGI_ERR_PARSE, "%s: malformed EXR header", path);
        goto done;
    }
    if (storage != EXR_STORAGE_SCANLINE) {
        s = pgi__fail(PGI_ERR_PARSE, "%s: only scanline EXR images are supported (this one is %s)", path,
                      storage == EXR_STORAGE_TILED ? "tiled" : "deep");
        goto done;
    }
    int found = 0;
    for (int i = 0; i < chl->num_channels; ++i) {
        int off = rgb_offset(chl->entries[i].name.str);
        if (off < 0) continue;
        if (chl->entries[i].x_sampling != 1 || chl->entries[i].y_sampling != 1) {
            s = pgi__fail(PGI_ERR_PARSE, "%s: subsampled EXR channels are not supported", path);
            goto done;
        }
        found |= 1 << off;
    }
    if (found != 7) {
        s = pgi__fail(PGI_ERR_PARSE, "%s: EXR image lacks one of the R, G, B channels", path);
        goto done;
    }
    int64_t w64 = (int64_t)dw.max.x - dw.min.x + 1, h64 = (int64_t)dw.max.y - dw.min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > INT32_MAX / 16 || h64 > INT32_MAX / 16) {
        s = pgi__fail(PGI_ERR_PARSE, "%s: bad EXR data window", path);
        goto done;
    }
    if ((s = pgi__check_image_size(path, w64, h64))) goto done;
    const int w = (int)w64, h = (int)h64;
    rgb = calloc((size_t)w * (size_t)h * 3, sizeof(float));
    if (!rgb) {
        s = pgi__fail(PGI_ERR_OOM, "%s: out of memory for a %dx%d image", path, w, h);
        goto done;
    }
    rv = exr_get_scanlines_per_chunk(ctxt, 0, &spc);
    if (rv == EXR_ERR_SUCCESS && spc < 1) rv = EXR_ERR_BAD_CHUNK_LEADER;
    for (int64_t y = dw.min.y; rv == EXR_ERR_SUCCESS && y <= dw.max.y; y += spc) {
        exr_chunk_info_t cinfo;
        rv = exr_read_scanline_chunk_info(ctxt, 0, (int)y, &cinfo);
        if (rv != EXR_ERR_SUCCESS) break;
        if (!dec_init) {
            rv = exr_decoding_initialize(ctxt, 0, &cinfo, &dec);
            if (rv != EXR_ERR_SUCCESS) break;
            dec_init = 1;
        } else {
            rv = exr_decoding_update(ctxt, 0, &cinfo, &dec);
            if (rv != EXR_ERR_SUCCESS) break;
        }
        /* A chunk may start above the data window (chunks are aligned to
         * the window's first line, but be defensive). */
        int64_t row = (int64_t)cinfo.start_y - dw.min.y;
        if (row < 0 || row + cinfo.height > h) {
            rv = EXR_ERR_BAD_CHUNK_LEADER;
            break;
        }
        for (int c = 0; c < dec.channel_count; ++c) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int off = rgb_offset(ch->channel_name);
            if (off < 0) {
                ch->decode_to_ptr = NULL; /* skipped (alpha, depth, ...) */
                continue;
            }
            ch->user_pixel_stride = 3 * (int32_t)sizeof(float);
            ch->user_line_stride = w * 3 * (int32_t)sizeof(float);
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->decode_to_ptr = (uint8_t *)(rgb + ((size_t)row * (size_t)w) * 3 + (size_t)off);
        }
        rv = exr_decoding_choose_default_routines(ctxt, 0, &dec);
        if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(ctxt, 0, &dec);
    }
    if (rv != EXR_ERR_SUCCESS) {
        s = pgi__fail(PGI_ERR_PARSE, "%s: cannot decode EXR pixels: %s", path, exr_reason(rv));
        goto done;
    }
    out->width = w;
    out->height = h;
    out->rgb = rgb;
    rgb = NULL;

done:
    if (dec_init) exr_decoding_destroy(ctxt, &dec);
    if (ctxt) exr_finish(&ctxt);
    free(rgb);
    return s;
}

/* ------------------------------------------------------------------ public */

pgi_status pgi_image_write(const pgi_image *img, const char *path, float exposure) {
    if (!path || !path[0]) return pgi__fail(PGI_ERR_INVALID_ARG, "image write: no output path");
    if (!image_valid(img)) return pgi__fail(PGI_ERR_INVALID_ARG, "%s: no image to write (empty or no pixels)", path);
    if (!has_ext(path, ".png") && !has_ext(path, ".exr"))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: unknown image format (use .png or .exr)", path);
    pgi__out o;
    pgi_status s = pgi__out_begin(path, &o);
    if (s) return s;
    s = pgi__image_write_to(img, path, pgi__out_path(&o, path), exposure);
    if (s) pgi__out_abort(&o);
    else s = pgi__out_commit(&o, path);
    return s;
}

pgi_status pgi__image_write_to(const pgi_image *img, const char *path, const char *wpath, float exposure) {
    const int png = has_ext(path, ".png");
    if (!png && !has_ext(path, ".exr"))
        return pgi__fail(PGI_ERR_INVALID_ARG, "%s: unknown image format (use .png or .exr)", path);
    return png ? write_png(img, path, wpath, exposure) : write_exr(img, path, wpath);
}

/* --------------------------------------------------------------------- read */

/* Radiance HDR run-length data: stb_image 2.27 (Debian 12's) loops forever on a literal run of
 * length 0, which is also what it reads past the end of a truncated file. Walks the scanlines
 * as stb will (same header parsing, same fall-back to flat pixels) and reports such a run
 * before stb sees it. Not an HDR file, or not run-length encoded: fine (stb decides). */
typedef struct byte_src {
    FILE *f;
    const unsigned char *p, *end;
} byte_src;

static int src_get(byte_src *s) { /* stb's stbi__get8: 0 past the end */
    if (s->f) {
        int c = getc(s->f);
        return c == EOF ? 0 : c;
    }
    return s->p < s->end ? *s->p++ : 0;
}

/* One header line (stbi__hdr_gettoken: up to '\n', the first 1023 bytes kept); -1 at the end. */
static int src_line(byte_src *s, char *buf, size_t cap) {
    size_t n = 0;
    int any = 0;
    for (;;) {
        int c;
        if (s->f) c = getc(s->f);
        else c = s->p < s->end ? *s->p++ : EOF;
        if (c == EOF) {
            if (!any) return -1;
            break;
        }
        any = 1;
        if (c == '\n') break;
        if (n + 1 < cap) buf[n++] = (char)c;
    }
    buf[n] = 0;
    return (int)n;
}

/* Returns the 1-based scanline with a zero-length run, or 0. */
static long hdr_zero_run(byte_src *s) {
    char line[1024];
    if (src_line(s, line, sizeof line) < 0 || (strcmp(line, "#?RADIANCE") != 0 && strcmp(line, "#?RGBE") != 0))
        return 0;
    for (;;) { /* header lines up to an empty one */
        int n = src_line(s, line, sizeof line);
        if (n < 0) return 0;
        if (line[0] == 0) break; /* stb compares C strings: a line that starts with a NUL is empty too */
    }
    if (src_line(s, line, sizeof line) < 0 || strncmp(line, "-Y ", 3) != 0) return 0;
    char *p = line + 3;
    long h = strtol(p, &p, 10);
    while (*p == ' ') ++p;
    if (strncmp(p, "+X ", 3) != 0) return 0;
    long w = strtol(p + 3, NULL, 10);
    if (w < 8 || w >= 32768 || h < 1 || h > (1 << 24)) return 0; /* flat pixels, or refused by stb */
    for (long j = 0; j < h; j++) {
        int c1 = src_get(s), c2 = src_get(s), len = src_get(s);
        if (c1 != 2 || c2 != 2 || (len & 0x80)) return 0; /* stb reads flat pixels from here on */
        len = (len << 8) | src_get(s);
        if (len != w) return 0; /* stb: "invalid decoded scanline length" */
        for (int k = 0; k < 4; k++) {
            for (long i = 0; i < w;) {
                int count = src_get(s);
                if (count > 128) {
                    src_get(s);
                    count -= 128;
                } else if (count == 0) {
                    return j + 1;
                } else {
                    for (int z = 0; z < count; z++) src_get(s);
                }
                if (count > w - i) return 0; /* stb: "bad RLE data in HDR" */
                i += count;
            }
        }
    }
    return 0;
}

/* PNG chunks: stb_image grows its buffer to a chunk's declared length before it reads the chunk
 * (a 227-byte file asked for 2 GiB). Returns the offset of the first chunk that declares more
 * bytes than are left (its length, type and CRC included), or 0 (fine, or not a PNG). */
static uint64_t png_chunk_past_end(byte_src *s, uint64_t size, uint32_t *declared, char type[5]) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    for (int i = 0; i < 8; i++)
        if (src_get(s) != sig[i]) return 0;
    uint64_t at = 8;
    while (at + 12 <= size) {
        uint32_t len = 0;
        for (int i = 0; i < 4; i++) len = len << 8 | (uint32_t)src_get(s);
        for (int i = 0; i < 4; i++) type[i] = (char)src_get(s);
        type[4] = 0;
        if ((uint64_t)len > size - at - 12) {
            *declared = len;
            return at;
        }
        if (memcmp(type, "IEND", 4) == 0) return 0;
        at += 12 + (uint64_t)len;
        if (s->f) {
            if (fseek(s->f, (long)(len + 4), SEEK_CUR) != 0) return 0;
        } else {
            s->p += len + 4;
        }
    }
    return 0;
}

pgi_status pgi__hdr_check(const char *what, FILE *f, const void *data, size_t size) {
    byte_src src = {f, data, data ? (const unsigned char *)data + size : NULL};
    long pos = f ? ftell(f) : 0;
    long line = hdr_zero_run(&src);
    uint64_t total = size;
    if (f) {
        struct stat sb;
        total = fstat(fileno(f), &sb) == 0 && pos >= 0 ? (uint64_t)sb.st_size - (uint64_t)pos : 0;
    }
    if (!line) { /* again from the start, as a PNG */
        if (f) clearerr(f);
        if (f && (pos < 0 || fseek(f, pos, SEEK_SET) != 0)) return pgi__fail(PGI_ERR_IO, "%s: cannot seek", what);
        src.p = data;
    }
    uint32_t declared = 0;
    char type[5] = "";
    const uint64_t chunk = line ? 0 : png_chunk_past_end(&src, total, &declared, type);
    if (f) {
        clearerr(f);
        if (pos < 0 || fseek(f, pos, SEEK_SET) != 0) return pgi__fail(PGI_ERR_IO, "%s: cannot seek", what);
    }
    if (line)
        return pgi__fail(PGI_ERR_PARSE,
                         "%s: corrupt Radiance HDR data: scanline %ld has a run of length 0 (or ends early)", what,
                         line);
    if (chunk) {
        pgi__sanitize(type);
        return pgi__fail(PGI_ERR_PARSE, "%s: corrupt PNG: chunk '%s' at byte %llu declares %u bytes, %llu are left",
                         what, type, (unsigned long long)chunk, declared,
                         (unsigned long long)(total - chunk - 12 < total ? total - chunk - 12 : 0));
    }
    return PGI_OK;
}

static pgi_status read_stb(const char *path, FILE *f, int png, pgi_image *out, int *is_hdr) {
    int w = 0, h = 0, comp = 0;
    float *rgb = NULL;
    /* The header's size first: a few bytes can declare gigabytes of pixels. */
    if (!stbi_info_from_file(f, &w, &h, &comp))
        return pgi__fail(PGI_ERR_PARSE, "%s: unreadable image: %s", path, stbi_failure_reason());
    pgi_status st = pgi__check_image_size(path, w, h);
    if (st) return st;
    if ((st = pgi__hdr_check(path, f, NULL, 0))) return st;
    if (stbi_is_hdr_from_file(f)) {
        float *px = stbi_loadf_from_file(f, &w, &h, &comp, 3);
        if (!px) return pgi__fail(PGI_ERR_PARSE, "%s: unreadable image: %s", path, stbi_failure_reason());
        /* stb scales its own HDR loads by 1 (no gamma): values as stored. */
        rgb = malloc((size_t)w * (size_t)h * 3 * sizeof(float));
        if (rgb) memcpy(rgb, px, (size_t)w * (size_t)h * 3 * sizeof(float));
        stbi_image_free(px);
        if (is_hdr) *is_hdr = 1;
    } else if (stbi_is_16_bit_from_file(f)) {
        /* Debian's stb (2.27) says 16 bits for a 16-bit PNM but loads 8: only PNG is read as 16-bit. */
        if (!png) return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: 16-bit images other than PNG are not supported", path);
        stbi_us *px = stbi_load_from_file_16(f, &w, &h, &comp, 3);
        if (!px) return pgi__fail(PGI_ERR_PARSE, "%s: unreadable image: %s", path, stbi_failure_reason());
        size_t n = (size_t)w * (size_t)h * 3;
        rgb = malloc(n * sizeof(float));
        if (rgb)
            for (size_t i = 0; i < n; ++i) rgb[i] = (float)pgi__srgb_to_linear(px[i] / 65535.0);
        stbi_image_free(px);
        if (is_hdr) *is_hdr = 0;
    } else {
        stbi_uc *px = stbi_load_from_file(f, &w, &h, &comp, 3);
        if (!px) return pgi__fail(PGI_ERR_PARSE, "%s: unreadable image: %s", path, stbi_failure_reason());
        float lut[256];
        for (int i = 0; i < 256; ++i) lut[i] = (float)pgi__srgb_to_linear(i / 255.0);
        size_t n = (size_t)w * (size_t)h * 3;
        rgb = malloc(n * sizeof(float));
        if (rgb)
            for (size_t i = 0; i < n; ++i) rgb[i] = lut[px[i]];
        stbi_image_free(px);
        if (is_hdr) *is_hdr = 0;
    }
    if (!rgb) return pgi__fail(PGI_ERR_OOM, "%s: out of memory for a %dx%d image", path, w, h);
    out->width = w;
    out->height = h;
    out->rgb = rgb;
    return PGI_OK;
}

pgi_status pgi__image_read(const char *path, pgi_image *out, int *is_hdr) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "image read: no output image");
    out->width = out->height = 0;
    out->rgb = NULL;
    if (is_hdr) *is_hdr = 0;
    if (!path || !path[0]) return pgi__fail(PGI_ERR_INVALID_ARG, "image read: no input path");

    errno = 0;
    const char *why = NULL;
    FILE *f = pgi__fopen_input(path, 0, NULL, &why); /* a FIFO or device is refused, not read */
    if (!f) return pgi__fail(PGI_ERR_IO, "%s: %s", path, why ? why : strerror(errno));
    unsigned char magic[4] = {0};
    size_t got = fread(magic, 1, sizeof magic, f);
    if (ferror(f)) {
        int e = errno;
        fclose(f);
        return pgi__fail(PGI_ERR_IO, "%s: cannot read: %s", path, strerror(e));
    }
    /* Sniff the content rather than trusting the extension: EXR's magic is
     * 0x762f3101; everything else goes to stb, which probes its formats. */
    if (got == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01) {
        fclose(f);
        pgi_status s = read_exr(path, out);
        if (s == PGI_OK && is_hdr) *is_hdr = 1;
        return s;
    }
    rewind(f);
    const int png = got == 4 && magic[0] == 0x89 && magic[1] == 'P' && magic[2] == 'N' && magic[3] == 'G';
    pgi_status s = read_stb(path, f, png, out, is_hdr);
    fclose(f);
    return s;
}
