/* State and helpers shared by the cluster-hierarchy estimators (cluster,
 * cluster-cone, cluster-trivial in est_cluster.c, directional in
 * est_directional.c) and the hierarchy build (cluster_build.c). */
#ifndef PGI__EST_CLUSTER_INTERNAL_H
#define PGI__EST_CLUSTER_INTERNAL_H

#include "buf.h"
#include "est_common.h"
#include "packed.h"
#include "screen.h"

enum { V_CONE = 1, V_TRIVIAL = 2, V_DIR = 4 };

#define MAX_LEVELS 12
#define NCHUNK_MAX 64
#define JOB_LEVEL_NODES 256

typedef struct cnode {
    float lo[3], hi[3]; /* view-space AABB of the samples */
    float ax, ay, az;   /* normal-cone axis (world space, unit up to rounding) */
    float rej, acc;     /* dot(axis, w_p) < rej: below every normal; > acc: above every normal */
    uint32_t mask;      /* child occupancy: bit i = child with key digit i */
    uint32_t first;     /* index of the first child; children are contiguous in digit order */
    uint32_t lambert;   /* every sample in the node is Lambertian */
    uint32_t parent;
    float alpha; /* normal-cone half-angle (radians, rounded up); > pi: open cone */
} cnode;

typedef struct {
    pgi__est_common c;
    int variant, T, dir_up, blur;
    /* frame */
    int W, H, ntx, nty, L, J, D;
    pgi__view_xf x;
    float r;
    size_t nvalid, nnodes, nchunks, chunk;
    uint32_t lvl_off[MAX_LEVELS + 2];
    /* sort */
    PGI__BUF(uint64_t, keys);  /* sorted cluster keys */
    PGI__BUF(uint64_t, keys2); /* per-tile sorted samples */
    PGI__BUF(uint64_t, spread);
    PGI__BUF(uint64_t, ck2);
    PGI__BUF(uint32_t, tcl); /* per tile: cluster base */
    PGI__BUF(uint32_t, tn);  /* per tile: count */
    PGI__BUF(uint32_t, ci);  /* per cluster: index */
    PGI__BUF(uint32_t, ci2);
    PGI__BUF(uint32_t, cb); /* per cluster: begin */
    PGI__BUF(uint32_t, cn); /* per cluster: size */
    PGI__BUF(uint32_t, cs); /* per cluster: start */
    PGI__BUF(uint32_t, order);
    PGI__BUF(uint32_t, hist);
    PGI__BUF(uint32_t, pix_cnt);
    PGI__BUF(uint64_t, sec_key); /* mirror-seen samples: cell keys (two halves: radix ping-pong) */
    PGI__BUF(uint32_t, sec_pix); /* their pixels (the same) */
    PGI__BUF(float, sec_pos);    /* their view-space positions */
    /* hierarchy */
    PGI__BUF(cnode, nodes);
    PGI__BUF(uint32_t, sbeg); /* nnodes + 1: node sample ranges [sbeg[i], send[i]) */
    PGI__BUF(uint32_t, send);
    PGI__BUF(uint64_t, nkey);
    /* splat */
    PGI__BUF(uint32_t, top_cnt);
    PGI__BUF(uint32_t, top_tcnt);
    PGI__BUF(uint32_t, job_start);
    PGI__BUF(uint32_t, jobs);
    PGI__BUF(uint32_t, top_ids);
    PGI__BUF(uint32_t, node_cnt);
    PGI__BUF(uint32_t, node_start);
    PGI__BUF(uint32_t, node_tcnt);
    PGI__BUF(uint32_t, cursor);
    PGI__BUF(float, top_flux);
    PGI__BUF(float, node_flux);
    PGI__BUF(float, buckets);
    PGI__BUF(uint32_t, lists);        /* node photon lists: indices into pk, photon order */
    PGI__BUF(pgi__packed_photon, pk); /* every photon packed, grouped by its first top node */
    PGI__BUF(uint32_t, perm);         /* per photon: its position in pk */
    PGI__BUF(uint32_t, perm_hist);    /* per top chunk x first top node: counts, then positions */
    size_t njobs, nlist, ntop_list, npacked;
    /* radiance */
    PGI__BUF(float, cum_flux);
    PGI__BUF(float, irr);
    PGI__BUF(uint32_t, cum_cnt);
    uint64_t deposits;
    struct sink *outs; /* traversal records: one per top chunk / per thread */
    int nouts;
    PGI__BUF(uint32_t, task_rec); /* per job-level node: thread, first and end record */
    /* SoA copies for child_hits (in soa); cacc: the trivial-accept threshold, +inf for a node
       that is not all-Lambertian */
    float *sx0, *sy0, *sz0, *sx1, *sy1, *sz1, *cax, *cay, *caz, *crej, *cacc;
    PGI__BUF(float, soa);
    PGI__BUF(float, sam); /* 6 x nvalid: sorted samples' world position (x NaN: not Lambertian) and normal */
    int splatted;         /* this frame has nodes and photons (lists/buckets are valid) */
} cl_state;

/* Grows the PGI__BUF field s->field to n elements of `type`. */
#define ENSURE(field, n, type) pgi__buf_reserve(&s->field##_buf, (n), sizeof(type))

/* The branch-free inner loops (blur taps, radiance blocks) vectorise over
 * consecutive pixels / samples. GCC's -O3 unroll-and-jam would fuse two outer
 * iterations and leave the fused loop scalar, so it is turned off for them;
 * on x86-64 an AVX2 clone is picked at load time (no FMA: -ffp-contract=off
 * still holds, lanes are independent, so the results are bit-identical). */
#if defined(__GNUC__) && !defined(__clang__)
#define PGI__HOT_LOOP __attribute__((optimize("no-loop-unroll-and-jam"))) PGI__AVX2_CLONES
#else
#define PGI__HOT_LOOP
#endif

/* Shared across the family's files (cl_: the cluster family, internal). */

/* est_cluster.c: the family's create, build (hierarchy + splat), destroy. */
pgi_status cl_create_variant(const pgi_estimator_desc *d, void **state, int variant);
/* The cluster edge option of the cluster family and directional (est_cluster.c). */
extern const pgi_option pgi__opt_cluster_tile;
pgi_status cl_build(void *state, const pgi_estimate_args *a);
void cl_destroy(void *state);
/* Bytes per structure of the frame (the paper's Table 1), after the radiance pass. */
void cl_stats_memory(cl_state *s, size_t npix);

/* cluster_build.c: the view-sample hierarchy of one frame; *t_sort gets the
 * time the sort ended. */
pgi_status cl_build_hierarchy(cl_state *s, const pgi_view_samples *vs, const pgi_camera *cam, double *t_sort);

#endif
