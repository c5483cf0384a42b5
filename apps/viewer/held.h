/* How long each movement key of photongi-view was held, by the wall clock: from its press to its
 * release, or to now while it is down, whatever the frame rate. A tap during a slow frame counts
 * its own duration (not the frame's), and every press of a frame counts. Header only, no SDL, so
 * that tests/test_viewer_held.c checks it with made-up times. */
#ifndef PGI__VIEWER_HELD_H
#define PGI__VIEWER_HELD_H

#define HELD_KEYS 12

typedef struct held_keys {
    int down[HELD_KEYS];
    double since[HELD_KEYS]; /* down: when the time not yet taken starts, seconds */
    double held[HELD_KEYS];  /* seconds held and not yet taken */
} held_keys;

/* Key k pressed at time t (a key repeat of a held key changes nothing). */
static inline void held_press(held_keys *h, int k, double t) {
    if (k < 0 || k >= HELD_KEYS || h->down[k]) return;
    h->down[k] = 1;
    h->since[k] = t;
}

/* Key k released at time t: its time since the press (or the last take) is kept for the next take. */
static inline void held_release(held_keys *h, int k, double t) {
    if (k < 0 || k >= HELD_KEYS || !h->down[k]) return;
    if (t > h->since[k]) h->held[k] += t - h->since[k];
    h->down[k] = 0;
}

/* The seconds each key was held since the last take, up to `now` for the keys still down, into
 * out[HELD_KEYS]; returns 1 when any key moved or is down. */
static inline int held_take(held_keys *h, double now, double *out) {
    int any = 0;
    for (int k = 0; k < HELD_KEYS; k++) {
        if (h->down[k]) {
            if (now > h->since[k]) h->held[k] += now - h->since[k];
            h->since[k] = now;
            any = 1;
        }
        out[k] = h->held[k];
        any |= h->held[k] > 0.0;
        h->held[k] = 0.0;
    }
    return any;
}

#endif
