#include "core.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static _Thread_local char g_last_error[1024];

pgi_status pgi__fail(pgi_status s, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(g_last_error, sizeof g_last_error, fmt, ap);
    va_end(ap);
    pgi__sanitize(g_last_error); /* names from files: no escape sequences reach a terminal */
    return s;
}

void pgi__sanitize(char *text) {
    for (unsigned char *p = (unsigned char *)text; *p; p++)
        if ((*p < 0x20 && *p != '\n' && *p != '\t') || *p == 0x7f) *p = '?';
}

#if defined(__x86_64__) || defined(__i386__)
int pgi__cpu_narrow = 0;
int pgi__cpu_no512 = 0;
#endif

void pgi__clear_error(void) { g_last_error[0] = 0; }

const char *pgi_last_error(void) { return g_last_error; }

const char *pgi_status_string(pgi_status s) {
    switch (s) {
    case PGI_OK: return "ok";
    case PGI_ERR_INVALID_ARG: return "invalid argument";
    case PGI_ERR_IO: return "i/o error";
    case PGI_ERR_PARSE: return "parse error";
    case PGI_ERR_OOM: return "out of memory";
    case PGI_ERR_UNSUPPORTED: return "unsupported";
    case PGI_ERR_INTERNAL: return "internal error";
    case PGI_ERR_CANCELLED: return "cancelled";
    }
    return "unknown status";
}

const char *pgi_version(void) { return PGI_VERSION_STRING; }

pgi_status pgi_cancel_create(pgi_cancel **out) {
    if (!out) return pgi__fail(PGI_ERR_INVALID_ARG, "pgi_cancel_create: NULL argument");
    *out = calloc(1, sizeof **out);
    if (!*out) return pgi__fail(PGI_ERR_OOM, "out of memory for a cancel token");
    atomic_init(&(*out)->requested, 0);
    return PGI_OK;
}

void pgi_cancel_destroy(pgi_cancel *c) { free(c); }

void pgi_cancel_request(pgi_cancel *c) {
    if (c) atomic_store_explicit(&c->requested, 1, memory_order_relaxed);
}

void pgi_cancel_reset(pgi_cancel *c) {
    if (c) atomic_store_explicit(&c->requested, 0, memory_order_relaxed);
}

int pgi_cancel_requested(const pgi_cancel *c) { return pgi__cancelled(c); }

pgi_status pgi__fail_cancelled(const char *what) { return pgi__fail(PGI_ERR_CANCELLED, "%s: cancelled", what); }

void pgi__assert_fail(const char *expr, const char *file, int line) {
    fprintf(stderr, "photongi: internal invariant failed: %s (%s:%d)\n", expr, file, line);
    abort();
}

double pgi__now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

void pgi__list_append(char *buf, size_t cap, const char *name) {
    size_t n = strlen(buf);
    snprintf(buf + n, cap > n ? cap - n : 0, "%s%s", n ? ", " : "", name);
}

void *pgi__aalloc(size_t bytes) {
    if (bytes == 0) bytes = 64;
    bytes = (bytes + 63) & ~(size_t)63;
    return aligned_alloc(64, bytes);
}

void pgi__afree(void *p) { free(p); }

pgi_status pgi__check_image_size(const char *what, int64_t w, int64_t h) {
    if (w >= 1 && h >= 1 && w <= PGI__MAX_SIDE && h <= PGI__MAX_SIDE && (uint64_t)(w * h) <= PGI__MAX_PIXELS)
        return PGI_OK;
    return pgi__fail(PGI_ERR_UNSUPPORTED, "%s: image of %lldx%lld is out of range (1..%d a side, at most %u pixels)",
                     what, (long long)w, (long long)h, PGI__MAX_SIDE, PGI__MAX_PIXELS);
}

const char *pgi__not_regular_file(const char *path) {
    struct stat st;
    if (stat(path, &st) != 0) return errno == ENOENT || errno == ENOTDIR ? "no such file" : strerror(errno);
    if (S_ISREG(st.st_mode)) return NULL;
    if (S_ISDIR(st.st_mode)) return "is a directory";
    if (S_ISFIFO(st.st_mode)) return "is a FIFO, not a regular file";
    if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return "is a device, not a regular file";
    if (S_ISSOCK(st.st_mode)) return "is a socket, not a regular file";
    return "is not a regular file";
}

FILE *pgi__fopen_input(const char *path, uint64_t max_bytes, uint64_t *size, const char **why) {
    static _Thread_local char too_big[96];
    *why = NULL;
    if (size) *size = 0;
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        int e = errno;
        *why = e == ENOENT || e == ENOTDIR ? "no such file" : strerror(e);
        errno = e;
        return NULL;
    }
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        *why = strerror(e);
        errno = e;
        return NULL;
    }
    if (!S_ISREG(st.st_mode)) {
        *why = S_ISDIR(st.st_mode)                          ? "is a directory"
               : S_ISFIFO(st.st_mode)                       ? "is a FIFO, not a regular file"
               : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "is a device, not a regular file"
               : S_ISSOCK(st.st_mode)                       ? "is a socket, not a regular file"
                                                            : "is not a regular file";
        close(fd);
        errno = EINVAL;
        return NULL;
    }
    if (max_bytes && (uint64_t)st.st_size > max_bytes) {
        snprintf(too_big, sizeof too_big, "is %llu bytes, more than the %llu this file may have",
                 (unsigned long long)st.st_size, (unsigned long long)max_bytes);
        *why = too_big;
        close(fd);
        errno = EFBIG;
        return NULL;
    }
    int fl = fcntl(fd, F_GETFL);
    if (fl >= 0) fcntl(fd, F_SETFL, fl & ~O_NONBLOCK);
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        *why = strerror(e);
        errno = e;
        return NULL;
    }
    if (size) *size = (uint64_t)st.st_size;
    return f;
}
