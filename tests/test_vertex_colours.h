/* Vertex colours for a loaded scene, shared by the tests that check every path multiplies them
 * into the albedo alike (test_determinism, test_gpu_frame, test_gpu_trace). Header only. */
#ifndef PGI__TEST_VERTEX_COLOURS_H
#define PGI__TEST_VERTEX_COLOURS_H

#include <math.h>
#include <stdlib.h>

#include "scene/scene_internal.h"

/* Gives a loaded scene vertex colours (linear, in [0.1, 1]) that change from vertex to vertex,
 * strongly and in each channel on its own: a fraction of the position scaled differently per
 * channel (what a coloured mesh file loads into pgi_scene.col). Called before a renderer or GPU
 * scene is made of it. */
static inline void tu_add_vertex_colours(pgi_scene *s) {
    free(s->col);
    s->col = malloc(3 * (s->nverts ? s->nverts : 1) * sizeof(float));
    if (!s->col) abort();
    for (size_t v = 0; v < s->nverts; v++) {
        const float *p = s->pos + 3 * v;
        for (int c = 0; c < 3; c++) {
            const float t = 1.3f * p[c] + 0.7f * p[(c + 1) % 3] + 0.37f * (float)c;
            s->col[3 * v + c] = 0.1f + 0.9f * (t - floorf(t));
        }
    }
}

#endif
