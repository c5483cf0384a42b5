/* Growable 64-byte-aligned arrays kept by an estimator between frames. */
#ifndef PGI__EST_BUF_H
#define PGI__EST_BUF_H

#include "core/core.h"

/* Grows *p to hold n elements of `size` bytes (64-byte aligned); keeps the
 * allocation when it is large enough. */
pgi_status pgi__ensure(void **p, size_t *cap, size_t n, size_t size);

/* A growable array: pointer and capacity (in elements). */
typedef struct pgi__buf {
    void *p;
    size_t cap;
    size_t bytes; /* the most bytes asked of it since it was allocated (the part in use: memory stats) */
} pgi__buf;

/* Makes b hold n elements of `elem` bytes: pgi__ensure's growth policy and
 * alignment. The contents are not kept when it grows. */
static inline pgi_status pgi__buf_reserve(pgi__buf *b, size_t n, size_t elem) {
    void *old = b->p;
    pgi_status st = pgi__ensure(&b->p, &b->cap, n, elem);
    if (st == PGI_OK && (b->p != old || n * elem > b->bytes)) b->bytes = n * elem;
    return st;
}

static inline void pgi__buf_free(pgi__buf *b) {
    pgi__afree(b->p);
    b->p = NULL;
    b->cap = 0;
    b->bytes = 0;
}

/* A pgi__buf field with a typed view of its pointer: PGI__BUF(float, irr)
 * declares `float *irr` and `pgi__buf irr_buf` sharing storage (anonymous
 * union), so code indexes s->irr and grows s->irr_buf. */
#define PGI__BUF(type, name)                                                                                           \
    union {                                                                                                            \
        pgi__buf name##_buf;                                                                                           \
        type *name;                                                                                                    \
    }

#endif
