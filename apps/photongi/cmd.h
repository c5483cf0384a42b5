/* Commands implemented outside main.c (one file each). Each returns the
 * process exit status (cli.h): 0 success, 2 usage error, 1 failure. */
#ifndef PGI__CLI_CMD_H
#define PGI__CLI_CMD_H

#include <stdint.h>
#include <string.h>

#include "photongi/photongi.h"
#include "photongi/reference.h"

int pgi_cmd_render(int argc, char **argv);
int pgi_cmd_reference(int argc, char **argv);
int pgi_cmd_compare(int argc, char **argv);
int pgi_cmd_study(int argc, char **argv);

/* Where `render` runs its frames and `reference` its samples: NULL (photongi) in this process;
 * photongi-mpi (apps/mpi) sets a backend that deals them to MPI ranks. The commands parse and
 * check the command line, load the scene and resolve the settings as always, then hand the work
 * to the backend on every rank; only a `writer` (rank 0) writes the outputs and prints. */
typedef struct pgi_cli_backend {
    int writer; /* this process writes the image, the stats and the sidecar, and prints the summary */
    /* the frames of `render` (--progressive N, N >= 1): as pgi_render_progressive */
    pgi_status (*progressive)(pgi_renderer *r, const pgi_render_desc *desc, int frames, pgi_image *out,
                              pgi_frame_stats *stats);
    /* the samples of `reference`: as pgi_reference_render */
    pgi_status (*reference)(const pgi_scene *scene, const pgi_reference_desc *desc, pgi_image *mean, uint64_t *spp);
    /* writes the render's stats JSON (the library's, plus what the backend adds) */
    pgi_status (*write_stats)(const pgi_frame_stats *stats, const char *path);
    /* the writer's value, returned on every process (whether a reference goes on after a checkpoint) */
    int (*agree)(int value);
} pgi_cli_backend;

extern const pgi_cli_backend *pgi_cli_backend_now;

/* What two references' sidecars differ in ("scenes", "sizes", ...), or NULL when they were made alike
 * but for seed and samples. */
static inline const char *cli_reference_differs(const pgi_reference_meta *a, const pgi_reference_meta *b) {
    return strcmp(a->scene, b->scene)                       ? "scenes"
           : a->width != b->width || a->height != b->height ? "sizes"
           : a->bounces != b->bounces                       ? "bounces"
           : a->camera != b->camera || a->has_view != b->has_view ||
                   (a->has_view && memcmp(&a->view, &b->view, sizeof a->view) != 0)
               ? "cameras"
           : a->jitter != b->jitter     ? "jitter settings"
           : a->specular != b->specular ? "specular models"
                                        : NULL;
}

/* A reference's own noise from one of its halves (cmd_compare.c): REF is the mean of n samples, HALF
 * the mean of n_half of them alone (both linear, at the same scale); the other part is
 * (n REF - n_half HALF) / (n - n_half), and the tone-mapped squared difference of the two parts times
 * n_half (n - n_half) / n^2 is about REF's own mean squared error against the truth (for equal halves,
 * a quarter of their difference). 0 when it cannot be computed. */
double cli_halves_noise_mse(const pgi_image *ref, uint64_t n, const pgi_image *half, uint64_t n_half, float exposure);

/* Where a reference REF.exr keeps such a half: REF-half.exr, with its sidecar ('photongi study' writes
 * both); 0 when the name does not fit. */
int cli_reference_half_path(const char *ref, char *out, size_t cap);

#endif
