/* photongi-mpi: `photongi render` and `photongi reference` with their frames and samples dealt
 * to MPI ranks (docs/distributed.md). A thin layer over the public API: the command lines are
 * photongi's own (apps/photongi/cmd_render.c, cmd_reference.c), which call this file's backend
 * (pgi_cli_backend, apps/photongi/cmd.h) where photongi renders in its own process.
 *
 * The unit of work is a block of PGI_PROGRESSIVE_BLOCK frames (PGI_REFERENCE_BLOCK samples), the
 * unit of the library's summation order, and for the last 2R blocks of a progressive render a
 * single frame (so that the tail is one frame): rank 0 deals units on demand (each worker keeps
 * one queued ahead while many remain; at the end a worker's TAG_SOON gets it its next unit before
 * it needs it), renders units itself between serving the others (from the render's progress
 * callback, which the library calls between passes), receives the workers' block sums and adds
 * them into the total in block order, and their single frames into their block's sum in frame
 * order, holding those that arrive early (at most `window` blocks dealt past the oldest
 * unfinished one). Frame k is the same whoever renders it (seed stream k, radius r_k from frame
 * 0's r0, broadcast by rank 0 as soon as frame 0 has chosen it; a worker traces its first frame's
 * photons before it needs r0), so the image is the single-process image, byte for byte, whatever
 * the rank and thread counts.
 *
 * Failures: every rank parses the command line and loads the scene; then all meet once
 * (begin_scene(), which also fails a rank whose scene differs from rank 0's): if any rank failed by then, rank 0's message (or, when rank 0 is fine, the failed
 * rank's, prefixed with its rank) is printed and every rank exits with that status. A failure
 * after that point prints "photongi-mpi: rank N: ..." and ends the job with MPI_Abort. Ranks
 * other than 0 write nothing: their standard output is discarded and their standard error kept
 * in a temporary file, shown only when that rank fails. */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <mpi.h>
#include <stdarg.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "cli.h"
#include "cmd.h"
#include "photongi/photongi.h"
#include "photongi/reference.h"

#define STR(x) #x
#define XSTR(x) STR(x)

static const char *k_help =
    "photongi-mpi " PGI_VERSION_STRING " - photongi's render and reference across MPI ranks\n"
    "\n"
    "usage: mpirun -np R photongi-mpi render [options] -o OUT.png|OUT.exr\n"
    "       mpirun -np R photongi-mpi reference [options] -o REF.exr\n"
    "\n"
    "The command lines are photongi's ('photongi-mpi render --help' lists the options). The\n"
    "frames of render --progressive N (blocks of " XSTR(
        PGI_PROGRESSIVE_BLOCK) " frames) and the samples of reference\n"
                               "(blocks of " XSTR(
                                   PGI_REFERENCE_BLOCK) " samples) are dealt to the ranks by rank 0 on demand, so a "
                                                        "slow rank does not\n"
                                                        "hold up the others; the sums are added in block order, so the "
                                                        "image is the one 'photongi'\n"
                                                        "writes with the same options, byte for byte, whatever R and "
                                                        "--threads. Rank 0 writes the\n"
                                                        "outputs and prints; render --stats adds \"mpi\": per-rank "
                                                        "blocks, frames, busy, wait and\n"
                                                        "reduction milliseconds, bytes sent and peak resident set. "
                                                        "Every rank reads the scene (and\n"
                                                        "--continue's reference): the files must be visible to all of "
                                                        "them. Give --threads T for\n"
                                                        "the threads of each rank (default: all cores, per rank). "
                                                        "Without mpirun it runs as 1 rank.\n"
                                                        "\n"
                                                        "Exit status as photongi's (0 success, 2 usage error, 1 "
                                                        "failure); an error on a rank other\n"
                                                        "than 0 is printed with its rank. See docs/distributed.md.\n";

/* TAG_SOON: a worker has started the last passes of its unit's last frame (no data) */
enum { TAG_DEAL = 1, TAG_RESULT = 2, TAG_FRAME = 3, TAG_SOON = 4 };

static int g_rank, g_size;
static int g_real_err = 2; /* the process's standard error (rank > 0: stderr itself goes to g_capture) */
static FILE *g_capture;    /* rank > 0: what the command printed on stderr */
static int g_entered;      /* begin() was called */
static int g_mismatch;     /* begin_scene(): a rank's scene differs from rank 0's (rank 0 said so) */
static int *g_codes;       /* begin(): each rank's code (0 ready, -1 done without work, > 0 exit status) */
static int g_quiet;

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

/* A failure once the ranks work together: the message, with the rank, and the end of the job. */
#if defined(__GNUC__)
__attribute__((format(printf, 1, 2), noreturn))
#endif
static void
die(const char *fmt, ...) {
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    dprintf(g_real_err, "photongi-mpi: rank %d of %d: %s\n", g_rank, g_size, msg);
    MPI_Abort(MPI_COMM_WORLD, CLI_EXIT_FAILURE);
    exit(CLI_EXIT_FAILURE);
}

/* What a rank loaded, as a number: its counts, bounds, area and first camera (FNV-1a over them).
 * Ranks that read different files under one path (a node's own copy) differ here. */
static uint64_t scene_fingerprint(const pgi_scene *s) {
    pgi_scene_info in;
    memset(&in, 0, sizeof in);
    if (s) pgi_scene_get_info(s, &in);
    const double v[] = {(double)in.triangles, (double)in.vertices,  (double)in.materials, (double)in.textures,
                        (double)in.lights,    (double)in.cameras,   in.surface_area,      in.bounds_min[0],
                        in.bounds_min[1],     in.bounds_min[2],     in.bounds_max[0],     in.bounds_max[1],
                        in.bounds_max[2],     in.camera.eye[0],     in.camera.eye[1],     in.camera.eye[2],
                        in.camera.look_at[0], in.camera.look_at[1], in.camera.look_at[2], in.camera.fov_y_deg};
    uint64_t h = 1469598103934665603ull;
    const unsigned char *b = (const unsigned char *)v;
    for (size_t i = 0; i < sizeof v; i++) h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* The one meeting before the work: every rank's code; returns the first failed rank or -1. A rank
 * whose scene differs from rank 0's (scene_fingerprint) fails it: mixing them would be a silent
 * wrong image. */
static int begin_scene(int code, const pgi_scene *scene) {
    g_entered = 1;
    MPI_Allgather(&code, 1, MPI_INT, g_codes, 1, MPI_INT, MPI_COMM_WORLD);
    for (int i = 0; i < g_size; i++)
        if (g_codes[i] > 0) return i;
    if (scene) {
        uint64_t fp = scene_fingerprint(scene), fp0 = fp;
        MPI_Bcast(&fp0, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
        int bad = fp != fp0 ? g_rank : -1, first = -1;
        MPI_Allreduce(&bad, &first, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        if (first >= 0) {
            if (g_rank == 0) {
                pgi_scene_info in;
                pgi_scene_get_info(scene, &in);
                fprintf(stderr,
                        "photongi-mpi: rank %d loaded a different scene from %s than rank 0 did (another file "
                        "under the same path on its machine?): the ranks must read the same files\n",
                        first, in.source);
            }
            for (int i = 0; i < g_size; i++) g_codes[i] = i == first ? CLI_EXIT_FAILURE : 0;
            g_mismatch = 1;
            return first;
        }
    }
    return -1;
}

static pgi_status peer_failed(int who) {
    /* the library's error slot is not ours to set: the message goes through cli_fail's fallback */
    if (g_rank != who && g_rank == 0 && !g_mismatch)
        fprintf(stderr, "photongi-mpi: rank %d of %d failed before the work began (its message follows)\n", who,
                g_size);
    return PGI_ERR_IO;
}

/* ------------------------------------------------------------------ per-rank statistics */

/* wait: all of a rank's waiting; of it, wait_r0: a worker's wait for r0, wait_end: the wait after its
   last unit (a worker: for the end; rank 0: for the workers' last results) */
enum { RS_BLOCKS, RS_ITEMS, RS_BUSY, RS_WAIT, RS_WAIT_R0, RS_WAIT_END, RS_REDUCE, RS_SENT, RS_RSS, RS_COUNT };
static double g_rs[RS_COUNT];

/* ------------------------------------------------------------------ the dealer */

/* A unit of work as it travels in a TAG_DEAL message: block b (b >= 0), the single frame k of a
 * split block (-2 - k) or the end of the work (-1). */
#define UNIT_STOP (-1)
static int64_t unit_frame(int64_t k) { return -2 - k; }
static int unit_is_frame(int64_t u) { return u <= -2; }
static int64_t frame_of_unit(int64_t u) { return -2 - u; }

typedef struct job job;
/* Renders the items of block b into *sum (3 doubles a pixel; overwritten; a worker's *sum may be NULL
 * before its first frame, which tells the image size: then allocated). */
typedef pgi_status (*work_fn)(job *j, int64_t b, double **sum);
/* Renders the single frame k into j->frame (split blocks, render --progressive only). */
typedef pgi_status (*frame_fn)(job *j, int64_t k);

struct job {
    size_t values; /* 3 x pixels */
    int64_t items; /* frames or samples */
    int block;     /* items per block */
    int64_t nblocks;
    work_fn work;
    frame_fn work_frame;
    double time_limit_ms; /* reference --time: no block is dealt after it (0: none) */
    int stop_asked;       /* rank 0: the caller's progress callback asked to stop (a checkpoint, a signal) */
    double t0;
    /* the blocks from split_from on are dealt frame by frame (nblocks: none), so that the last
       rank to finish is at most about one frame, not one block, behind the others */
    int64_t split_from;
    /* rank 0 */
    double *total;
    double **held; /* block -> its sum, until merged */
    double **pool;
    int npool, cap_pool;
    int64_t next_item; /* the first frame (sample) not dealt yet */
    int64_t next_merge, items_done;
    int window;
    int *outstanding, *stopped;
    int *soon;          /* per worker: units whose TAG_SOON came but not their result */
    double unit_t0;     /* rank 0: when its unit in progress started (0: none) */
    int64_t unit_items; /* ... and its frames still to render */
    MPI_Request *rreq;
    double **rbuf;
    int *rframe; /* rreq[i] receives a frame (else a block sum) */
    int nrecv, cap_recv;
    double **part;      /* split block split_from + i: its sum so far, frames added in frame order */
    int64_t *part_next; /* ... and the next frame it takes */
    double **fheld;     /* frame split_from * block + i, arrived before its turn (a pool buffer) */
    /* workers: results in flight; the frame being rendered and its unit's last frame */
    MPI_Request sreq[2];
    int64_t cur_frame, unit_last;
    int soon_sent;
    /* what the job is */
    pgi_renderer *r;
    pgi_render_desc d;
    float r0;      /* frame 0's radius, once broadcast (0 before) */
    int have_r0;   /* this rank took part in r0's broadcast */
    int in_frame0; /* rank 0 is rendering frame 0 */
    int serving;   /* rank 0 takes in results (from frame 0's end: the image size is known) */
    pgi_image frame;
    pgi_frame_stats first, sum; /* rank 0: frame 0's; every rank: its frames' counters summed */
    int have_sum;
    pgi_reference_sampler *sampler;
    uint64_t n0;
    /* the caller's progress callbacks */
    pgi_progress_fn user_progress;
    void *user_progress_user;
    pgi_reference_progress_fn ref_progress;
    void *ref_progress_user;
    const char *pass;
};

static int64_t block_items(const job *j, int64_t b) {
    int64_t lo = b * j->block, hi = lo + j->block;
    return (hi > j->items ? j->items : hi) - lo;
}

/* Blocks dealt so far, whole or in part. */
static int64_t blocks_dealt(const job *j) { return (j->next_item + j->block - 1) / j->block; }

/* A buffer of values + 1 doubles: a block sum and its index, or (as bytes) a frame's index and floats. */
static double *pool_get(job *j) {
    if (j->npool > 0) return j->pool[--j->npool];
    double *p = malloc((j->values + 1) * sizeof *p);
    if (!p) die("out of memory for a block sum of %zu values", j->values);
    return p;
}

static void pool_put(job *j, double *p) {
    if (j->npool == j->cap_pool) {
        int cap = j->cap_pool ? 2 * j->cap_pool : 8;
        double **q = realloc(j->pool, (size_t)cap * sizeof *q);
        if (!q) die("out of memory");
        j->pool = q;
        j->cap_pool = cap;
    }
    j->pool[j->npool++] = p;
}

/* A frame message: the frame index (int64) and then the frame's values floats. */
#define FRAME_HEAD sizeof(int64_t)
static size_t frame_bytes(const job *j) { return FRAME_HEAD + j->values * sizeof(float); }
static float *frame_rgb(double *buf) { return (float *)(void *)((char *)buf + FRAME_HEAD); }

static int dealing_over(const job *j) {
    if (j->next_item >= j->items || j->stop_asked) return 1;
    return j->time_limit_ms > 0.0 && now_ms() - j->t0 >= j->time_limit_ms && j->next_item > 0;
}

static int can_deal(const job *j) { return !dealing_over(j) && j->next_item / j->block < j->next_merge + j->window; }

/* The next unit (can_deal): a whole block before split_from, else one frame. */
static int64_t take_unit(job *j) {
    const int64_t b = j->next_item / j->block;
    if (b < j->split_from) {
        j->next_item = b * j->block + block_items(j, b);
        return b;
    }
    return unit_frame(j->next_item++);
}

static void merge_ready(job *j) {
    double t = now_ms();
    const int64_t dealt = blocks_dealt(j);
    while (j->next_merge < dealt && j->held[j->next_merge]) {
        pgi_block_sum_merge(j->total, j->held[j->next_merge], j->values);
        j->items_done += block_items(j, j->next_merge);
        /* a reference rounds its total after every whole block, as pgi_reference_render does */
        if (j->sampler && block_items(j, j->next_merge) == j->block)
            pgi_block_sum_round(j->total, j->values, j->n0 + (uint64_t)j->items_done);
        pool_put(j, j->held[j->next_merge]);
        j->held[j->next_merge++] = NULL;
    }
    g_rs[RS_REDUCE] += now_ms() - t;
}

/* Frame k of a split block, from rank 0 itself (rgb, buf NULL) or from a worker (buf, a pool
 * buffer, given up): added into its block's sum in frame order (pgi_block_sum_add, as one rank
 * would), or held until the frames before it have come. */
static void deliver_frame(job *j, int64_t k, const float *rgb, double *buf) {
    double t = now_ms();
    const int64_t b = k / j->block, i = b - j->split_from, f0 = j->split_from * j->block;
    if (k != j->part_next[i]) {
        if (!buf) {
            buf = pool_get(j);
            memcpy(frame_rgb(buf), rgb, j->values * sizeof(float));
        }
        j->fheld[k - f0] = buf;
        g_rs[RS_REDUCE] += now_ms() - t;
        return;
    }
    if (!j->part[i]) j->part[i] = pool_get(j);
    const int64_t end = b * j->block + block_items(j, b);
    for (;;) {
        pgi_block_sum_add(j->part[i], rgb, j->values, k == b * j->block);
        if (buf) pool_put(j, buf);
        j->part_next[i] = ++k;
        if (k == end || !j->fheld[k - f0]) break;
        buf = j->fheld[k - f0];
        j->fheld[k - f0] = NULL;
        rgb = frame_rgb(buf);
    }
    if (k == end) {
        j->held[b] = j->part[i];
        j->part[i] = NULL;
    }
    g_rs[RS_REDUCE] += now_ms() - t;
    merge_ready(j);
}

/* Rank 0's frames so far, mean milliseconds (0 before it has finished any). */
static double rank0_frame_ms(void) { return g_rs[RS_ITEMS] > 0.0 ? g_rs[RS_BUSY] / g_rs[RS_ITEMS] : 0.0; }

/* How long until rank 0 is done with its unit in progress (0 when it renders none). */
static double rank0_free_in(const job *j) {
    if (j->unit_t0 <= 0.0) return 0.0;
    const double left = rank0_frame_ms() * (double)j->unit_items - (now_ms() - j->unit_t0);
    return left > 0.0 ? left : 0.0;
}

static void top_up(job *j) {
    for (int w = 1; w < g_size; w++) {
        if (j->stopped[w]) continue;
        for (;;) {
            /* one unit queued ahead while many remain; at the end one at a time, so that no rank
               holds work another could start */
            const int64_t b = j->next_item / j->block;
            const int target = b < j->split_from ? (j->nblocks - b >= 2 * g_size ? 2 : 1)
                                                 : (j->items - j->next_item >= 2 * g_size ? 2 : 1);
            /* at the end, a unit whose last passes have started (TAG_SOON) is as good as done: its
               successor is dealt now and is there when it ends, no round trip */
            const int held = j->outstanding[w] - (target == 1 ? j->soon[w] : 0);
            if (held >= target || !can_deal(j)) break;
            /* the very last frame: a worker still finishing its frame (TAG_SOON came: about half a
               frame to go) would end it about 1.5 frames from now; rank 0 keeps it when it will be
               free within half a frame (it, or a worker that is idle by then, takes it) */
            const double per_frame = rank0_frame_ms();
            if (held < j->outstanding[w] && b >= j->split_from && j->items - j->next_item == 1 && per_frame > 0.0 &&
                rank0_free_in(j) < 0.5 * per_frame)
                break;
            int64_t u = take_unit(j);
            MPI_Send(&u, 1, MPI_INT64_T, w, TAG_DEAL, MPI_COMM_WORLD);
            g_rs[RS_SENT] += sizeof u;
            j->outstanding[w]++;
        }
        if (dealing_over(j)) {
            int64_t stop = UNIT_STOP;
            MPI_Send(&stop, 1, MPI_INT64_T, w, TAG_DEAL, MPI_COMM_WORLD);
            g_rs[RS_SENT] += sizeof stop;
            j->stopped[w] = 1;
        }
    }
}

/* A completed receive (rreq[i], status s): a block sum held for its turn, or a frame delivered. */
static void received(job *j, int i, const MPI_Status *s) {
    double *buf = j->rbuf[i];
    const int is_frame = j->rframe[i];
    j->rreq[i] = j->rreq[j->nrecv - 1];
    j->rbuf[i] = j->rbuf[j->nrecv - 1];
    j->rframe[i] = j->rframe[j->nrecv - 1];
    j->nrecv--;
    j->outstanding[s->MPI_SOURCE]--;
    if (j->soon[s->MPI_SOURCE] > 0) j->soon[s->MPI_SOURCE]--;
    if (is_frame) {
        int64_t k;
        memcpy(&k, buf, sizeof k);
        if (k < j->split_from * j->block || k >= j->next_item || k < j->part_next[k / j->block - j->split_from] ||
            j->fheld[k - j->split_from * j->block])
            die("rank %d sent frame %" PRId64 " it was not dealt", s->MPI_SOURCE, k);
        deliver_frame(j, k, frame_rgb(buf), buf);
        return;
    }
    int64_t b = (int64_t)buf[j->values];
    if (b < 0 || b >= j->split_from || b >= blocks_dealt(j) || j->held[b])
        die("rank %d sent block %" PRId64 " it was not dealt", s->MPI_SOURCE, b);
    j->held[b] = buf;
}

/* Rank 0: takes in what the workers sent (receives posted, completed ones added or held, TAG_SOON
 * noted); returns how many messages it handled. */
static int collect(job *j) {
    int flag, n = 0;
    MPI_Status s;
    for (;;) {
        MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &s);
        if (!flag) break;
        if (s.MPI_TAG == TAG_SOON) {
            MPI_Recv(NULL, 0, MPI_BYTE, s.MPI_SOURCE, TAG_SOON, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            j->soon[s.MPI_SOURCE]++;
            n++;
            continue;
        }
        if (s.MPI_TAG != TAG_RESULT && s.MPI_TAG != TAG_FRAME) die("unexpected message (tag %d)", s.MPI_TAG);
        if (j->nrecv == j->cap_recv) {
            int cap = j->cap_recv ? 2 * j->cap_recv : 8;
            MPI_Request *q = realloc(j->rreq, (size_t)cap * sizeof *q);
            if (q) j->rreq = q;
            double **qb = realloc(j->rbuf, (size_t)cap * sizeof *qb);
            if (qb) j->rbuf = qb;
            int *qf = realloc(j->rframe, (size_t)cap * sizeof *qf);
            if (qf) j->rframe = qf;
            if (!q || !qb || !qf) die("out of memory");
            j->cap_recv = cap;
        }
        double *buf = pool_get(j);
        j->rframe[j->nrecv] = s.MPI_TAG == TAG_FRAME;
        if (s.MPI_TAG == TAG_FRAME)
            MPI_Irecv(buf, (int)frame_bytes(j), MPI_BYTE, s.MPI_SOURCE, TAG_FRAME, MPI_COMM_WORLD, &j->rreq[j->nrecv]);
        else
            MPI_Irecv(buf, (int)(j->values + 1), MPI_DOUBLE, s.MPI_SOURCE, TAG_RESULT, MPI_COMM_WORLD,
                      &j->rreq[j->nrecv]);
        j->rbuf[j->nrecv++] = buf;
    }
    for (int i = 0; i < j->nrecv;) {
        MPI_Test(&j->rreq[i], &flag, &s);
        if (flag) {
            received(j, i, &s);
            n++;
        } else i++;
    }
    return n;
}

/* Rank 0, between its own passes and when idle: take in finished work, add it in order, deal. */
static void master_poll(job *j) {
    if (g_size == 1 || !j->serving) return; /* alone, or frame 0 (nothing can have come yet) */
    double t = now_ms(), red = g_rs[RS_REDUCE];
    collect(j);
    g_rs[RS_REDUCE] = red + (now_ms() - t); /* the adds inside included once */
    merge_ready(j);
    top_up(j);
}

/* Rank 0 with nothing to render: until a worker's message comes (any of them, so that a worker's
 * TAG_SOON is answered while another's result is still on its way). */
static void master_wait(job *j) {
    double t = now_ms(), red = g_rs[RS_REDUCE];
    const int end = dealing_over(j);
    while (!collect(j)) sched_yield();
    const double w = now_ms() - t - (g_rs[RS_REDUCE] - red);
    g_rs[RS_WAIT] += w;
    if (end) g_rs[RS_WAIT_END] += w;
    merge_ready(j);
    top_up(j);
}

/* A worker's buffer: a block sum and its index, or a frame's index and floats. */
static double *alloc_sum(const job *j) {
    double *p = malloc((j->values + 1) * sizeof *p);
    if (!p) die("out of memory for a block sum of %zu values", j->values);
    return p;
}

/* Workers: let the results in flight move while rendering. */
static void worker_poll(job *j) {
    int flag;
    for (int i = 0; i < 2; i++)
        if (j->sreq[i] != MPI_REQUEST_NULL) MPI_Test(&j->sreq[i], &flag, MPI_STATUS_IGNORE);
}

/* Renders unit u: block b into *sum, or frame k into j->frame. */
static void run_unit(job *j, int64_t u, double **sum) {
    /* test hook (tests/test_mpi.sh): a rank that fails in the middle of the work */
    const char *fail = getenv("PHOTONGI_MPI_FAIL_RANK");
    if (fail && *fail && atoi(fail) == g_rank) die("failing on purpose (PHOTONGI_MPI_FAIL_RANK=%s)", fail);
    double t = now_ms(), served = g_rs[RS_REDUCE], waited = g_rs[RS_WAIT];
    const int is_frame = unit_is_frame(u);
    j->unit_last = is_frame ? frame_of_unit(u) : u * j->block + block_items(j, u) - 1;
    j->soon_sent = 0;
    if (g_rank == 0) {
        j->unit_t0 = t;
        j->unit_items = is_frame ? 1 : block_items(j, u) - (u == 0); /* frame 0 is done before */
    }
    pgi_status st = is_frame ? j->work_frame(j, frame_of_unit(u)) : j->work(j, u, sum);
    if (st) {
        const char *m = pgi_last_error();
        if (is_frame) die("frame %" PRId64 ": %s", frame_of_unit(u), *m ? m : pgi_status_string(st));
        die("block %" PRId64 ": %s", u, *m ? m : pgi_status_string(st));
    }
    j->unit_t0 = 0.0;
    /* rank 0's serving between passes is reduction, a worker's wait for r0 in its first frame wait */
    g_rs[RS_BUSY] += now_ms() - t - (g_rs[RS_REDUCE] - served) - (g_rs[RS_WAIT] - waited);
    if (is_frame) g_rs[RS_ITEMS] += 1;
    else {
        g_rs[RS_BLOCKS] += 1;
        g_rs[RS_ITEMS] += (double)block_items(j, u);
    }
}

/* Rank 0, before its first frame: the dealer's state, and the first units dealt to the workers (which
 * start on them while rank 0 renders frame 0; progressive: rank 0 starts with frame 0 of block 0). */
static void master_begin(job *j, int frame0) {
    j->held = calloc((size_t)j->nblocks, sizeof *j->held);
    j->outstanding = calloc((size_t)g_size, sizeof *j->outstanding);
    j->stopped = calloc((size_t)g_size, sizeof *j->stopped);
    j->soon = calloc((size_t)g_size, sizeof *j->soon);
    const int64_t nsplit = j->nblocks - j->split_from;
    j->part = calloc((size_t)nsplit + 1, sizeof *j->part);
    j->part_next = calloc((size_t)nsplit + 1, sizeof *j->part_next);
    const int64_t split_items = j->split_from < j->nblocks ? j->items - j->split_from * j->block : 0;
    j->fheld = calloc((size_t)split_items + 1, sizeof *j->fheld);
    if (!j->held || !j->outstanding || !j->stopped || !j->soon || !j->part || !j->part_next || !j->fheld)
        die("out of memory for %" PRId64 " blocks", j->nblocks);
    for (int64_t i = 0; i < nsplit; i++) j->part_next[i] = (j->split_from + i) * j->block;
    j->window = 4 * g_size < 8 ? 8 : 4 * g_size;
    /* block 0 is rank 0's; when it is split, only frame 0 */
    if (frame0) j->next_item = j->split_from == 0 ? 1 : block_items(j, 0);
    top_up(j);
}

/* Rank 0's part after master_begin; own0: the sum of frame 0 (progressive), or NULL. */
static void master_run(job *j, double *own0) {
    j->serving = 1;
    if (own0 && j->split_from == 0) {
        /* block 0 is split: frame 0 is its first frame, the others are dealt */
        g_rs[RS_ITEMS] += 1; /* frame 0 (a whole block 0 counts it with its block) */
        j->part[0] = own0;
        j->part_next[0] = 1;
        if (block_items(j, 0) == 1) {
            j->held[0] = own0;
            j->part[0] = NULL;
            merge_ready(j);
        }
    } else if (own0) {
        run_unit(j, 0, &own0);
        j->held[0] = own0;
        merge_ready(j);
    }
    for (;;) {
        master_poll(j);
        if (can_deal(j)) {
            int64_t u = take_unit(j);
            top_up(j);
            if (unit_is_frame(u)) {
                run_unit(j, u, NULL);
                deliver_frame(j, frame_of_unit(u), j->frame.rgb, NULL);
            } else {
                double *buf = pool_get(j);
                run_unit(j, u, &buf);
                j->held[u] = buf;
                merge_ready(j);
            }
            continue;
        }
        if (dealing_over(j) && j->next_merge == blocks_dealt(j)) break;
        master_wait(j);
    }
    top_up(j); /* the stops, if the last blocks were rank 0's */
    free(j->held);
    free(j->outstanding);
    free(j->stopped);
    free(j->soon);
    free(j->rreq);
    free(j->rbuf);
    free(j->rframe);
    free(j->part);
    free(j->part_next);
    free(j->fheld);
    for (int i = 0; i < j->npool; i++) free(j->pool[i]);
    free(j->pool);
}

static void worker_run(job *j) {
    double *buf[2] = {NULL, NULL}; /* progressive: the image size is known after the first frame */
    j->sreq[0] = j->sreq[1] = MPI_REQUEST_NULL;
    for (int k = 0;; k ^= 1) {
        int64_t u;
        double t = now_ms();
        MPI_Recv(&u, 1, MPI_INT64_T, 0, TAG_DEAL, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        if (u != UNIT_STOP) MPI_Wait(&j->sreq[k], MPI_STATUS_IGNORE);
        g_rs[RS_WAIT] += now_ms() - t;
        if (u == UNIT_STOP) {
            g_rs[RS_WAIT_END] += now_ms() - t;
            break;
        }
        if (!buf[k] && j->values) buf[k] = alloc_sum(j);
        run_unit(j, u, &buf[k]);
        if (!buf[k]) buf[k] = alloc_sum(j);
        if (unit_is_frame(u)) {
            /* a single frame of a split block: its index and its floats, added on rank 0 in order */
            const int64_t f = frame_of_unit(u);
            memcpy(buf[k], &f, sizeof f);
            memcpy(frame_rgb(buf[k]), j->frame.rgb, j->values * sizeof(float));
            MPI_Isend(buf[k], (int)frame_bytes(j), MPI_BYTE, 0, TAG_FRAME, MPI_COMM_WORLD, &j->sreq[k]);
            g_rs[RS_SENT] += (double)frame_bytes(j);
        } else {
            buf[k][j->values] = (double)u;
            MPI_Isend(buf[k], (int)(j->values + 1), MPI_DOUBLE, 0, TAG_RESULT, MPI_COMM_WORLD, &j->sreq[k]);
            g_rs[RS_SENT] += (double)((j->values + 1) * sizeof(double));
        }
    }
    double t = now_ms();
    MPI_Waitall(2, j->sreq, MPI_STATUSES_IGNORE);
    g_rs[RS_WAIT] += now_ms() - t;
    g_rs[RS_WAIT_END] += now_ms() - t;
    free(buf[0]);
    free(buf[1]);
}

/* ------------------------------------------------------------------ frame statistics across ranks */

/* The counters pgi_render_progressive sums over frames (its stats_add), as one array. */
enum {
    FC_VIEW,
    FC_TRACE,
    FC_BUILD,
    FC_EST,
    FC_DIRECT,
    FC_TOTAL,
    FC_RT,
    FC_RADIUS,
    FC_EMITTED,
    FC_STORED,
    FC_PRAYS,
    FC_DISC,
    FC_PRIM,
    FC_SHADOW,
    FC_READS,
    FC_CONTRIB,
    FC_NODES,
    FC_CREATED,
    FC_PASSES
};
#define FC_COUNT (FC_PASSES + PGI_MAX_STAT_ENTRIES)

static void counters_of(const pgi_frame_stats *f, double *c) {
    memset(c, 0, FC_COUNT * sizeof *c);
    c[FC_VIEW] = f->view_ms, c[FC_TRACE] = f->trace_ms, c[FC_BUILD] = f->build_ms, c[FC_EST] = f->estimate_ms;
    c[FC_DIRECT] = f->direct_ms, c[FC_TOTAL] = f->total_ms, c[FC_RT] = f->rt_update_ms, c[FC_RADIUS] = f->radius_ms;
    c[FC_EMITTED] = (double)f->photons_emitted, c[FC_STORED] = (double)f->photons_stored;
    c[FC_PRAYS] = (double)f->photon_rays, c[FC_DISC] = (double)f->photon_paths_discarded;
    c[FC_PRIM] = (double)f->primary_rays, c[FC_SHADOW] = (double)f->shadow_rays;
    c[FC_READS] = (double)f->reads, c[FC_CONTRIB] = (double)f->contributing, c[FC_NODES] = (double)f->nodes_visited;
    c[FC_CREATED] = f->estimators_created;
    for (int i = 0; i < f->pass_count && i < PGI_MAX_STAT_ENTRIES; i++) c[FC_PASSES + i] = f->passes_ms[i].value;
}

static void counters_to(const double *c, pgi_frame_stats *f) {
    f->view_ms = c[FC_VIEW], f->trace_ms = c[FC_TRACE], f->build_ms = c[FC_BUILD], f->estimate_ms = c[FC_EST];
    f->direct_ms = c[FC_DIRECT], f->total_ms = c[FC_TOTAL], f->rt_update_ms = c[FC_RT], f->radius_ms = c[FC_RADIUS];
    f->photons_emitted = (uint64_t)c[FC_EMITTED], f->photons_stored = (uint64_t)c[FC_STORED];
    f->photon_rays = (uint64_t)c[FC_PRAYS], f->photon_paths_discarded = (uint64_t)c[FC_DISC];
    f->primary_rays = (uint64_t)c[FC_PRIM], f->shadow_rays = (uint64_t)c[FC_SHADOW];
    f->reads = (uint64_t)c[FC_READS], f->contributing = (uint64_t)c[FC_CONTRIB];
    f->nodes_visited = (uint64_t)c[FC_NODES], f->estimators_created = (int)c[FC_CREATED];
    for (int i = 0; i < f->pass_count && i < PGI_MAX_STAT_ENTRIES; i++) f->passes_ms[i].value = c[FC_PASSES + i];
}

static double g_fc[FC_COUNT]; /* this rank's frames, summed */

/* Gathers every rank's statistics on rank 0 (in rank order): rs[g_size][RS_COUNT], fc summed. */
static double *g_all_rs;
static double g_reduce_wall_ms, g_wall_ms;
static int64_t g_blocks, g_block;
static const char *g_unit;

static void gather_stats(double *fc_total) {
    g_rs[RS_RSS] = (double)pgi_memory_peak_rss();
    double send[RS_COUNT + FC_COUNT];
    memcpy(send, g_rs, sizeof g_rs);
    memcpy(send + RS_COUNT, g_fc, sizeof g_fc);
    double *all = g_rank == 0 ? malloc((size_t)g_size * sizeof send) : NULL;
    if (g_rank == 0 && !all) die("out of memory");
    MPI_Gather(send, RS_COUNT + FC_COUNT, MPI_DOUBLE, all, RS_COUNT + FC_COUNT, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (g_rank != 0) return;
    free(g_all_rs);
    g_all_rs = malloc((size_t)g_size * RS_COUNT * sizeof *g_all_rs);
    if (!g_all_rs) die("out of memory");
    if (fc_total) memset(fc_total, 0, FC_COUNT * sizeof *fc_total);
    for (int r = 0; r < g_size; r++) {
        memcpy(g_all_rs + (size_t)r * RS_COUNT, all + (size_t)r * (RS_COUNT + FC_COUNT), RS_COUNT * sizeof(double));
        if (fc_total)
            for (int i = 0; i < FC_COUNT; i++) fc_total[i] += all[(size_t)r * (RS_COUNT + FC_COUNT) + RS_COUNT + i];
    }
    free(all);
}

static void print_summary(void) {
    if (g_rank != 0 || g_quiet || !g_all_rs) return;
    char line[4096];
    int n = snprintf(line, sizeof line, "photongi-mpi: %d rank%s, %" PRId64 " blocks of %" PRId64 " %s, %.0f ms",
                     g_size, g_size == 1 ? "" : "s", g_blocks, g_block, g_unit, g_wall_ms);
    for (int r = 0; r < g_size && n < (int)sizeof line - 200; r++) {
        const double *s = g_all_rs + (size_t)r * RS_COUNT;
        n += snprintf(line + n, sizeof line - (size_t)n,
                      "; rank %d: %.0f %s, busy %.0f ms, wait %.0f ms (r0 %.0f, end %.0f), reduce %.0f ms, sent %.1f "
                      "MiB, rss %.0f MiB",
                      r, s[RS_ITEMS], g_unit, s[RS_BUSY], s[RS_WAIT], s[RS_WAIT_R0], s[RS_WAIT_END], s[RS_REDUCE],
                      s[RS_SENT] / 1048576.0, s[RS_RSS] / 1048576.0);
    }
    fprintf(stderr, "%s\n", line);
}

/* ------------------------------------------------------------------ render --progressive */

static void send_r0(job *j, float r0);

static void frame_progress(void *user, const pgi_progress *p) {
    job *j = user;
    /* frame 0's radius, known from its "build" pass on (given: from the start), is everyone's r0 */
    if (g_rank == 0 && j->in_frame0 && !j->have_r0 && p->radius > 0.f && g_size > 1) send_r0(j, p->radius);
    if (g_rank == 0) master_poll(j);
    else {
        worker_poll(j);
        /* the last passes of the unit's last frame: rank 0 may deal the next unit now (TAG_SOON) */
        if (!j->soon_sent && j->cur_frame == j->unit_last && strcmp(p->pass, "build") == 0) {
            MPI_Send(NULL, 0, MPI_BYTE, 0, TAG_SOON, MPI_COMM_WORLD);
            j->soon_sent = 1;
        }
    }
    if (j->user_progress) {
        pgi_progress q = *p;
        q.frame = (int)(j->items_done < j->items ? j->items_done : j->items - 1);
        q.frames = (int)j->items;
        q.elapsed_ms = now_ms() - j->t0;
        j->user_progress(j->user_progress_user, &q);
    }
}

static void add_frame_stats(job *j, const pgi_frame_stats *fs) {
    double c[FC_COUNT];
    counters_of(fs, c);
    for (int i = 0; i < FC_COUNT; i++) g_fc[i] += c[i];
}

/* Rank 0: frame 0's radius to every rank, as soon as it is known (from frame 0's progress). */
static void send_r0(job *j, float r0) {
    double t = now_ms();
    MPI_Bcast(&r0, 1, MPI_FLOAT, 0, MPI_COMM_WORLD);
    g_rs[RS_REDUCE] += now_ms() - t;
    j->r0 = r0;
    j->have_r0 = 1;
}

/* A worker: r0 from rank 0 (the first frame asks for it once its photons are traced; a worker
 * dealt no frame takes part at the end). */
static float receive_r0(void *user) {
    job *j = user;
    if (!j->have_r0) {
        double t = now_ms();
        float r0 = 0.f;
        MPI_Bcast(&r0, 1, MPI_FLOAT, 0, MPI_COMM_WORLD);
        g_rs[RS_WAIT] += now_ms() - t;
        g_rs[RS_WAIT_R0] += now_ms() - t;
        j->r0 = r0;
        j->have_r0 = 1;
    }
    return j->r0;
}

/* Progressive frame k > 0 into j->frame: a worker's first frame traces its photons before it
 * waits for r0 (pgi_progressive_frame_await_r0). */
static pgi_status render_frame(job *j, int64_t k) {
    pgi_frame_stats fs;
    j->cur_frame = k;
    pgi_status st = j->have_r0 ? pgi_progressive_frame(j->r, &j->d, j->r0, (int)k, &j->frame, &fs)
                               : pgi_progressive_frame_await_r0(j->r, &j->d, receive_r0, j, (int)k, &j->frame, &fs);
    if (st) return st;
    const size_t values = (size_t)fs.width * (size_t)fs.height * 3;
    if (!j->values) j->values = values;
    if (values != j->values) return PGI_ERR_INVALID_ARG; /* cannot happen: one desc */
    add_frame_stats(j, &fs);
    return PGI_OK;
}

static pgi_status frames_work(job *j, int64_t b, double **sum) {
    const int64_t k0 = b * j->block, n = block_items(j, b);
    for (int64_t k = k0; k < k0 + n; k++) {
        if (k == 0) continue; /* rank 0 rendered it first (its radius is everyone's r0) */
        pgi_status st = render_frame(j, k);
        if (st) return st;
        if (!*sum) *sum = alloc_sum(j);
        pgi_block_sum_add(*sum, j->frame.rgb, j->values, k == k0);
    }
    return PGI_OK;
}

/* One frame of a split block into j->frame (frame 0 is rank 0's, rendered first). */
static pgi_status frame_work(job *j, int64_t k) { return render_frame(j, k); }

static pgi_status mpi_progressive(pgi_renderer *r, const pgi_render_desc *in, int frames, pgi_image *out,
                                  pgi_frame_stats *stats) {
    job j;
    memset(&j, 0, sizeof j);
    j.r = r;
    j.d = *in;
    j.user_progress = in->progress;
    j.user_progress_user = in->progress_user;
    j.d.progress = frame_progress;
    j.d.progress_user = &j;
    j.items = frames;
    j.block = PGI_PROGRESSIVE_BLOCK;
    j.nblocks = (frames + j.block - 1) / j.block;
    j.work = frames_work;
    j.work_frame = frame_work;
    /* the last 2R blocks frame by frame (alone: none) */
    j.split_from = g_size == 1 ? j.nblocks : j.nblocks > 2 * g_size ? j.nblocks - 2 * g_size : 0;
    int who = begin_scene(0, pgi_renderer_scene(r));
    if (who >= 0) return peer_failed(who);
    j.t0 = now_ms();
    g_block = j.block;
    g_blocks = j.nblocks;
    g_unit = "frames";
    /* Frame 0 on rank 0: it resolves r0, which every other frame needs. The workers are dealt their
       first units before it and trace their first frame's photons meanwhile; rank 0 broadcasts r0 as
       soon as frame 0 has chosen it (frame_progress), before the frame ends. */
    int w = 0, h = 0;
    if (g_rank == 0) {
        master_begin(&j, 1);
        double t = now_ms(), served = g_rs[RS_REDUCE];
        j.in_frame0 = 1;
        pgi_status st = pgi_progressive_frame(r, &j.d, 0.f, 0, &j.frame, &j.first);
        j.in_frame0 = 0;
        if (st) die("frame 0: %s", *pgi_last_error() ? pgi_last_error() : pgi_status_string(st));
        g_rs[RS_BUSY] += now_ms() - t - (g_rs[RS_REDUCE] - served);
        if (!j.have_r0) send_r0(&j, j.first.radius); /* alone, or no pass reported it */
        if (j.r0 != j.first.radius)
            die("frame 0's radius %g is not the one broadcast (%g)", (double)j.first.radius, (double)j.r0);
        w = j.first.width;
        h = j.first.height;
        add_frame_stats(&j, &j.first);
        j.values = 3 * (size_t)w * (size_t)h;
        j.total = calloc(j.values, sizeof *j.total);
        double *own0 = pool_get(&j);
        if (!j.total) die("out of memory for the %dx%d total", w, h);
        pgi_block_sum_add(own0, j.frame.rgb, j.values, 1);
        master_run(&j, own0);
    } else {
        worker_run(&j);
        receive_r0(&j); /* a worker dealt no frame (more ranks than frames) */
    }
    double fc[FC_COUNT];
    double tr = now_ms();
    gather_stats(g_rank == 0 ? fc : NULL);
    g_reduce_wall_ms = now_ms() - tr;
    g_wall_ms = now_ms() - j.t0;
    pgi_image_free(&j.frame);
    if (g_rank != 0) return PGI_OK;
    if (!out->rgb || out->width != w || out->height != h) {
        pgi_image_free(out);
        out->rgb = malloc(j.values * sizeof(float));
        if (!out->rgb) die("out of memory for the image");
        out->width = w;
        out->height = h;
    }
    pgi_block_sum_mean(j.total, NULL, j.values, (uint64_t)frames, out->rgb);
    free(j.total);
    /* the stats of pgi_render_progressive: counters summed over every frame, the rest frame 0's */
    pgi_frame_stats fs = j.first;
    counters_to(fc, &fs);
    fs.frames = frames;
    fs.radius = pgi_progressive_radius(j.r0, frames - 1);
    if (frames > 1) fs.settings.jitter = in->jitter;
    fs.memory_peak_rss = pgi_memory_peak_rss();
    if (stats) *stats = fs;
    print_summary();
    return PGI_OK;
}

/* ------------------------------------------------------------------ reference */

static pgi_status samples_work(job *j, int64_t b, double **sump) {
    double *sum = *sump;
    memset(sum, 0, j->values * sizeof *sum);
    const int64_t s0 = b * j->block, n = block_items(j, b);
    for (int64_t s = s0; s < s0 + n; s++) {
        pgi_status st = pgi_reference_sampler_add(j->sampler, j->n0 + (uint64_t)s, sum);
        if (st) return st;
        if (g_rank == 0) {
            master_poll(j);
            if (j->ref_progress) {
                /* nonzero: no more blocks are dealt; those dealt are finished and added */
                uint64_t done = (uint64_t)j->items_done + (uint64_t)(s - s0 + 1);
                if (j->ref_progress(j->ref_progress_user, done > (uint64_t)j->items ? (uint64_t)j->items : done,
                                    (uint64_t)j->items, now_ms() - j->t0))
                    j->stop_asked = 1;
            }
        } else worker_poll(j);
    }
    return PGI_OK;
}

static pgi_status mpi_reference(const pgi_scene *scene, const pgi_reference_desc *in, pgi_image *mean, uint64_t *spp) {
    job j;
    memset(&j, 0, sizeof j);
    pgi_status st = PGI_OK;
    if (in->spp < 1) st = PGI_ERR_INVALID_ARG;
    else st = pgi_reference_sampler_create(scene, in, &j.sampler);
    int w = 0, h = 0;
    pgi_reference_sampler_size(j.sampler, &w, &h);
    if (!st && g_rank == 0 && *spp > 0 && (!mean->rgb || mean->width != w || mean->height != h))
        st = PGI_ERR_INVALID_ARG;
    int who = begin_scene(st ? CLI_EXIT_FAILURE : 0, scene);
    if (st || who >= 0) {
        pgi_reference_sampler_destroy(j.sampler);
        return st ? st : peer_failed(who);
    }
    j.values = 3 * (size_t)w * (size_t)h;
    j.n0 = *spp;
    j.items = (int64_t)in->spp;
    j.block = PGI_REFERENCE_BLOCK;
    j.nblocks = (j.items + j.block - 1) / j.block;
    j.work = samples_work;
    j.split_from = j.nblocks; /* whole blocks only: a sample adds into its block's sum on its own */
    j.time_limit_ms = in->time_limit_s > 0.0 ? 1000.0 * in->time_limit_s : 0.0;
    j.ref_progress = in->progress;
    j.ref_progress_user = in->progress_user;
    j.t0 = now_ms();
    g_block = j.block;
    g_blocks = j.nblocks;
    g_unit = "samples";
    if (g_rank == 0) {
        j.total = malloc(j.values * sizeof *j.total);
        if (!j.total) die("out of memory for the %dx%d total", w, h);
        /* as pgi_reference_render: the mean so far times its samples */
        for (size_t i = 0; i < j.values; i++) j.total[i] = j.n0 > 0 ? (double)mean->rgb[i] * (double)j.n0 : 0.0;
        master_begin(&j, 0);
        master_run(&j, NULL);
    } else worker_run(&j);
    int64_t dealt = blocks_dealt(&j); /* rank 0: fewer than nblocks after --time */
    gather_stats(NULL);
    g_wall_ms = now_ms() - j.t0;
    pgi_reference_sampler_destroy(j.sampler);
    /* every rank learns the samples added: the caller's next call (a checkpoint's) goes on from them */
    uint64_t done = (uint64_t)j.items_done;
    MPI_Bcast(&done, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    if (g_rank != 0) {
        *spp = j.n0 + done;
        return PGI_OK;
    }
    g_blocks = dealt;
    if (*spp == 0) {
        pgi_image_free(mean);
        mean->rgb = malloc(j.values * sizeof(float));
        if (!mean->rgb) die("out of memory for the image");
        mean->width = w;
        mean->height = h;
    }
    pgi_block_sum_mean(j.total, NULL, j.values, j.n0 + done, mean->rgb);
    free(j.total);
    *spp = j.n0 + done;
    print_summary();
    return PGI_OK;
}

/* ------------------------------------------------------------------ stats JSON with "mpi" */

/* rank 0's value, on every rank */
static int agree(int value) {
    MPI_Bcast(&value, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return value;
}

static pgi_status write_stats(const pgi_frame_stats *fs, const char *path) {
    /* the library's JSON, with "mpi" added */
    char small[1];
    const size_t len = pgi_stats_json(fs, small, sizeof small);
    char *text = len ? malloc(len + 1) : NULL;
    if (text) pgi_stats_json(fs, text, len + 1);
    cJSON *root = text ? cJSON_Parse(text) : NULL;
    free(text);
    if (!root) return pgi_stats_write_json(fs, path);
    cJSON *m = cJSON_AddObjectToObject(root, "mpi");
    cJSON_AddNumberToObject(m, "ranks", g_size);
    cJSON_AddNumberToObject(m, "block", (double)g_block);
    cJSON_AddNumberToObject(m, "blocks", (double)g_blocks);
    cJSON_AddNumberToObject(m, "wall_ms", g_wall_ms);
    cJSON_AddNumberToObject(m, "stats_gather_ms", g_reduce_wall_ms);
    cJSON *per = cJSON_AddArrayToObject(m, "per_rank");
    static const char *const names[RS_COUNT] = {"blocks",       "frames",     "busy_ms",
                                                "wait_ms",      "wait_r0_ms", "wait_end_ms",
                                                "reduction_ms", "bytes_sent", "peak_rss_bytes"};
    for (int r = 0; g_all_rs && r < g_size; r++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "rank", r);
        for (int i = 0; i < RS_COUNT; i++) cJSON_AddNumberToObject(o, names[i], g_all_rs[(size_t)r * RS_COUNT + i]);
        cJSON_AddItemToArray(per, o);
    }
    char *out = cJSON_Print(root);
    cJSON_Delete(root);
    if (!out) return PGI_ERR_OOM;
    FILE *o = strcmp(path, "-") == 0 ? stdout : fopen(path, "wb");
    pgi_status st = PGI_OK;
    if (!o || fputs(out, o) < 0 || fputc('\n', o) == EOF) st = PGI_ERR_IO;
    if (o && o != stdout && fclose(o) != 0) st = PGI_ERR_IO;
    if (st) fprintf(stderr, "photongi-mpi: cannot write %s: %s\n", path, strerror(errno));
    free(out);
    return st;
}

/* ------------------------------------------------------------------ main */

/* Rank > 0: what the command printed, each line prefixed with the rank, on the real stderr. */
static void replay_capture(void) {
    if (!g_capture) return;
    fflush(stderr);
    rewind(g_capture);
    char line[2048];
    while (fgets(line, sizeof line, g_capture))
        dprintf(g_real_err, "photongi-mpi: rank %d of %d: %s%s", g_rank, g_size, line, strchr(line, '\n') ? "" : "\n");
}

/* All ranks on one machine (Open MPI's mpirun says so: every rank local), or one process without a
 * launcher: Open MPI's shared-memory path (pml ob1, btl vader) instead of UCX, whose start-up
 * probing of network devices costs 0.2 to 0.4 s a run here (docs/distributed.md, "Start").
 * An explicit choice (OMPI_MCA_pml, which mpirun --mca pml X sets) is kept; under another
 * launcher, or across machines, nothing changes. */
static void prefer_shared_memory(void) {
    if (getenv("OMPI_MCA_pml") || getenv("PHOTONGI_MPI_KEEP_PML")) return;
    const char *size = getenv("OMPI_COMM_WORLD_SIZE"), *local = getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
    int one_machine;
    if (size && local) one_machine = strcmp(size, local) == 0;
    else
        one_machine = !size && !local && !getenv("PMIX_RANK") && !getenv("PMI_RANK") && !getenv("SLURM_PROCID") &&
                      !getenv("OMPI_COMM_WORLD_RANK");
    if (one_machine) setenv("OMPI_MCA_pml", "ob1", 0);
}

int main(int argc, char **argv) {
    int provided;
    signal(SIGXFSZ, SIG_IGN); /* a file size limit fails a write (reported), not the process */
    prefer_shared_memory();
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    g_codes = calloc((size_t)g_size, sizeof *g_codes);
    if (!g_codes) {
        fprintf(stderr, "photongi-mpi: out of memory\n");
        MPI_Abort(MPI_COMM_WORLD, 1);
    }
    g_real_err = dup(2);
    if (g_real_err < 0) g_real_err = 2;
    if (g_rank > 0) {
        fflush(stdout);
        int null = open("/dev/null", O_WRONLY);
        if (null >= 0) {
            dup2(null, 1);
            close(null);
        }
        g_capture = tmpfile();
        if (g_capture) {
            fflush(stderr);
            dup2(fileno(g_capture), 2);
        }
    }
    for (int i = 2; i < argc; i++)
        if (strcmp(argv[i], "-q") == 0 || strcmp(argv[i], "--quiet") == 0) g_quiet = 1;
    static pgi_cli_backend be = {0, mpi_progressive, mpi_reference, write_stats, agree};
    be.writer = g_rank == 0;
    pgi_cli_backend_now = &be;
    int rc;
    if (argc < 2) {
        fputs(k_help, stderr);
        rc = CLI_EXIT_USAGE;
    } else if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "help") == 0) {
        if (argc > 2 && strcmp(argv[1], "help") == 0) {
            char help[] = "--help";
            char *args[] = {help, NULL};
            if (strcmp(argv[2], "render") == 0) rc = pgi_cmd_render(1, args);
            else if (strcmp(argv[2], "reference") == 0) rc = pgi_cmd_reference(1, args);
            else {
                fprintf(stderr, "photongi-mpi help: unknown help topic '%s'; the topics are render, reference\n",
                        argv[2]);
                rc = CLI_EXIT_USAGE;
            }
        } else {
            fputs(k_help, stdout);
            rc = 0;
        }
    } else if (strcmp(argv[1], "--version") == 0) {
        printf("photongi-mpi %s\n", pgi_version());
        rc = 0;
    } else if (strcmp(argv[1], "render") == 0) rc = pgi_cmd_render(argc - 2, argv + 2);
    else if (strcmp(argv[1], "reference") == 0) rc = pgi_cmd_reference(argc - 2, argv + 2);
    else {
        fprintf(stderr, "photongi-mpi: unknown command '%s' (photongi-mpi runs render and reference)\n\n%s", argv[1],
                k_help);
        rc = CLI_EXIT_USAGE;
    }
    /* what rank 0 printed must have reached standard output (not /dev/full, a closed pipe) */
    if ((fflush(stdout) != 0 || ferror(stdout)) && rc == 0 && g_rank == 0) {
        fprintf(stderr, "photongi-mpi: cannot write to standard output\n");
        rc = CLI_EXIT_FAILURE;
    }
    fflush(stderr);
    int final = rc;
    if (!g_entered) {
        int who = begin_scene(rc ? rc : -1, NULL);
        final = who < 0 ? 0 : g_codes[who];
        if (g_rank > 0 && who == g_rank && g_codes[0] <= 0) replay_capture();
    } else {
        /* entered: the work was done (or refused because a rank failed before it) */
        int who = -1;
        for (int i = 0; i < g_size; i++)
            if (g_codes[i] > 0) {
                who = i;
                break;
            }
        if (who >= 0) {
            final = g_codes[who];
            if (g_rank > 0 && who == g_rank && g_codes[0] <= 0 && !g_mismatch) replay_capture();
        } else if (rc && g_rank > 0) replay_capture(); /* after the work: this rank's own failure */
    }
    if (g_capture) fclose(g_capture);
    free(g_codes);
    free(g_all_rs);
    MPI_Finalize();
    return final;
}
